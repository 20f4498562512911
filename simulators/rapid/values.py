"""RAPID values as the controller stores them.

num: a 32-bit IEEE float (every literal, every result rounded so); string: at most 80
characters (longer is ERR_STRTOOLNG); bool; records (mutable, value semantics: assignment and
by-value parameters copy); arrays with bounds 1..n (ERR_OUTOFBND). A `socketdev` is an object
that cannot be copied (a reference to the controller's socket).
"""

from __future__ import annotations

import math
import socket
import struct
from typing import Any

from simulators.rapid.errors import RapidError

MAX_STRING = 80
_F32 = struct.Struct("<f")
_F32_MAX = 3.4028234663852886e38


def num(x: float) -> float:
    """x as a RAPID num holds it: rounded to 32 bits (ERR_NUMOVERFLOW beyond)."""
    if x != x or abs(x) > _F32_MAX:
        raise RapidError("ERR_NUMOVERFLOW", f"{x!r} is no num")
    return _F32.unpack(_F32.pack(x))[0]


def string(s: str) -> str:
    if len(s) > MAX_STRING:
        raise RapidError("ERR_STRTOOLNG", f"string of {len(s)} characters (at most 80)")
    return s


# The records the module and the motion instructions use (RAPID reference, data types).
RECORDS: dict[str, tuple[tuple[str, str], ...]] = {
    "pos": (("x", "num"), ("y", "num"), ("z", "num")),
    "orient": (("q1", "num"), ("q2", "num"), ("q3", "num"), ("q4", "num")),
    "pose": (("trans", "pos"), ("rot", "orient")),
    "confdata": (("cf1", "num"), ("cf4", "num"), ("cf6", "num"), ("cfx", "num")),
    "robjoint": tuple((f"rax_{i}", "num") for i in range(1, 7)),
    "extjoint": tuple((f"eax_{c}", "num") for c in "abcdef"),
    "robtarget": (("trans", "pos"), ("rot", "orient"), ("robconf", "confdata"),
                  ("extax", "extjoint")),
    "jointtarget": (("robax", "robjoint"), ("extax", "extjoint")),
    "loaddata": (("mass", "num"), ("cog", "pos"), ("aom", "orient"), ("ix", "num"),
                 ("iy", "num"), ("iz", "num")),
    "tooldata": (("robhold", "bool"), ("tframe", "pose"), ("tload", "loaddata")),
    "wobjdata": (("robhold", "bool"), ("ufprog", "bool"), ("ufmec", "string"),
                 ("uframe", "pose"), ("oframe", "pose")),
    "speeddata": (("v_tcp", "num"), ("v_ori", "num"), ("v_leax", "num"), ("v_reax", "num")),
    "zonedata": (("finep", "bool"), ("pzone_tcp", "num"), ("pzone_ori", "num"),
                 ("pzone_eax", "num"), ("zone_ori", "num"), ("zone_leax", "num"),
                 ("zone_reax", "num")),
    "inposdata": (("position", "num"), ("speed", "num"), ("mintime", "num"),
                  ("maxtime", "num")),
    "stoppointdata": (("type", "num"), ("progsynch", "bool"), ("inpos", "inposdata"),
                      ("stoptime", "num"), ("followtime", "num"), ("signal", "string"),
                      ("relation", "num"), ("checkvalue", "num")),
}
# Aliases of num (RAPID: errnum, btnres, ...) and of string.
ALIASES = {"errnum": "num", "btnres": "num", "socketstatus": "num", "stoppoint": "num",
           "intnum": "num", "dnum": "num", "byte": "num", "errdomain": "num",
           "errtype": "num"}
ATOMIC = {"num", "string", "bool"}
# World Zones' data (option World Zones): accepted, not supervised (`worldzones`).
WORLD_ZONE_TYPES = {"wzstationary", "wztemporary", "shapedata"}
OPAQUE = {"socketdev", "clock", "rawbytes"} | WORLD_ZONE_TYPES


def base_type(t: str) -> str:
    t = t.lower()
    return ALIASES.get(t, t)


SYSTEM_TYPES = frozenset(ATOMIC | set(RECORDS) | OPAQUE | set(ALIASES))


def known_type(t: str, own: frozenset[str] = frozenset()) -> bool:
    """A data type of the system, or one of `own` (the task's RECORDs and ALIASes)."""
    t = t.lower()
    return t in own or base_type(t) in SYSTEM_TYPES


def declare_types(records: dict[str, tuple[tuple[str, str], ...]],
                  aliases: dict[str, str]) -> None:
    """A task's RECORD types (name -> (component, type) pairs) and ALIASes (name -> type),
    all lower case, made known to the values of every task (the last loaded declaration of a
    name is the one used; a system type's name is refused by the caller)."""
    for name, base in aliases.items():
        ALIASES[name] = base
    for name, fields in records.items():
        RECORDS[name] = fields
        _RECORD_DEFAULTS.pop(name, None)


class Record:
    """A record value: its type and its components in declaration order."""

    __slots__ = ("f", "type")

    def __init__(self, type_: str, fields: dict[str, Any]):
        self.type, self.f = type_, fields

    def copy(self) -> Record:
        return Record(self.type, {k: copy(v) for k, v in self.f.items()})

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Record) and self.type == other.type and self.f == other.f

    def __repr__(self) -> str:
        return f"[{', '.join(repr(v) for v in self.f.values())}]"


