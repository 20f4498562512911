"""The measuring arm's serial line (docs/protocol.md): one probed point per line,

    $PT,SEQ,LABEL,X,Y,Z*CS\\r\\n

SEQ counts lines from 1; LABEL names the feature (P1, P2, P3 for the flange holes); X, Y, Z in mm
with 4 decimals in the arm's frame; CS is the XOR of every byte between `$` and `*` as two
upper-case hex digits (NMEA 0183). A point out of the arm's reach is not measured, and the stream
says so with the same framing: `$NM,SEQ,LABEL,REASON*CS`.

The reading is strict, exactly as written above: a line must end in CR LF, the checksum must be
two upper-case hex digits, every coordinate must have exactly 4 decimals and lie within
`MAX_COORD_MM` of the arm's origin (no portable arm reaches further; a larger number is a
corrupted line, not a measurement). Anything else is an `ArmProblem`, never a point.

`ArmLineDecoder` is the codec (bytes in, items out, no I/O): good lines become `ArmPoint` or
`ArmNotMeasured`; a line with a bad checksum, a bad field or a gap in SEQ becomes an `ArmProblem`
that is reported and never used as a measurement. `ArmReader` reads it through
`serial.serial_for_url` (a real port, `socket://host:port`, `loop://`), or through the port its
`connect` gives (a link in memory to an emulated arm: protocol.memory's `serial_link`).
"""

from __future__ import annotations

import re
import socket
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Union

import serial

from protocol.errors import ArmLineError, LinkTimeoutError
from protocol.memory import SerialPort

HOLE_LABELS = ("P1", "P2", "P3")
_NUMBER = re.compile(r"-?[0-9]{1,5}\.[0-9]{4}\Z")
_LABEL = re.compile(r"[A-Za-z0-9_]{1,16}\Z")
_SEQ = re.compile(r"[1-9][0-9]{0,8}\Z")
_CHECKSUM = re.compile(r"[0-9A-F]{2}\Z")
MAX_LINE = 200
MAX_COORD_MM = 5000.0


@dataclass(frozen=True)
class ArmPoint:
    seq: int
    label: str
    xyz_mm: tuple[float, float, float]


@dataclass(frozen=True)
class ArmNotMeasured:
    seq: int
    label: str
    reason: str


@dataclass(frozen=True)
class ArmProblem:
    """A line that must not be used: what was wrong and the raw text."""

    reason: str
    raw: bytes


ArmItem = Union[ArmPoint, ArmNotMeasured, ArmProblem]  # noqa: UP007


def checksum(body: str) -> str:
    cs = 0
    for b in body.encode("ascii"):
        cs ^= b
    return f"{cs:02X}"


def encode_point(seq: int, label: str, xyz_mm: tuple[float, float, float] | list[float]) -> bytes:
    body = f"PT,{seq},{label}," + ",".join(f"{v:.4f}" for v in xyz_mm)
    return f"${body}*{checksum(body)}\r\n".encode("ascii")


def encode_not_measured(seq: int, label: str, reason: str) -> bytes:
    body = f"NM,{seq},{label},{reason}"
    return f"${body}*{checksum(body)}\r\n".encode("ascii")


def parse_line(raw: bytes) -> ArmPoint | ArmNotMeasured:
    """One CRLF-terminated line -> an item, or ArmLineError saying what is wrong."""
    if not raw.endswith(b"\r\n"):
        raise ArmLineError("line does not end in CR LF")
    try:
        text = raw[:-2].decode("ascii")
    except UnicodeDecodeError:
        raise ArmLineError("not ASCII") from None
    if not text.startswith("$") or "*" not in text:
        raise ArmLineError("not a $...*CS line")
    body, _, cs = text[1:].rpartition("*")
    if not _CHECKSUM.match(cs) or checksum(body) != cs:
        raise ArmLineError(f"bad checksum {cs!r} (expected {checksum(body)}, two upper-case "
                           "hex digits)")
    fields = body.split(",")
    if fields[0] == "PT" and len(fields) == 6:
        _, seq, label, *xyz = fields
        if not all(_NUMBER.match(v) for v in xyz):
            raise ArmLineError(f"bad coordinate in {xyz} (mm with exactly 4 decimals)")
        point = (float(xyz[0]), float(xyz[1]), float(xyz[2]))
        if max(abs(v) for v in point) > MAX_COORD_MM:
            raise ArmLineError(f"coordinate beyond {MAX_COORD_MM:g} mm in {xyz}: no arm "
                               "reaches there")
    elif fields[0] == "NM" and len(fields) == 4:
        _, seq, label, reason = fields
        point = None
    else:
        raise ArmLineError(f"unknown sentence or field count: {fields[0]!r}, {len(fields)} fields")
    if not _SEQ.match(seq):
        raise ArmLineError(f"bad SEQ {seq!r}")
    if not _LABEL.match(label):
        raise ArmLineError(f"bad LABEL {label!r}")
    if point is None:
        return ArmNotMeasured(int(seq), label, reason)
    return ArmPoint(int(seq), label, point)


