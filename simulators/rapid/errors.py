"""The controller's error numbers (RAPID `errnum` constants) and the interpreter's exceptions.

A RAPID error is recoverable: the routine's ERROR handler sees it in ERRNO. The numbers here
are the interpreter's own (the module compares names, never values); the names are ABB's.
"""

from __future__ import annotations

_CORE = """ERR_ALRDYCNT ERR_ARGDUPCND ERR_ARGNOTPER ERR_ARGNOTVAR ERR_ARGVALERR ERR_CALLPROC
ERR_CNTNOTVAR ERR_DIVZERO ERR_EXCRTYMAX ERR_ILLRAISE ERR_INOMAX ERR_NORETURN ERR_NOTPRES
ERR_OUTOFBND ERR_OUTSIDE_REACH ERR_REFUNKDAT ERR_REFUNKFUN ERR_REFUNKPRC ERR_ROBLIMIT
ERR_SOCK_ADDR_INUSE ERR_SOCK_ADDR_INVALID ERR_SOCK_CLOSED ERR_SOCK_IS_BOUND ERR_SOCK_IS_CONN
ERR_SOCK_NET_UNREACH ERR_SOCK_NOT_BOUND ERR_SOCK_NOT_CONN ERR_SOCK_TIMEOUT ERR_SOCK_UNSPEC
ERR_STRTOOLNG ERR_TP_DIBREAK ERR_TP_MAXTIME ERR_TP_NO_CLIENT ERR_NUMOVERFLOW ERR_COLL_STOP
ERR_PATH_STOP ERR_ARRAY_INDEX"""
# The rest of the controller's predefined error numbers (RAPID reference, errnum): a module
# may name any of them in an ERROR handler or a TEST; the interpreter raises few of them.
_MORE = """ ERR_ACC_TOO_LOW ERR_ALIASIO_DEF ERR_ALIASIO_TYPE ERR_ALRDY_MOVING ERR_AO_LIM
ERR_ARGNAME ERR_AXIS_ACT ERR_AXIS_IND ERR_AXIS_MOVING ERR_AXIS_PAR ERR_BUSSTATE ERR_BWDLIMIT
ERR_CALC_NEG ERR_CALC_DIVZERO ERR_CFG_INTERNAL ERR_CFG_ILLTYPE ERR_CFG_LIMIT ERR_CFG_NOTFND
ERR_CFG_OUTOFBOUNDS ERR_CFG_WRITEFILE ERR_CNV_NOT_ACT ERR_CNV_CONNECT ERR_CNV_DROPPED
ERR_COMM_EXT ERR_COMM_INIT ERR_COMM_INIT_FAILED ERR_CONC_MAX ERR_DATA_RECV ERR_DEV_MAXTIME
ERR_DIPLAG_LIM ERR_EXECPHR ERR_FILEACC ERR_FILEEXIST ERR_FILEOPEN ERR_FILNOTFND ERR_FNCNORET
ERR_FRAME ERR_GO_LIM ERR_ILLDIM ERR_ILLQUAT ERR_INT_MAXVAL ERR_INT_NOTVAL ERR_INVDIM
ERR_IODISABLE ERR_IODN_TIMEOUT ERR_IOENABLE ERR_IOERROR ERR_LINKREF ERR_LOADED
ERR_LOADID_FATAL ERR_LOADID_RETRY ERR_MAXINTVAL ERR_MODULE ERR_MOD_NOT_LOADED ERR_MSG_PENDING
ERR_NAME_INVALID ERR_NORUNUNIT ERR_NOT_MOVETASK ERR_NOTARR ERR_NOTEQDIM ERR_NOTINTVAL
ERR_NOTSAVED ERR_NUM_LIMIT ERR_OVERFLOW ERR_PATH ERR_PATHDIST ERR_PERSSUPSEARCH
ERR_PID_MOVESTOP ERR_PID_RAISE_PP ERR_PRGMEMFULL ERR_PROCSIGNAL_OFF ERR_PROGSTOP
ERR_RANYBIN_CHK ERR_RANYBIN_EOF ERR_RCVDATA ERR_REFUNKTRP ERR_SC_WRITE ERR_SIGSUPSEARCH
ERR_SIG_NAME ERR_SIG_NOT_VALID ERR_SPEED_REFRESH_LIM ERR_STARTMOVE ERR_STORE_PROF
ERR_SYMBOL_TYPE ERR_SYM_ACCESS ERR_SYNCMOVEOFF ERR_SYNCMOVEON ERR_SYNTAX ERR_TASKNAME
ERR_TP_DOBREAK ERR_TRUSTLEVEL ERR_TXTNOEXIST ERR_UDPUC_COMM ERR_UISHOW_FATAL ERR_UISHOW_FULL
ERR_UNIT_PAR ERR_UNKINO ERR_UNKPROC ERR_UNLOAD ERR_USE_PROF ERR_WAITSYNCTASK ERR_WAIT_MAXTIME
ERR_WHLSEARCH ERR_WOBJ_MOVING ERR_RMQ_DIM ERR_RMQ_FULL ERR_RMQ_INVALID ERR_RMQ_INVMSG
ERR_RMQ_MSGSIZE ERR_RMQ_NAME ERR_RMQ_NOMSG ERR_RMQ_TIMEOUT ERR_RMQ_VALUE ERR_ROBLIMIT_SPEED
ERR_INPAR_RDONLY ERR_ERRNO_NOTSET ERR_STRUCTURE_NOT_MOD"""
_NAMES = (_CORE + _MORE).split()

