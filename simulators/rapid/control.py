"""How RAPID leaves a block: the interpreter's control transfers (not RAPID errors, which are
`errors.RapidError`). The built-ins raise `Stopped` (Stop, EXIT, the controller's stop) and
`ExitCycle`; the interpreter raises and catches the others."""

from __future__ import annotations

from typing import Any

from screwcal.rapid import ast as A  # noqa: N812 - the node classes
from simulators.rapid.errors import RapidError


class Stopped(BaseException):
    """The program stops (Stop, an unhandled error, the controller's stop or PP to Main)."""

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason)


class Return(BaseException):
    def __init__(self, value: Any):
        self.value = value


class Retry(BaseException):
    pass


class TryNext(BaseException):
    pass


class ExitCycle(BaseException):
    pass


class Propagate(BaseException):
    """An error on its way to the caller's instruction (not handled by this routine again)."""

    def __init__(self, error: RapidError):
        self.error = error


class Fatal(BaseException):
    def __init__(self, error: RapidError):
        self.error = error


class Jump(BaseException):
    """GOTO: to the label (lower case) in this statement list or an enclosing one."""

    def __init__(self, label: str):
        self.label = label


def at_label(st: Any, frame: Any) -> None:
    """A label does nothing where it stands."""


def label_index(stmts: tuple[Any, ...], name: str) -> int | None:
    """Where label `name` (lower case) stands in a statement list, if it does."""
    for i, st in enumerate(stmts):
        if isinstance(st, A.Label) and st.name.lower() == name:
            return i
    return None
