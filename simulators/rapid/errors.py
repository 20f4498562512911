"""The controller's error numbers (RAPID `errnum` constants) and the interpreter's exceptions.

A RAPID error is recoverable: the routine's ERROR handler sees it in ERRNO. The numbers here
are the interpreter's own (the module compares names, never values); the names are ABB's.
"""

from __future__ import annotations

_NAMES = """ERR_ALRDYCNT ERR_ARGDUPCND ERR_ARGNOTPER ERR_ARGNOTVAR ERR_ARGVALERR ERR_CALLPROC
ERR_CNTNOTVAR ERR_DIVZERO ERR_EXCRTYMAX ERR_ILLRAISE ERR_INOMAX ERR_NORETURN ERR_NOTPRES
ERR_OUTOFBND ERR_OUTSIDE_REACH ERR_REFUNKDAT ERR_REFUNKFUN ERR_REFUNKPRC ERR_ROBLIMIT
ERR_SOCK_ADDR_INUSE ERR_SOCK_ADDR_INVALID ERR_SOCK_CLOSED ERR_SOCK_IS_BOUND ERR_SOCK_IS_CONN
ERR_SOCK_NET_UNREACH ERR_SOCK_NOT_BOUND ERR_SOCK_NOT_CONN ERR_SOCK_TIMEOUT ERR_SOCK_UNSPEC
ERR_STRTOOLNG ERR_TP_DIBREAK ERR_TP_MAXTIME ERR_TP_NO_CLIENT ERR_NUMOVERFLOW ERR_COLL_STOP
ERR_PATH_STOP ERR_ARRAY_INDEX""".split()

# User error numbers 1..90 are the program's own (RAISE n, BookErrNo); the system's start above.
ERRNUMS: dict[str, int] = {name: 1001 + i for i, name in enumerate(_NAMES)}
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
        super().__init__(f"{self.name}: {self.detail}")


class LoadError(ValueError):
    """A module the controller would refuse to load (or could not run): where and why."""

    def __init__(self, path: str, line: int, reason: str):
        self.path, self.line, self.reason = path, line, reason
        super().__init__(f"{path}:{line}: {reason}")
