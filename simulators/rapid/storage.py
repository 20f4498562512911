"""Where RAPID data live: a declared datum (Var), one the controller's configuration sets while
the program runs (LiveVar), an array element and a record component passed by reference."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from simulators.rapid.errors import RapidError
from simulators.rapid.values import RECORDS, RArray, Record, convert


class Var:
    __slots__ = ("const", "dims", "type", "value")

    def __init__(self, type_: str, value: Any, dims: tuple[int, ...] = (), const: bool = False):
        self.type, self.value, self.dims, self.const = type_, value, dims, const

    def set(self, v: Any) -> None:
        if type(v) is float and self.type == "num" and not self.dims:
            self.value = v  # already a num (every result is rounded to 32 bits)
            return
        self.value = convert(self.type, v, self.dims)


class LiveVar:
    """A datum the controller's configuration sets and may change while the program runs
    (the emulator's settings behind the module's CONSTs): read-only to the program."""

    __slots__ = ("_read", "const", "dims", "type")

    def __init__(self, type_: str, read: Callable[[], Any]):
        self.type, self.dims, self.const, self._read = type_, (), True, read

    @property
    def value(self) -> Any:
        return convert(self.type, self._read())

    def set(self, v: Any) -> None:
        raise RapidError("ERR_ARGVALERR", "a CONST cannot be assigned")


class ElemRef:
    __slots__ = ("arr", "i")

    def __init__(self, arr: RArray, i: int):
        self.arr, self.i = arr, i

    @property
    def value(self) -> Any:
        return self.arr.items[self.i]

    @value.setter
    def value(self, v: Any) -> None:
        self.arr.items[self.i] = v

    def set(self, v: Any) -> None:
        self.arr.items[self.i] = convert(self.arr.type, v)


class FieldRef:
    __slots__ = ("name", "rec")

    def __init__(self, rec: Record, name: str):
        self.rec, self.name = rec, name

    @property
    def value(self) -> Any:
        return self.rec.f[self.name]

    @value.setter
    def value(self, v: Any) -> None:
        self.rec.f[self.name] = v

    def set(self, v: Any) -> None:
        ft = dict(RECORDS[self.rec.type])[self.name]
        self.rec.f[self.name] = convert(ft, v)
