"""RAPID's binary operators on num (every result a 32-bit num), string (+, at most 80
characters), pos (+, -) and bool; integer DIV and MOD; ERR_DIVZERO. A TypeError means the
operands' types do not fit the operator (the interpreter names it)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from simulators.rapid.errors import RapidError
from simulators.rapid.values import Record, num, string


def _num_op(f: Callable[[float, float], float]) -> Callable[[Any, Any], Any]:
    def op(a: Any, b: Any) -> Any:
        if isinstance(a, float) and isinstance(b, float):
            return num(f(a, b))
        raise TypeError
    return op


def _add(a: Any, b: Any) -> Any:
    if isinstance(a, float) and isinstance(b, float):
        return num(a + b)
    if isinstance(a, str) and isinstance(b, str):
        return string(a + b)
    if isinstance(a, Record) and isinstance(b, Record) and a.type == b.type == "pos":
        return Record("pos", {k: num(a.f[k] + b.f[k]) for k in a.f})
    raise TypeError


def _sub(a: Any, b: Any) -> Any:
    if isinstance(a, float) and isinstance(b, float):
        return num(a - b)
    if isinstance(a, Record) and isinstance(b, Record) and a.type == b.type == "pos":
        return Record("pos", {k: num(a.f[k] - b.f[k]) for k in a.f})
    raise TypeError


def _div(a: Any, b: Any) -> Any:
    if not (isinstance(a, float) and isinstance(b, float)):
        raise TypeError
    if b == 0:
        raise RapidError("ERR_DIVZERO")
    return num(a / b)


def _int_op(kind: str) -> Callable[[Any, Any], Any]:
    def op(a: Any, b: Any) -> Any:
        if not (isinstance(a, float) and isinstance(b, float)):
            raise TypeError
        if a != int(a) or b != int(b):
            raise RapidError("ERR_ARGVALERR", f"{kind} needs integers")
        if b == 0:
            raise RapidError("ERR_DIVZERO")
        q = abs(int(a)) // abs(int(b)) * (1 if (a < 0) == (b < 0) else -1)
        return float(q) if kind == "DIV" else float(int(a) - q * int(b))
    return op


def _cmp(f: Callable[[Any, Any], bool]) -> Callable[[Any, Any], bool]:
    def op(a: Any, b: Any) -> bool:
        if isinstance(a, float) and isinstance(b, float):
            return f(a, b)
        raise TypeError
    return op


def _logic(f: Callable[[bool, bool], bool]) -> Callable[[Any, Any], bool]:
    def op(a: Any, b: Any) -> bool:
        if isinstance(a, bool) and isinstance(b, bool):
            return f(a, b)
        raise TypeError
    return op


def _eq(a: Any, b: Any) -> bool:
    if type(a) is not type(b):
        raise TypeError
    return a == b


BINARY: dict[str, Callable[[Any, Any], Any]] = {
    "+": _add, "-": _sub, "*": _num_op(lambda a, b: a * b), "/": _div,
    "DIV": _int_op("DIV"), "MOD": _int_op("MOD"),
    "<": _cmp(lambda a, b: a < b), "<=": _cmp(lambda a, b: a <= b),
    ">": _cmp(lambda a, b: a > b), ">=": _cmp(lambda a, b: a >= b),
    "=": _eq, "<>": lambda a, b: not _eq(a, b),
    "AND": _logic(lambda a, b: a and b), "OR": _logic(lambda a, b: a or b),
    "XOR": _logic(lambda a, b: a != b),
}
