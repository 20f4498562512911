"""The instructions and functions of the RAPID reference (RobotWare 6 base system and the
socket, file and raw-data options), with their arguments as far as `rapid check` verifies
them: how many positional (required) arguments, and which optional `\\Name` arguments exist.

One line per routine: `Name  positional  options`, where positional is a count or `min-max`
and options are names or `*` (any: routines whose optional arguments are too many to list
here are checked by name only). Names compare without case, as in RAPID.
"""

from __future__ import annotations

from dataclasses import dataclass

_INSTRUCTIONS = """
MoveJ 4 Conc ID V T Z Inpos WObj Corr TLoad
MoveL 4 Conc ID V T Z Inpos WObj Corr TLoad
MoveC 5 Conc ID V T Z Inpos WObj Corr TLoad
MoveAbsJ 4 Conc ID NoEOffs V T Z Inpos WObj TLoad
MoveExtJ 3 Conc ID UseEOffs T Inpos
MoveJDO 6 ID T WObj TLoad
MoveLDO 6 ID T WObj TLoad
MoveCDO 7 ID T WObj TLoad
MoveJSync 5 ID T WObj TLoad
MoveLSync 5 ID T WObj TLoad
MoveCSync 6 ID T WObj TLoad
MoveJAO 6 ID T WObj TLoad
MoveLAO 6 ID T WObj TLoad
MoveJGO 6 ID T WObj TLoad
MoveLGO 6 ID T WObj TLoad
TriggJ 4-10 *
TriggL 4-10 *
TriggC 5-11 *
SearchL 5 *
SearchJ 5 *
SearchC 6 *
StopMove 0 Quick AllMotionTasks
StartMove 0 AllMotionTasks BufferResume
StartMoveRetry 0
StopMoveReset 0 AllMotionTasks
StorePath 0 KeepSync
RestoPath 0
ClearPath 0
WaitRob 0 InPos ZeroSpeed
ConfJ 0 On Off
ConfL 0 On Off
SingArea 0 Wrist LockAxis4 Off
AccSet 2 FinePointRamp
VelSet 2
PathAccLim 2 AccMax DecelMax
SoftAct 2 MechUnit Ramp
SoftDeact 0 Ramp
GripLoad 1
MechUnitLoad 3
ActUnit 1
DeactUnit 1
EOffsOn 1 ExeP
EOffsSet 1
EOffsOff 0
PDispOn 2 Rot ExeP WObj
PDispSet 1
PDispOff 0
CorrClear 0
TuneServo 3 Type TuneValue
TuneReset 0
SetDO 2 SDelay Sync
SetAO 2
SetGO 2 SDelay
Set 1
Reset 1
PulseDO 1 High PLength
InvertDO 1
WaitDI 2 MaxTime TimeFlag
WaitDO 2 MaxTime TimeFlag
WaitGI 2 *
WaitGO 2 *
WaitAI 3 *
WaitAO 3 *
WaitTime 1 InPos
WaitUntil 1 *
WaitSyncTask 2 InPos TimeOut
WaitLoad 1 *
WaitWObj 1 *
TPWrite 1 Num Bool Pos Orient Dnum
TPErase 0
TPReadNum 2 *
TPReadFK 7 *
TPReadDnum 2 *
TPShow 1
ErrWrite 2 W I RL2 RL3 RL4
ErrLog 2 *
UIMsgBox 1 *
Stop 0 NoRegain AllMoveTasks
ClkReset 1
ClkStart 1
ClkStop 1
WaitTestAndSet 1
Break 0
ExitCycle 0
SystemStopAction 0 Stop StopBlock Halt
SkipWarn 0
RaiseToUser 0 Continue BreakOff ErrorNumber
ResetRetryCount 0
BookErrNo 1
Incr 1
Decr 1
Add 2
Clear 1
BitSet 2
BitClear 2
CallByVar 2
IDelete 1
ISignalDI 3 Single SingleSafe
ISignalDO 3 Single SingleSafe
ISignalGI 2 Single SingleSafe
ISignalGO 2 Single SingleSafe
ISignalAI 6 *
ISignalAO 6 *
ITimer 2 Single SingleSafe
IPers 2 Single SingleSafe
IError 3 ErrorId
ISleep 1
IWatch 1
IEnable 0
IDisable 0
SocketCreate 1 UDP
SocketBind 3
SocketListen 1
SocketAccept 2 ClientAddress Time
SocketConnect 3 Time
SocketSend 1 Str RawData Data NoOfBytes
SocketSendTo 3 Str RawData Data NoOfBytes
SocketReceive 1 Str RawData Data ReadNoOfBytes NoRecBytes Time
SocketReceiveFrom 3 Str RawData Data ReadNoOfBytes NoRecBytes Time
SocketClose 1
ClearRawBytes 1 FromIndex
PackRawBytes 3 Network Hex1 IntX Float4 ASCII
UnpackRawBytes 3 Network Hex1 IntX Float4 ASCII
CopyRawBytes 4 NoOfBytes
PackDNHeader 3
Open 2 File Read Write Append Bin
Close 1
Write 2 Num Bool Pos Orient Dnum NoNewLine
WriteBin 3
WriteStrBin 2
WriteRawBytes 1 NoOfBytes
ReadRawBytes 2 Time
ReadAnyBin 2 Time
Rewind 1
ClearIOBuff 1
CopyFile 2
RemoveFile 1
RenameFile 2
MakeDir 1
RemoveDir 1
OpenDir 2
CloseDir 1
Load 1 *
StartLoad 2 *
UnLoad 1 *
EraseModule 1
Save 1 *
ReadCfgData 3 *
WriteCfgData 3 *
SetSysData 1 *
GetSysData 1 *
SetDataSearch 1 *
GetDataVal 2 *
SetDataVal 2 *
SetAllDataVal 2 *
SpyStart 1
SpyStop 0
SyncMoveOn 2 TimeOut
SyncMoveOff 1 TimeOut
TriggIO 3-4 *
TriggEquip 4-5 *
TriggInt 3 *
TriggCheckIO 5-6 *
TriggStopProc 6 *
TriggSpeed 4-5 *
MToolRotCalib 2 *
MToolTCPCalib 5
SToolRotCalib 4
SToolTCPCalib 5
WZBoxDef 3 Inside Outside
WZCylDef 4 Inside Outside
WZSphDef 3 Inside Outside
WZLimSup 2 Temp Stat
WZDOSet 4 Temp Stat Inside Before
WZEnable 1
WZDisable 1
WZFree 1
EGMGetId 1
EGMReset 1
EGMSetupAI 5 *
EGMSetupUC 4 *
EGMActJoint 2 *
EGMActPose 6 *
EGMRunJoint 2 *
EGMRunPose 2 *
EGMStop 2 *
EGMStreamStart 1 *
EGMStreamStop 1
RMQFindSlot 2 *
RMQSendMessage 2 *
RMQGetMessage 1 *
RMQGetMsgData 2 *
RMQGetMsgHeader 1 *
RMQReadWait 1 *
TestSignDefine 4 *
TestSignReset 0
IndAMove 2 *
IndCMove 2 *
IndDMove 2 *
IndRMove 2 *
IndReset 1 *
"""