class RArray:
    """An array: 1-based, fixed length; a two-dimensional array is an array of arrays."""

    __slots__ = ("items", "type")

    def __init__(self, type_: str, items: list[Any]):
        self.type, self.items = type_, items

    def copy(self) -> RArray:
        return RArray(self.type, [copy(v) for v in self.items])

    def index(self, i: float) -> int:
        if i != int(i):
            raise RapidError("ERR_OUTOFBND", f"index {i} is not an integer")
        k = int(i)
        if not 1 <= k <= len(self.items):
            raise RapidError("ERR_OUTOFBND", f"index {k} outside 1..{len(self.items)}")
        return k - 1

    def __eq__(self, other: object) -> bool:
        return isinstance(other, RArray) and self.items == other.items


class SocketDev:
    """A socketdev: which OS socket the controller holds for it (see sockets.py)."""

    __slots__ = ("local", "peer_closed", "sock", "state")

    def __init__(self) -> None:
        self.sock: socket.socket | None = None
        self.state = "none"
        self.peer_closed = False
        self.local: tuple[str, int] | None = None

    def copy(self) -> SocketDev:  # a reference: never duplicated
        return self


class Clock:
    """A clock: seconds counted while started (ClkReset, ClkStart, ClkStop, ClkRead)."""

    __slots__ = ("since", "total")

    def __init__(self) -> None:
        self.total, self.since = 0.0, None

    def copy(self) -> Clock:
        return self


class RawBytes:
    """A rawbytes: up to 1024 bytes, its valid length the length of `data` (a value: copied
    on assignment)."""

    MAX = 1024
    __slots__ = ("data",)

    def __init__(self, data: bytes = b"") -> None:
        self.data = data

    def copy(self) -> RawBytes:
        return RawBytes(self.data)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, RawBytes) and self.data == other.data


class WorldZone:
    """A world zone's data (wzstationary, wztemporary, shapedata): held, never supervised."""

    __slots__ = ("type",)

    def __init__(self, type_: str) -> None:
        self.type = type_


def copy(v: Any) -> Any:
    return v.copy() if isinstance(v, Record | RArray | RawBytes) else v


def default(type_: str, dims: tuple[int, ...] = ()) -> Any:
    """The initial value of a declaration without one: 0, "", FALSE, records of those."""
    if dims:
        return RArray(type_, [default(type_, dims[1:]) for _ in range(dims[0])])
    t = base_type(type_)
    if t == "num":
        return 0.0
    if t == "string":
        return ""
    if t == "bool":
        return False
    if t == "socketdev":
        return SocketDev()
    if t == "clock":
        return Clock()
    if t == "rawbytes":
        return RawBytes()
    if t in WORLD_ZONE_TYPES:
        return WorldZone(t)
    if t in RECORDS:
        template = _RECORD_DEFAULTS.get(t)
        if template is None:
            template = _RECORD_DEFAULTS[t] = Record(t, {name: default(ft)
                                                        for name, ft in RECORDS[t]})
        return template.copy()  # a record holds no socketdev or clock: a copy is a new one
    raise RapidError("ERR_ARGVALERR", f"unknown data type {type_}")


_RECORD_DEFAULTS: dict[str, Record] = {}  # each record type's initial value, copied


def convert(type_: str, value: Any, dims: tuple[int, ...] = ()) -> Any:
    """A value of this type from what an expression gave (an aggregate is a Python list)."""
    if dims:
        if isinstance(value, RArray):
            value = value.items
        if not isinstance(value, list) or len(value) != dims[0]:
            raise RapidError("ERR_ARGVALERR", f"an array of {dims[0]} {type_} expected")
        return RArray(type_, [convert(type_, v, dims[1:]) for v in value])
    t = base_type(type_)
    if t == "num":
        if isinstance(value, bool) or not isinstance(value, float | int):
            raise RapidError("ERR_ARGVALERR", f"num expected, got {value!r}")
        return num(float(value))
    if t == "string":
        if not isinstance(value, str):
            raise RapidError("ERR_ARGVALERR", f"string expected, got {value!r}")
        return string(value)
    if t == "bool":
        if not isinstance(value, bool):
            raise RapidError("ERR_ARGVALERR", f"bool expected, got {value!r}")
        return value
    if t in RECORDS:
        if isinstance(value, Record):
            if value.type != t:
                raise RapidError("ERR_ARGVALERR", f"{t} expected, got {value.type}")
            return value.copy()
        fields = RECORDS[t]
        if not isinstance(value, list) or len(value) != len(fields):
            raise RapidError("ERR_ARGVALERR", f"{t} has {len(fields)} components")
        return Record(t, {n: convert(ft, v) for (n, ft), v in zip(fields, value, strict=True)})
    if t == "rawbytes":
        if not isinstance(value, RawBytes):
            raise RapidError("ERR_ARGVALERR", f"rawbytes expected, got {value!r}")
        return value.copy()
    if t in OPAQUE:
        return value
    raise RapidError("ERR_ARGVALERR", f"unknown data type {type_}")


def record(type_: str, *values: Any) -> Record:
    return convert(type_, list(values))


def is_integer(x: float) -> bool:
    return math.isfinite(x) and x == int(x)
