"""The registry of RAPID instructions and functions the interpreter knows, and the predefined
data (tool0, v100, fine, ERR_* ...). An instruction or function not here is a load error.

A built-in is a Python callable `fn(task, pos, opt)`: `pos` the positional arguments, `opt` the
optional ones by name (a switch is True). Arguments the routine writes (VAR/INOUT) arrive as
references with `.value`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from simulators.rapid.errors import ERRNUMS, LONG_JMP_ALL_ERR
from simulators.rapid.values import record


@dataclass(frozen=True)
class Builtin:
    kind: str  # "proc" or "func"
    fn: Callable[..., Any]
    refs: frozenset[int] = frozenset()  # positional arguments passed by reference
    optrefs: frozenset[str] = frozenset()  # optional arguments passed by reference (lower case)
    min_args: int = 0
    max_args: int = 99
    lazy: frozenset[int] = frozenset()  # positional arguments passed unevaluated (`Lazy`)
    # The optional arguments it implements (lower case; None: any, for instructions accepted
    # without effect): any other is refused when the module loads.
    opts: frozenset[str] | None = frozenset()


BUILTINS: dict[str, Builtin] = {}


def builtin(name: str, kind: str, refs: tuple[int, ...] = (), optrefs: tuple[str, ...] = (),
            args: tuple[int, int] = (0, 99),
            lazy: tuple[int, ...] = (), opts: tuple[str, ...] | None = (),
            ) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    def register(fn: Callable[..., Any]) -> Callable[..., Any]:
        BUILTINS[name.lower()] = Builtin(
            kind, fn, frozenset(refs), frozenset(o.lower() for o in optrefs), *args,
            lazy=frozenset(lazy),
            opts=None if opts is None else frozenset(o.lower() for o in opts))
        return fn
    return register


@dataclass(frozen=True)
class Lazy:
    """An argument a built-in evaluates itself (WaitUntil's condition, again and again) or
    inspects (Present's parameter): its expression node in the caller's frame."""

    node: Any
    frame: Any
    evaluate: Callable[[], Any]

    def __call__(self) -> Any:
        return self.evaluate()


def _pose0() -> list:
    return [[0, 0, 0], [1, 0, 0, 0]]


def _speed(v: float) -> Any:
    return record("speeddata", v, 500.0, 5000.0, 1000.0)


def predefined() -> dict[str, Any]:
    """The system's data, by lower-case name (values; all read-only)."""
    data: dict[str, Any] = {f"err_{k[4:].lower()}": float(v) for k, v in ERRNUMS.items()}
    data |= {
        "long_jmp_all_err": float(LONG_JMP_ALL_ERR),
        "tool0": record("tooldata", True, _pose0(), [0.001, [0, 0, 0.001], [1, 0, 0, 0], 0, 0, 0]),
        "wobj0": record("wobjdata", False, True, "", _pose0(), _pose0()),
        "load0": record("loaddata", 0.001, [0, 0, 0.001], [1, 0, 0, 0], 0, 0, 0),
        "fine": record("zonedata", True, 0, 0, 0, 0, 0, 0),
        "vmax": _speed(7000.0),
        "wait_max": 8388608.0,
        "stempty": "",
        "str_digit": "0123456789",
        "str_upper": "ABCDEFGHIJKLMNOPQRSTUVWXYZ",
        "str_lower": "abcdefghijklmnopqrstuvwxyz",
        "str_white": " ",
        "pi": 3.1415927410125732,
        "socket_created": 1.0, "socket_connected": 2.0, "socket_bound": 3.0,
        "socket_listening": 4.0, "socket_closed": 5.0,
        # PackRawBytes/UnpackRawBytes \IntX: the integer's size in bytes, negative signed
        "usint": 1.0, "uint": 2.0, "udint": 4.0, "ulint": 8.0,
        "sint": -1.0, "int": -2.0, "dint": -4.0, "lint": -8.0,
    }
    for v in (5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800, 1000,
              1500, 2000, 2500, 3000, 4000, 5000, 6000, 7000):
        data[f"v{v}"] = _speed(float(v))
    for z in (0, 1, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 150, 200):
        data[f"z{z}"] = record("zonedata", False, z, 1.5 * z, 1.5 * z, 0.15 * z, 1.5 * z,
                               0.15 * z)
    for p in (20, 50, 100):  # stop points: in position within p % of the fine zone
        data[f"inpos{p}"] = record("stoppointdata", 1, False, [p, p, 0, 20], 0, 0, "", 0, 0)
    return data
