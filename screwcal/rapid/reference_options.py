"""The RAPID instructions, functions and data types that RobotWare options bring, one table per
option, each from the option's own manual (named in `manual`). Rows as in
`reference_instructions` (`* *`: a routine known by name, its arguments not checked);
`types` is a list of names. A name may belong to several options
(RAPID Message Queue comes with PC Interface, FlexPendant Interface and Multitasking).

`rapid check --options` selects which of these the controller has; a name that only an option
brings is reported with the option's name when that option is not selected.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Option:
    key: str  # what --options takes
    title: str  # as RobotWare names it, with its number
    manual: str  # where its instructions are described
    instructions: str = ""
    functions: str = ""
    types: str = ""


_RMQ = """
IRMQMessage 2 Single|SingleSafe
RMQEmptyQueue 0
RMQFindSlot 2
RMQGetMessage 1
RMQGetMsgData 2
RMQGetMsgHeader 1 Header SenderId UserDef
RMQReadWait 1 TimeOut
RMQSendMessage 2 UserDef
RMQSendWait 4 UserDef TimeOut
"""
_APP = "Application manual - Controller software IRC5 (3HAC050798-001)"

OPTIONS = (
    Option("socket-messaging", "Socket Messaging (616-1 PC Interface)", _APP + ", Socket Messaging",
           """
SocketAccept 2 ClientAddress Time
SocketBind 3
SocketClose 1
SocketConnect 3 Time
SocketCreate 1 UDP
SocketListen 1
SocketReceive 1 Str|RawData|Data ReadNoOfBytes NoRecBytes Time
SocketReceiveFrom 3 Str|RawData|Data ReadNoOfBytes NoRecBytes Time
SocketSend 1 Str|RawData|Data NoOfBytes
SocketSendTo 3 Str|RawData|Data NoOfBytes
""", """
SocketGetStatus 1
SocketPeek 1
""", "socketdev socketstatus"),
    Option("pc-interface", "PC Interface (616-1)", _APP + ", RAPID Message Queue",
           _RMQ + "SCWrite 2 TaskRef|TaskName ToNode\n", "RMQGetSlotName 1\n",
           "rmqheader rmqmessage rmqslot"),
    Option("flexpendant-interface", "FlexPendant Interface (617-1)",
           _APP + ", RAPID Message Queue", _RMQ + "UIShow 2 InitCmd InstanceID Status NoCloseBtn\n",
           "RMQGetSlotName 1\n", "rmqheader rmqmessage rmqslot uishownum"),
    Option("multitasking", "Multitasking (623-1)", _APP + ", Multitasking",
           _RMQ + "WaitSyncTask 2 InPos TimeOut\n", """
RMQGetSlotName 1
TaskIsActive 1
TaskIsExecuting 1
""", "rmqheader rmqmessage rmqslot syncident tasks"),
    Option("multimove", "MultiMove (604-1, 604-2)",
           "Application manual - MultiMove (3HAC050961-001)", """
SyncMoveOff 1 TimeOut
SyncMoveOn 2 TimeOut
SyncMoveResume 0
SyncMoveSuspend 0
SyncMoveUndo 0
WaitSyncTask 2 InPos TimeOut
""", "IsSyncMoveOn 0\nTasksInSync 1\n", "identno syncident tasks"),
    Option("collision-detection", "Collision Detection (613-1)", _APP + ", Collision Detection",
           "MotionSup 0 On|Off TuneValue\n"),
    Option("world-zones", "World Zones (608-1)", _APP + ", World Zones", """
WZBoxDef 3 Inside|Outside
WZCylDef 4 Inside|Outside
WZDisable 1
WZDOSet 4 Temp|Stat Inside|Before
WZEnable 1
WZFree 1
WZHomeJointDef 3 Inside|Outside
WZLimJointDef 3 Inside|Outside
WZLimSup 2 Temp|Stat
WZSphDef 3 Inside|Outside
""", "", "shapedata wzstationary wztemporary"),
    Option("path-offset", "Path Offset (612-1)", _APP + ", Path Offset", """
CorrClear 0
CorrCon 1
CorrDiscon 1
CorrWrite 2
""", "CorrRead 0\n", "corrdescr"),
    Option("path-recovery", "Path Recovery (611-1)", _APP + ", Path Recovery", """
PathRecMoveBwd 0 ID ToolOffs Speed
PathRecMoveFwd 0 ID ToolOffs Speed
PathRecStart 1
PathRecStop 0 Clear
""", "PathRecValidBwd 0 ID\nPathRecValidFwd 0 ID\n", "pathrecid"),
    Option("independent-axes", "Independent Axes (610-1)", _APP + ", Independent Axes", """
