"""The instructions of the RobotWare base system (RobotWare 6.13 / 7), from ABB's Technical
reference manual - RAPID Instructions, Functions and Data types (3HAC050917-001), chapter 1
"Instructions": each row is the section of that chapter titled with the instruction's name.

A row: `Name  positional  optional...`. `positional` is the number of required arguments (a
`min-max` range where the manual has alternatives between required ones); each optional
argument is written without its backslash, and alternatives of one another (`[\\V] | [\\T]`)
are joined with `|` (giving two of one group is an error). An indented line continues the
row above it. Four rows are service routines every system installs in each task from its own
hidden modules, named in the manual beside the chapter: LoadIdentify, BrakeCheck,
CyclicBrakeCheck and ServiceInfo (Operating manual - IRC5, service routines), and Linked_m_exe,
called by the LINKEDM.sys module RobotStudio puts in a new system's SYSMOD. Instructions of
RobotWare options are in `reference_options`.
"""

INSTRUCTIONS = """
BrakeCheck 0
CyclicBrakeCheck 0
IOActivate 2
IODeactivate 2
Linked_m_exe 0
LoadIdentify 0
MoveCAO 7 ID T WObj TLoad
MoveCGO 7 ID T WObj TLoad
MoveJAO 6 ID T WObj TLoad
MoveJGO 6 ID T WObj TLoad
MoveLAO 6 ID T WObj TLoad
MoveLGO 6 ID T WObj TLoad
SafetyControllerSyncRequest 0
ServiceInfo 0
StepBwdPath 2
AccSet 2 FinePointRamp
ActEventBuffer 0
ActUnit 1
Add 2
AliasIO 2
AliasIOReset 1
BitClear 2
BitSet 2
BookErrNo 1
Break 0
CallByVar 2
CancelLoad 1
CheckProgRef 0
CirPathMode 0 PathFrame|ObjectFrame|CirPointOri|Wrist45|Wrist46|Wrist56|AuxJoints
Clear 1
ClearIOBuff 1
ClearPath 0
ClearRawBytes 1 FromIndex
ClkReset 1
ClkStart 1
ClkStop 1
Close 1
CloseDir 1
ConfJ 0 On|Off
ConfL 0 On|Off
CopyFile 2
CopyRawBytes 4 NoOfBytes
DeactEventBuffer 0
DeactUnit 1
Decr 1
DitherAct 1 MechUnit Axis Level
DitherDeact 0
EOffsOff 0
EOffsOn 1 ExeP
EOffsSet 1
EraseModule 1
ErrLog 6 W|I
ErrRaise 3-8 W
ErrWrite 2 W|I RL2 RL3 RL4
ExitCycle 0
GetDataVal 2 Object Block|TaskRef|TaskName Hidden
GetSysData 1 TaskRef|TaskName ObjectName
GetTrapData 1
GripLoad 1
HollowWristReset 0
IDelete 1
IDisable 0
IEnable 0
IError 3 ErrorId
IncrLinked_m_exe 0
LoadIdentify 0
Incr 1
InvertDO 1
IOBusStart 1
IOBusState 2 Phys|Logic
IODisable 2
IOEnable 2
IPers 2 Single|SingleSafe
ISignalAI 6 Single|SingleSafe DPos|DNeg
ISignalAO 6 Single|SingleSafe DPos|DNeg
ISignalDI 3 Single|SingleSafe
ISignalDO 3 Single|SingleSafe
ISignalGI 2 Single|SingleSafe
ISignalGO 2 Single|SingleSafe
ISleep 1
ITimer 2 Single|SingleSafe
IWatch 1
Load 1 Dynamic FilePath File CheckRef
LoadId 3 PayLoad WObj ConfAngle SlowTest Accuracy
MakeDir 1
ManLoadIdProc 0 ParIdType MechUnit MechUnitName AxisNumber PayLoad ConfigAngle DeactAll
    AlreadyActive DefinedFlag DoExit
MechUnitLoad 3
MotionProcessModeSet 1
MoveAbsJ 4 Conc ID NoEOffs V|T Z Inpos WObj TLoad
MoveC 5 Conc ID V|T Z Inpos WObj Corr TLoad
MoveCDO 7 ID T WObj TLoad
MoveCSync 6 ID T WObj TLoad
MoveExtJ 3 Conc ID UseEOffs T Inpos
MoveJ 4 Conc ID V|T Z Inpos WObj TLoad
MoveJDO 6 ID T WObj TLoad
MoveJSync 5 ID T WObj TLoad
MoveL 4 Conc ID V|T Z Inpos WObj Corr TLoad
MoveLDO 6 ID T WObj TLoad
MoveLSync 5 ID T WObj TLoad
MToolRotCalib 3 XPos
MToolTCPCalib 7
Open 2 File Read|Write|Append Bin
OpenDir 2
PackDNHeader 3
PackRawBytes 3 Network Hex1|IntX|Float4|ASCII
PathAccLim 2 AccMax DecelMax
PathResol 1
PDispOff 0
PDispOn 2 Rot ExeP WObj
PDispSet 1
ProcerrRecovery 0 SyncOrgMoveInst|SyncLastMoveInst ProcSignal
PulseDO 1 High PLength
RaiseToUser 0 Continue|BreakOff ErrorNumber
ReadAnyBin 2 Time
ReadCfgData 3 ListNo
ReadErrData 4 Title Str1 Str2 Str3 Str4 Str5 RL2 RL3 RL4
ReadRawBytes 2 NoOfBytes Time
RemoveAllCyclicBool 0
RemoveCyclicBool 1
RemoveDir 1
RemoveFile 1
RenameFile 2
Reset 1
ResetAxisDistance 2
ResetAxisMoveTime 1
ResetPPMoved 0
ResetRetryCount 0
RestoPath 0
Rewind 1
Save 1 TaskRef|TaskName FilePath File
SaveCfgData 2
SearchC 6 Stop|PStop|SStop|Sup Flanks|PosFlank|NegFlank|HighLevel|LowLevel ID V|T WObj Corr TLoad
SearchExtJ 4 Stop|PStop|SStop|Sup Flanks|PosFlank|NegFlank|HighLevel|LowLevel ID UseEOffs T
SearchJ 5 Stop|PStop|SStop|Sup Flanks|PosFlank|NegFlank|HighLevel|LowLevel ID V|T WObj TLoad
SearchL 5 Stop|PStop|SStop|Sup Flanks|PosFlank|NegFlank|HighLevel|LowLevel ID V|T WObj Corr TLoad
Set 1
SetAllDataVal 2 TypeMod Object Hidden
SetAO 2
SetDataSearch 1 Object PersSym VarSym ConstSym InTask|InMod InRout GlobalSym|LocalSym
SetDataVal 2 Object Block|TaskRef|TaskName Hidden
SetDO 2 SDelay|Sync
SetGO 2 SDelay
SetLeadThrough 0 On|Off
SetSysData 1 ObjectName
SetupCyclicBool 2
SingArea 0 Wrist|LockAxis4|Off
SkipWarn 0
SoftAct 2 MechUnit Ramp
SoftDeact 0 Ramp
SpeedLimAxis 3
SpeedLimCheckPoint 1
SpeedRefresh 1
SpyStart 1
SpyStop 0
StartLoad 2 Dynamic FilePath File
StartMove 0 AllMotionTasks
StartMoveRetry 0
SToolRotCalib 4
SToolTCPCalib 7
Stop 0 NoRegain|AllMoveTasks
StopMove 0 Quick AllMotionTasks
StopMoveReset 0 AllMotionTasks
StorePath 0 KeepSync
SystemStopAction 0 Stop|StopBlock|Halt
TestSignDefine 4
TestSignReset 0
TextTabInstall 1
TPErase 0
TPReadDnum 2 MaxTime DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag
TPReadFK 7 MaxTime DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag
TPReadNum 2 MaxTime DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag
TPShow 1
TPWrite 1 Num|Bool|Pos|Orient|Dnum
TriggC 6 Conc ID T T2 T3 T4 T5 T6 T7 T8 Inpos WObj Corr TLoad
TriggCheckIO 5-6 Start|Time StopMove
TriggDataCopy 2
TriggDataReset 1
TriggEquip 4 Start DOp|GOp|AOp|ProcID Inhib InhibSetValue InhibStatus
TriggInt 3 Start|Time Inhib InhibSetValue InhibStatus
TriggIO 3 Start|Time DOp|GOp|AOp|ProcID DODelay
TriggJ 5 Conc ID T T2 T3 T4 T5 T6 T7 T8 Inpos WObj TLoad
TriggJIOs 4 Conc ID T TriggData1 TriggData2 TriggData3 Inpos WObj TLoad
TriggL 5 Conc ID T T2 T3 T4 T5 T6 T7 T8 Inpos WObj Corr TLoad
TriggLIOs 4 Conc ID T TriggData1 TriggData2 TriggData3 Inpos WObj Corr TLoad
TriggRampAO 5-6 Start Time Inhib
TriggSpeed 5 Start DipLag ErrDO Inhib
TriggStopProc 2 DO GO1 GO2 GO3 GO4
TryInt 1
TuneReset 0
TuneServo 3 Type
UIMsgBox 1 Header MsgLine2 MsgLine3 MsgLine4 MsgLine5 Wrap Buttons Icon Image Result MaxTime
    DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UnLoad 1 ErrIfChanged|Save FilePath File
UnpackRawBytes 3 Network Hex1|IntX|Float4|ASCII
VelSet 2
WaitAI 3 LT|GT MaxTime ValueAtTimeout
WaitAO 3 LT|GT MaxTime ValueAtTimeout
WaitDI 2 MaxTime TimeFlag Visualize Header Message|MsgArray Icon Image VisualizeTime UIActiveSignal
WaitDO 2 MaxTime TimeFlag Visualize Header Message|MsgArray Icon Image VisualizeTime UIActiveSignal
WaitGI 2 NOTEQ|LT|GT MaxTime ValueAtTimeout Visualize Header Message|MsgArray Icon Image
    VisualizeTime UIActiveSignal
WaitGO 2 NOTEQ|LT|GT MaxTime ValueAtTimeout Visualize Header Message|MsgArray Icon Image
    VisualizeTime UIActiveSignal
WaitLoad 1 UnloadPath UnloadFile CheckRef
WaitRob 0 InPos|ZeroSpeed
WaitTestAndSet 1
WaitTime 1 InPos
WaitUntil 1 InPos MaxTime TimeFlag Visualize Header Message|MsgArray Icon Image VisualizeTime
    UIActiveSignal PollRate
WarmStart 0
WorldAccLim 0 On|Off
Write 2 Num|Bool|Pos|Orient|Dnum NoNewLine
WriteAnyBin 2
WriteBin 3
WriteCfgData 3 ListNo
WriteRawBytes 2 NoOfBytes
WriteStrBin 2
"""