# User error numbers 1..90 are the program's own (RAISE n, BookErrNo); the system's start above.
ERRNUMS: dict[str, int] = {name: 1001 + i for i, name in enumerate(_NAMES)}
# An ERROR handler's number that catches every error (`ERROR (LONG_JMP_ALL_ERR)`): errors of
# the routine and those its callees pass on, RETRY then executing again the instruction of the
# routine that failed (or called the routine that did).
LONG_JMP_ALL_ERR = 1000
NAMES: dict[int, str] = {v: k for k, v in ERRNUMS.items()}

# What the event log says about an error nobody handled.
TEXTS = {
    "ERR_STRTOOLNG": "string longer than 80 characters",
    "ERR_OUTOFBND": "array index outside the array's bounds",
    "ERR_DIVZERO": "division by zero",
    "ERR_SOCK_TIMEOUT": "socket time-out",
    "ERR_SOCK_CLOSED": "socket closed",
    "ERR_SOCK_ADDR_INUSE": "socket address in use",
    "ERR_SOCK_ADDR_INVALID": "socket address not valid on this controller",
    "ERR_ROBLIMIT": "position outside the joint limits",
    "ERR_OUTSIDE_REACH": "position outside reach",
    "ERR_TP_MAXTIME": "no answer on the FlexPendant in time",
    "ERR_EXCRTYMAX": "RETRY repeated more than the maximum number of times",
    "ERR_NORETURN": "function ended without RETURN",
    "ERR_COLL_STOP": "collision detected, motion stopped",
}


def errnum_name(errno: int) -> str:
    return NAMES.get(errno, f"user error {errno}")


class RapidError(Exception):
    """A RAPID run-time error: ERRNO and where it arose."""

    def __init__(self, name_or_no: str | int, detail: str = "", line: int | None = None):
        self.errno = ERRNUMS[name_or_no] if isinstance(name_or_no, str) else name_or_no
        self.name = errnum_name(self.errno)
        self.detail = detail or TEXTS.get(self.name, "")
        self.line = line
        self.origin: int | None = line  # where it arose (line is where it is handled)
        self.path: str | None = None  # the file of the module where it arose
        super().__init__(f"{self.name}: {self.detail}")


class LoadError(ValueError):
    """A module the controller would refuse to load (or could not run): where and why."""

    def __init__(self, path: str, line: int, reason: str):
        self.path, self.line, self.reason = path, line, reason
        super().__init__(f"{path}:{line}: {reason}")


class SettingError(LoadError):
    """A `--set NAME=VALUE` the program cannot take: the item as given and why. A
    command-line option has no file nor line: the message names the option and the item."""

    def __init__(self, item: str, reason: str):
        super().__init__("--set", 0, reason)
        self.item = item
        self.args = (f"--set {item!r}: {reason}",)