IndAMove 3 ToAbsPos|ToAbsNum Ramp
IndCMove 3 Ramp
IndDMove 4 Ramp
IndReset 2 RefPos|RefNum|Short|Fwd|Bwd|Old Ramp
IndRMove 3 ToRelPos|ToRelNum Short|Fwd|Bwd Ramp
""", "IndInpos 2\nIndSpeed 2 InSpeed|ZeroSpeed\n"),
    Option("conveyor-tracking", "Conveyor Tracking (606-1)",
           "Application manual - Conveyor tracking (3HAC050991-001)", """
DropWObj 1
WaitWObj 1 RelDist MaxTime
""", "", "cnvcmd"),
    Option("sensor-interface", "Sensor Interface (628-1)", _APP + ", Sensor Interface", """
IVarValue 3 ReportAtTime SBLength
ReadBlock 4 Time
SenDevice 3 Close
SiClose 1
SiConnect 1 NoStop
SiGetCyclic 3
SiSetCyclic 3
WaitSensor 1 RelDist PredTime MaxTime
WriteBlock 4
WriteVar 3 TaskRef|TaskName
""", "ReadVar 3 TaskRef|TaskName\n", "sensor sensorstate"),
    Option("egm", "Externally Guided Motion (689-1)",
           "Application manual - Externally Guided Motion (3HAC073319-001)", """
EGMActJoint 1 StreamStart Tool WObj TLoad J1 J2 J3 J4 J5 J6 J7 LpFilter SampleRate
    MaxPosDeviation MaxSpeedDeviation
EGMActMove 2 SampleRate
EGMActPose 5 StreamStart Tool WObj TLoad X Y Z Rx Ry Rz LpFilter SampleRate MaxPosDeviation
    MaxSpeedDeviation
EGMGetId 1
EGMMoveC 6 WObj TLoad
EGMMoveL 5 WObj TLoad
EGMReset 1
EGMRunJoint 2 NoWaitCond J1 J2 J3 J4 J5 J6 J7 CondTime RampInTime RampOutTime Offset PosCorrGain
EGMRunPose 2 NoWaitCond X Y Z Rx Ry Rz CondTime RampInTime RampOutTime Offset PosCorrGain
EGMSetupAI * *
EGMSetupAO * *
EGMSetupGI * *
EGMSetupLTAPP * *
EGMSetupUC 4 Joint|Pose|PathCorr APTR|LATR CommTimeout
EGMStop 2 RampOutTime
EGMStreamStart 1 SampleRate
EGMStreamStop 1
EGMWaitCond 1
""", "EGMGetState 1\n", "egm_minmax egmframetype egmident egmstate egmstopmode"),
    Option("softmove", "SoftMove (885-1)", "Application manual - SoftMove (3HAC050998-001)", """
CSSAct 2 MechUnit RefOrient Stiffness StiffnessNonSoftDir AllowMove Ramp
CSSDeactMoveL 3 WObj
CSSForceOffsetAct 2 ForceOffset ForceChange|DampingGain
CSSForceOffsetDeact 0
CSSOffsetTune 2
""", "", "css_offset_dir css_refframe css_soft_dir"),
    Option("arc", "RobotWare Arc (633-4)",
           "Application manual - Arc and Arc Sensor (3HAC050988-001)", """
ArcC 7 On|Off ID Weave Track SeamName Time|T1 T2 T3 T4 T5 T6 T7 T8 WObj Corr TLoad
ArcC1 7 ID Weave Track Time WObj Corr TLoad
ArcC2 7 ID Weave Track Time WObj Corr TLoad
ArcCEnd 7 ID Weave Track Time WObj Corr TLoad
ArcCStart 7 ID Weave Track SeamName Time WObj Corr TLoad
ArcKill 0
ArcL 6 On|Off ID Weave Track SeamName Time|T1 T2 T3 T4 T5 T6 T7 T8 WObj Corr TLoad
ArcL1 6 ID Weave Track Time WObj Corr TLoad
ArcL2 6 ID Weave Track Time WObj Corr TLoad
ArcLEnd 6 ID Weave Track Time WObj Corr TLoad
ArcLStart 6 ID Weave Track SeamName Time WObj Corr TLoad
ArcMoveAbsJ 4 ID NoEOffs T WObj TLoad
ArcMoveExtJ 3 ID T
ArcRefresh 0
ArcRepL 3 ID Weave Track Time WObj
""", "", "arcdata seamdata trackdata weavedata welddata"),
    Option("bullseye", "BullsEye (TCP check of arc welding torches)",
           "Application manual - BullsEye (3HAC050989-001)", """
