"""The functions and data types of the RobotWare base system (RobotWare 6.13 / 7), from ABB's
Technical reference manual - RAPID Instructions, Functions and Data types (3HAC050917-001):
chapter 2 "Functions" (each row the section titled with the function's name) and chapter 3
"Data types" (each name the section titled with it), the predefined data of the system
modules beside them. Rows as in `reference_instructions`.
"""

FUNCTIONS = """
Abs 1
AbsDnum 1
ACos 1
ACosDnum 1
AInput 1
AOutput 1
ArgName 1 ErrorNumber
ASin 1
ASinDnum 1
ATan 1
ATanDnum 1
ATan2 2
ATan2Dnum 2
BitAnd 2
BitAndDnum 2
BitCheck 2
BitCheckDnum 2
BitLSh 2
BitLShDnum 2
BitNeg 1
BitNegDnum 1
BitOr 2
BitOrDnum 2
BitRSh 2
BitRShDnum 2
BitXOr 2
BitXOrDnum 2
ByteToStr 1 Hex|Okt|Bin|Char
CalcJointT 2 UseCurWObjPos WObj ErrorNumber
CalcRobT 2 WObj
CalcRotAxFrameZ 4
CalcRotAxisFrame 4
CDate 0
CJointT 0 TaskRef|TaskName
ClkRead 1 HighRes
Cos 1
CosDnum 1
CPos 0 Tool WObj
CRobT 0 TaskRef|TaskName Tool WObj
CrossProd 2
CSpeedOverride 0 CTask
CTime 0
CTool 0 TaskRef|TaskName
CWObj 0 TaskRef|TaskName
DecToHex 1
DefAccFrame 4-6
DefDFrame 6
DefFrame 3 Origin
Dim 2
DInput 1
Distance 2
DivDnum 2
DnumToNum 1 Integer
DnumToStr 2 Exp
DotProd 2
DOutput 1
EulerZYX 1 X|Y|Z
EventType 0
ExecHandler 0
ExecLevel 0
Exp 1
FileSize 1
FileTimeDnum 1 ModifyTime|AccessTime|StatCTime
FSSize 1 Total|Free Kbyte|Mbyte
GetMaxNumberOfCyclicBool 0
GetMecUnitName 1
GetModalPayLoadMode 0
GetMotorTorque 0-1 MecUnit Axis
GetNextCyclicBool 2
GetNextMechUnit 2 MecRef TCPRob NoOfAxes MecTaskNo MotPlanNo Active DriveModule OKToDeact
GetNextSym 2 Recursive
GetNumberOfCyclicBool 0
GetServiceInfo 1 DutyTimeCnt
GetSignalOrigin 2
GetSysInfo 0
    SerialNo|SWVersion|RobotType|CtrlId|LanIp|CtrlLang|SystemName|SystemId|CtrlName|CtrlType|SWVersionName|StartTime
GetTaskName 0 TaskNo|MecTaskNo
GetTime 0 WDay|Hour|Min|Sec
GInput 1
GInputDnum 1
GOutput 1
GOutputDnum 1
HexToDec 1
IOUnitState 1 Phys|Logic
IsBrakeCheckActive 0
IsCyclicBool 1
IsFile 1 Directory|Fifo|RegFile|BlockSpec|CharSpec
IsLeadThrough 0
IsMechUnitActive 1
IsPers 1
IsStopMoveAct 0 FromMoveTask|FromNonMoveTask
IsStopStateEvent 0 PPMoved|PPToMain
IsSysId 1
IsVar 1
MaxExtLinearSpeed 0
MaxExtReorientSpeed 0
MaxRobReorientSpeed 0
MaxRobSpeed 0
MirPos 2 WObj MirY
ModExist 1
ModTime 1 StrDig
MotionPlannerNo 0
NonMotionMode 0 Main
NOrient 1
NumToDnum 1
NumToStr 2 Exp
Offs 4
OpMode 0
OrientZYX 3
ORobT 1 InPDisp|InEOffs
ParIdPosValid 3
ParIdRobValid 1 MechUnit AxisNo
PathLevel 0
PFRestart 0 Base|Irpt
PoseInv 1
PoseMult 2
PoseVect 2
Pow 2
PowDnum 2
PPMovedInManMode 0
Present 1
ProgMemFree 0
RawBytesLen 1
ReadBin 1 Time
ReadDir 2
ReadMotor 1 MecUnit
ReadNum 1 Delim Time
ReadStr 1 Delim|RemoveCR DiscardHeaders Time
ReadStrBin 2 Time
RelTool 4 Rx Ry Rz
RemainingRetries 0
RobName 0
RobOS 0
Round 1 Dec
RoundDnum 1 Dec
RunMode 0 Main
Sin 1
SinDnum 1
Sqrt 1
SqrtDnum 1
StrDigCalc 3
StrFormat 1 *
StrDigCmp 3
StrFind 3 NotInSet
StrLen 1
StrMap 3
StrMatch 3
StrMemb 3
StrOrder 3
StrPart 3
StrToByte 1 Hex|Okt|Bin|Char
StrToVal 2
Tan 1
TanDnum 1
TaskRunMec 0
TaskRunRob 0
TestAndSet 1
TestDI 1
TestSignRead 1
TextGet 2
TextTabFreeToUse 1
TextTabGet 1
Trunc 1 Dec
TruncDnum 1 Dec
Type 1 BaseName
UIAlphaEntry 0 Header Message|MsgArray Wrap Icon InitString MaxTime DIBreak DIPassive DOBreak
    DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UIClientExist 0
UIDnumEntry 0 Header Message|MsgArray Wrap Icon InitValue MinValue MaxValue AsInteger MaxTime
    DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UIDnumTune 2 Header Message|MsgArray Wrap Icon MinValue MaxValue MaxTime DIBreak DIPassive
    DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UIListView 1 Result Header Buttons|BtnArray Icon DefaultIndex MaxTime DIBreak DIPassive DOBreak
    DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UIMessageBox 0 Header Message|MsgArray Wrap Buttons|BtnArray DefaultBtn Icon Image MaxTime
    DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UINumEntry 0 Header Message|MsgArray Wrap Icon InitValue MinValue MaxValue AsInteger MaxTime
    DIBreak DIPassive DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
UINumTune 2 Header Message|MsgArray Wrap Icon MinValue MaxValue MaxTime DIBreak DIPassive
    DOBreak DOPassive PersBoolBreak PersBoolPassive BreakFlag UIActiveSignal
ValidIO 1
ValToStr 1
VectMagn 1
"""

# Chapter 3, and the predefined data types of the base system's modules.
DATA_TYPES = """
aiotrigg bool btnres busstate buttondata byte cfgdomain clock confdata datapos dionum dir dnum
errdomain errnum errstr errtype event_type exec_level extjoint handler_type icondata intnum
iodev iounit_state jointtarget listitem loaddata loadidnum loadsession mecunit motsetdata num
opcalc opnum orient paridnum paridvalidnum pos pose progdisp rawbytes restartdata robjoint
robtarget signalai signalao signaldi signaldo signalgi signalgo signalorigin speeddata
stoppointdata string stringdig switch symnum sysnum taskid testsignal tooldata tpnum trapdata
triggdata triggflag triggios triggiosdnum triggstrgo tunetype wobjdata zonedata
"""