_FUNCTIONS = """
Abs 1
AbsDnum 1
Sin 1
Cos 1
Tan 1
ASin 1
ACos 1
ATan 1
ATan2 2
Sqrt 1
SqrtDnum 1
Exp 1
Pow 2
PowDnum 2
Round 1 Dec
RoundDnum 1 Dec
Trunc 1 Dec
TruncDnum 1 Dec
Max 2
Min 2
NumToStr 2 Exp
DnumToStr 2 Exp
NumToDnum 1
DnumToNum 1 Integer
StrLen 1
StrPart 3
StrFind 3 NotInSet
StrMatch 3
StrMemb 3
StrOrder 3
StrMap 3
StrToVal 2
StrToByte 1 Hex Okt Bin Char
ByteToStr 1 Hex Okt Bin Char
ValToStr 1
DecToHex 1
HexToDec 1
CRobT 0 TaskRef TaskName Tool WObj
CJointT 0 TaskRef TaskName
CPos 0 Tool WObj
CTool 0
CWObj 0
CalcJointT 2 UseCurWObjPos WObj ConfigID ErrorNumber
CalcRobT 2 WObj
Offs 4
RelTool 4 Rx Ry Rz
OrientZYX 3
EulerZYX 1 X Y Z
PoseMult 2
PoseInv 1
PoseVect 2
NOrient 1
Distance 2
DotProd 2
CrossProd 2
VectMagn 1
MirPos 2 WObj MirY
DefFrame 3 *
DefDFrame 6
DefAccFrame 4 *
CDate 0
CTime 0
ClkRead 1 HighRes
GetTime 0 WDay Hour Min Sec
GetSysInfo 0 SerialNo SWVersion RobotType CtrlId LanIp CtrlLang SystemName
GetTaskName 0 TaskNo MecTaskNo
GetMecUnitName 1
IsPers 1
IsVar 1
Present 1
Dim 2
ArgName 1 *
DOutput 1
DInput 1
GOutput 1
GInput 1
AOutput 1
AInput 1
TestDI 1
ValidIO 1
ReadNum 1 Line Delim Time
ReadStr 1 *
ReadBin 1 Time
ReadStrBin 2 Time
ReadDir 2
SocketGetStatus 1
SocketPeek 1
RawBytesLen 1
ReadMotor 1 MecUnit
IsSyncMoveOn 0
OpMode 0
RunMode 0 Main
BitAnd 2
BitOr 2
BitXOr 2
BitNeg 1
BitLSh 2
BitRSh 2
BitCheck 2
CorrRead 0
MaxRobSpeed 0
ModExist 1
RobOS 0
IsStopMoveAct 0 FromMoveTask FromNonMoveTask
IsMechUnitActive 1
TaskRunMec 0
TaskRunRob 0
UIMsgBox 1 *
UINumEntry 0 *
UINumTune 2 *
UIAlphaEntry 0 *
UIListView 1 *
CSpeedOverride 0 CTask
GetNextSym 2 *
IsFile 1 *
FileSize 1
FSSize 1 *
ReadVar 2 *
ExecLevel 0
ExecHandler 0
RemainingRetries 0
ErrRaise 2 *
EGMGetState 1
GetMaxNumberOfCyclicBool 0
TestAndSet 1
WaitAndTest 1
"""


@dataclass(frozen=True)
class Signature:
    """What `rapid check` knows of a routine's arguments: positional counts (None: not
    checked) and optional names (None: any)."""

    name: str
    min_positional: int | None
    max_positional: int | None
    options: frozenset[str] | None  # lower case


def _table(text: str) -> dict[str, Signature]:
    out = {}
    for row in text.strip().splitlines():
        name, count, *options = row.split()
        low, _, high = count.partition("-")
        out[name.lower()] = Signature(
            name, int(low), int(high or low),
            None if options == ["*"] else frozenset(o.lower() for o in options))
    return out


INSTRUCTIONS = _table(_INSTRUCTIONS)
FUNCTIONS = _table(_FUNCTIONS)