BECheckTcp * *
BERefPointer * *
BESetupToolJ * *
BETcpExtend * *
BEUpdateTcp * *
""", "", "be_device be_scan be_tooldesign"),
    Option("production-manager", "Production Manager (RobotWare Arc)",
           "Application manual - Arc and Arc Sensor (3HAC050988-001), Production Manager",
           "", "", "menudata partdata stationdata"),
    Option("safemove", "Electronic Position Switches / SafeMove (810-1, 810-2)",
           "Application manual - SafeMove (3HAC052610-001)", "SoftwareSync 0\n"),
    Option("cap", "Continuous Application Platform (CAP)",
           "Application manual - Continuous Application Platform (3HAC050990-001)", """
CapC 7 Cent|Word ID Time Track Sup Inpos WObj Corr TLoad
CapL 6 Cent|Word ID Time Track Sup Inpos WObj Corr TLoad
CapCondSetDO 2
CapEquiDist 1
CapRefresh 0
ICap 2 Single
InitSuperv 0
RemoveSuperv 0
SetupSuperv 3 SupSpec
""", "", "capdata capspeeddata captestno captrackdata capweavedata supervtimeouts"),
    Option("spot", "RobotWare Spot", "Application manual - Spot servo (3HAC050992-001)", """
CalibL 5 ID WObj Conc
CalibJ 5 ID WObj Conc
ManServiceCalib 1
SetForce 2 Conc
SpotJ 5 InPos NoConc QuickRelease WObj
SpotL 5 InPos NoConc QuickRelease WObj
SpotML 5 Conc InPos QuickRelease WObj
""", "", "forcedata gundata smeqdata spotdata"),
    Option("servo-tool", "Servo Tool Control (Spot servo)",
           "Application manual - Spot servo (3HAC050992-001)", """
STCalib 2 ToolChg|TipChg|TipWear RetTipWear RetPosAdj PrePos InPos
STClose 1 RetThickness
STOpen 1 WaitZeroSpeed
STTune 3
STTuneReset 1
""", """
STCalcForce 2
STCalcTorque 2
STIsCalib 1 sguninit|sgunsynch
STIsClosed 1 RetThickness
STIsIndGun 1
STIsOpen 1
"""),
    Option("dispense", "RobotWare Dispense", "Application manual - Dispense (3HAC051007-001)", """
DispC 7 D|Start|On|Off ID T WObj Corr TLoad
DispL 6 D|Start|On|Off ID T WObj Corr TLoad
""", "", "beaddata equipdata"),
    Option("paint", "RobotWare Paint", "Application manual - Paint (3HAC052052-001)", """
PaintC 6 ID T WObj
PaintL 5 ID T WObj
SetBrush 1 X|Y|Z
SetBrushFac 1
""", "", "brushdata"),
    Option("integrated-vision", "Integrated Vision (1520-1)",
           "Application manual - Integrated Vision (3HAC067707-001)", """
AliasCamera 2
CamFlush 1
CamGetParameter 2 Num|Bool|Str SlotNo MaxTime
CamGetResult 2 SlotNo Time|MaxTime
CamLoadJob 2 KeepTargets MaxTime
CamReqImage 1 SceneId KeepTargets AwaitComplete
CamSetExposure 1 ExposureTime Brightness Contrast
CamSetParameter 2 Num|Bool|Str SlotNo MaxTime
CamSetProgramMode 1
CamSetRunMode 1
CamStartLoadJob 2 KeepTargets
CamWaitLoadJob 1
""", """
CamGetExposure 1 ExposureTime Brightness Contrast
CamGetLoadedJob 1
CamGetName 1
CamNumberOfResults 1 SceneId
""", "cameradev cameratarget"),
    Option("advanced-robot-motion", "Advanced robot motion (687-1)",
           "Application manual - Advanced robot motion (3HAC050961-001)", """
ContactL 4 DesiredTorque|Speed ID WObj
FricIdEvaluate 2 MechUnit BestFit
FricIdInit 0
FricIdSetFricLevels 2 MechUnit
""", "", "fricidlevel"),
)

# What a calibration cell's controller has (a socket server talks to the measuring PC; the
# robot may share its task with others): the default of `rapid check --options`.
CALIBRATION_CELL = ("socket-messaging", "pc-interface", "multitasking", "collision-detection",
                    "world-zones")