class ArmLineDecoder:
    """Incremental: feed bytes, get items; checks the SEQ sequence across lines."""

    def __init__(self) -> None:
        self._buffer = bytearray()
        self.last_seq = 0

    def feed(self, data: bytes) -> list[ArmItem]:
        self._buffer += data
        out: list[ArmItem] = []
        while True:
            end = self._buffer.find(b"\n")
            if end < 0:
                if len(self._buffer) > MAX_LINE:
                    out.append(ArmProblem("line too long, no end", bytes(self._buffer)))
                    self._buffer.clear()
                return out
            raw = bytes(self._buffer[:end + 1])
            del self._buffer[:end + 1]
            try:
                item = parse_line(raw)
            except ArmLineError as err:
                out.append(ArmProblem(str(err), raw))
                continue
            if self.last_seq and item.seq != self.last_seq + 1:
                out.append(ArmProblem(f"SEQ gap: expected {self.last_seq + 1}, got {item.seq}",
                                      raw))
                self.last_seq = item.seq
                continue  # the line after a gap is not trusted either
            self.last_seq = item.seq
            out.append(item)


@dataclass(frozen=True)
class HoleSet:
    """The three flange holes of one pose, mm in the arm's frame."""

    points_mm: tuple[tuple[float, float, float], ...]  # P1, P2, P3
    seqs: tuple[int, ...]


class ArmReader:
    """Reads probed points from the arm through pyserial (`serial_for_url`), or through the
    port `connect` opens (then `url` only names it in messages)."""

    def __init__(self, url: str, read_timeout_s: float = 0.1, *,
                 connect: Callable[[], SerialPort] | None = None):
        self.url = url
        with self._port_errors():
            if connect is None:
                self.port: SerialPort = _open_port(url, read_timeout_s)
            else:
                self.port = connect()
                self.port.timeout = read_timeout_s
        self.decoder = ArmLineDecoder()
        self.problems: list[ArmProblem] = []

    @contextmanager
    def _port_errors(self) -> Iterator[None]:
        """pyserial's and the OS's errors as this package's (callers catch LinkError)."""
        try:
            yield
        except (serial.SerialException, OSError) as err:
            raise ArmLineError(f"the measuring arm's port {self.url} failed: {err}") from err

    def close(self) -> None:
        _close_port(self.port)

    def __enter__(self) -> ArmReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _available(self) -> bytes:
        """Everything already received, without waiting. (`in_waiting` is a byte count on a
        real port but only 0 or 1 on socket://, so read non-blocking instead.)"""
        old = self.port.timeout
        self.port.timeout = 0
        try:
            with self._port_errors():
                data: bytes = self.port.read(65536)  # pyserial's read is untyped
                return data
        finally:
            self.port.timeout = old

    def read_items(self, timeout_s: float) -> list[ArmItem]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._port_errors():
                data = self.port.read(1)  # waits up to the port's read time-out for something
            if data:
                items = self.decoder.feed(data + self._available())
                if items:
                    return items
        return []

    def drain(self) -> int:
        """Discard whatever the arm sent so far (before a move: the next triple is then the new
        pose's); returns the number of items dropped."""
        return len(self.decoder.feed(self._available()))

    def request(self) -> None:
        """Ask an automated arm (the emulator) to probe now."""
        with self._port_errors():
            self.port.write(b"MEASURE\r\n")

    def read_holes(self, timeout_s: float = 5.0) -> HoleSet:
        """The next complete triple P1, P2, P3, in that order. A problem line, a label out of
        order or repeated, or a foreign label breaks the triple: it is kept in `problems` and
        the next P1 starts afresh. A not-measured hole raises ArmLineError; silence raises
        LinkTimeoutError."""
        deadline = time.monotonic() + timeout_s
        got: list[ArmPoint] = []
        while time.monotonic() < deadline:
            for item in self.read_items(max(0.0, deadline - time.monotonic())):
                if isinstance(item, ArmProblem):
                    self.problems.append(item)
                    got.clear()
                elif isinstance(item, ArmNotMeasured):
                    raise ArmLineError(f"hole {item.label} not measured: {item.reason}")
                elif item.label == HOLE_LABELS[len(got)]:
                    got.append(item)
                    if len(got) == len(HOLE_LABELS):
                        return HoleSet(tuple(p.xyz_mm for p in got), tuple(p.seq for p in got))
                else:
                    expected = HOLE_LABELS[len(got)]
                    self.problems.append(ArmProblem(
                        f"label {item.label} where {expected} was expected: the triple "
                        f"{'-'.join(p.label for p in got) or '(none)'} is not used",
                        encode_point(item.seq, item.label, item.xyz_mm)))
                    got = [item] if item.label == HOLE_LABELS[0] else []
        raise LinkTimeoutError(f"no complete P1-P3 set from the arm at {self.url} within "
                               f"{timeout_s:g} s")


def _open_port(url: str, timeout_s: float) -> SerialPort:
    """The port at `url`, open, its read time-out set before opening (an rfc2217:// port
    negotiates its settings again at each change once open)."""
    opening = serial.serial_for_url(url, timeout=timeout_s, do_not_open=True)
    try:
        opening.open()
    except BaseException:  # pyserial's socket:// open fails after it connected (a reset while
        _close_port(opening)  # it clears the input) and drops the socket
        raise
    port: SerialPort = opening
    return port


def _close_port(port: SerialPort) -> None:
    """Close the port for good: pyserial's socket:// close() shuts the socket down first and
    skips its close() when that fails (the arm already hung up: ENOTCONN), and does nothing on
    a port whose open failed half-way; either way the descriptor was left open."""
    sock: socket.socket | None = getattr(port, "_socket", None)
    port.close()
    if sock is not None:
        sock.close()
