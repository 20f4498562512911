"""rawbytes (RAPID reference, data type rawbytes; option Socket Messaging): a buffer of at most
1024 bytes and its valid length, packed and unpacked by the program and sent or received whole
by SocketSend/SocketReceive \\RawData.

- PackRawBytes Value, RawData [\\Network], StartIndex \\Hex1 | \\IntX | \\Float4 | \\ASCII: a
  byte (0..255), an integer of IntX's size (USINT 1, UINT 2, UDINT 4,
  ULINT 8 bytes unsigned; SINT, INT, DINT, LINT the signed ones, given as -1, -2, -4, -8), a
  4-byte float, or a string's characters; little-endian unless \\Network (big-endian). The
  valid length grows to the last byte written; a start beyond it + 1 is ERR_OUTOFBND.
- UnpackRawBytes RawData [\\Network], StartIndex, Value \\Hex1 | \\IntX | \\Float4 | \\ASCII:=n.
- CopyRawBytes From, FromIndex, To, ToIndex [\\NoOfBytes]; ClearRawBytes Raw [\\FromIndex];
  RawBytesLen(Raw).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from simulators.rapid.builtins import builtin
from simulators.rapid.errors import RapidError
from simulators.rapid.values import RawBytes, is_integer, num, string

INT_KINDS = {1: "B", 2: "H", 4: "I", 8: "Q", -1: "b", -2: "h", -4: "i", -8: "q"}


def _start(raw: RawBytes, index: float, size: int) -> int:
    """The 0-based start of `size` bytes at 1-based `index` (within 1024 bytes)."""
    i = int(index)
    if i != index or not 1 <= i or i - 1 + size > RawBytes.MAX:
        raise RapidError("ERR_OUTOFBND", f"{size} bytes at index {index:g}: a rawbytes holds "
                         f"{RawBytes.MAX}")
    return i - 1


def _write(raw: RawBytes, i: int, data: bytes) -> None:
    """Bytes written from 0-based `i` (a gap before them filled with zeros)."""
    buf = bytearray(raw.data.ljust(i, b"\0"))
    buf[i:i + len(data)] = data
    raw.data = bytes(buf)


def _int_format(opt: dict) -> str:
    kind = int(opt["intx"])
    if kind not in INT_KINDS:
        raise RapidError("ERR_ARGVALERR", f"\\IntX {kind}: not USINT, UINT, UDINT, ULINT, SINT,"
                         " INT, DINT or LINT")
    return INT_KINDS[kind]


def _encoded(value: Any, opt: dict) -> bytes:
    order = ">" if opt.get("network") else "<"
    if opt.get("hex1"):
        if not (is_integer(value) and 0 <= value <= 255):
            raise RapidError("ERR_ARGVALERR", f"\\Hex1 packs a byte (0..255), not {value!r}")
        return bytes([int(value)])
    if "intx" in opt:
        try:
            return struct.pack(order + _int_format(opt), int(value))
        except struct.error:
            raise RapidError("ERR_ARGVALERR", f"{value:g} does not fit \\IntX") from None
    if opt.get("float4"):
        return struct.pack(order + "f", value)
    if opt.get("ascii"):
        return value.encode("latin-1")
    raise RapidError("ERR_ARGVALERR", "PackRawBytes needs \\Hex1, \\IntX, \\Float4 or \\ASCII")


@builtin("PackRawBytes", "proc", refs=(1,), opts=("Network", "Hex1", "IntX", "Float4", "ASCII"))
def _pack(task: Any, pos: list, opt: dict) -> None:
    value, ref, index = pos
    raw: RawBytes = ref.value
    data = _encoded(value, opt)
    _write(raw, _start(raw, index, len(data)), data)


@builtin("UnpackRawBytes", "proc", refs=(2,), opts=("Network", "Hex1", "IntX", "Float4", "ASCII"))
def _unpack(task: Any, pos: list, opt: dict) -> None:
    raw, index, target = pos
    order = ">" if opt.get("network") else "<"
    decode: Callable[[bytes], Any]
    if opt.get("hex1"):
        size, decode = 1, (lambda b: float(b[0]))
    elif "intx" in opt:
        fmt = order + _int_format(opt)
        size, decode = struct.calcsize(fmt), (lambda b: num(float(struct.unpack(fmt, b)[0])))
    elif opt.get("float4"):
        size, decode = 4, (lambda b: num(struct.unpack(order + "f", b)[0]))
    elif "ascii" in opt:
        size, decode = int(opt["ascii"]), (lambda b: string(b.decode("latin-1")))
    else:
        raise RapidError("ERR_ARGVALERR",
                         "UnpackRawBytes needs \\Hex1, \\IntX, \\Float4 or \\ASCII")
    i = _start(raw, index, size)
    if i + size > len(raw.data):
        raise RapidError("ERR_OUTOFBND", f"{size} bytes from {index:g}: the rawbytes holds "
                         f"{len(raw.data)}")
    target.set(decode(raw.data[i:i + size]))


@builtin("CopyRawBytes", "proc", refs=(2,), opts=("NoOfBytes",))
def _copy(task: Any, pos: list, opt: dict) -> None:
    source, start, ref, to_index = pos
    first = _start(source, start, 0)
    n = int(opt.get("noofbytes", len(source.data) - first))
    if n < 0 or first + n > len(source.data):
        raise RapidError("ERR_OUTOFBND", f"{n} bytes from {start:g}: the source holds "
                         f"{len(source.data)}")
    chunk = source.data[first:first + n]
    raw: RawBytes = ref.value
    _write(raw, _start(raw, to_index, len(chunk)), chunk)


@builtin("ClearRawBytes", "proc", refs=(0,), opts=("FromIndex",))
def _clear(task: Any, pos: list, opt: dict) -> None:
    raw: RawBytes = pos[0].value
    keep = int(opt.get("fromindex", 1)) - 1
    raw.data = raw.data[:max(0, keep)]


@builtin("RawBytesLen", "func")
def _len(task: Any, pos: list, opt: dict) -> float:
    return float(len(pos[0].data))
