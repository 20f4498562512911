"""The controller wire protocol v1 (docs/protocol.md) as bytes in, messages out: no I/O.

Every frame, both directions, is 80 ASCII bytes: a payload of 1-79 printable characters (no
`#`), `#`, then spaces. Payloads are `SEQ VERB [args...]`; the thesis's data packets (Table 12)
are `SEQ j|p FLAG IDX v1..v6`.

`encode(message) -> bytes` makes one frame; `Decoder.feed(data) -> list[Message]` takes any
chunks (TCP splits and merges) and returns the messages completed so far. A malformed frame raises
`FramingError` (fatal: the decoder refuses further input); a malformed payload in a good frame
raises `PayloadError` with the ERR code to answer, and the frames after it stay buffered for the
next `feed`. Nothing else is ever raised.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal, TypeVar, Union

from protocol.errors import FramingError, PayloadError

FRAME_LEN = 80
MAX_SEQ = 999_999
MAX_LIST = 200
PROTOCOL_VERSION = 1
Lists = Literal["CAL", "PERF"]
Modes = Literal["AUTO", "STEP"]
States = Literal["IDLE", "MOVING", "WAITING", "FAULT"]
Loaded = Literal["CAL", "PERF", "NONE"]  # the list a STAT reply names: none loaded yet
LISTS: tuple[Lists, ...] = ("CAL", "PERF")
MODES: tuple[Modes, ...] = ("AUTO", "STEP")
STATES: tuple[States, ...] = ("IDLE", "MOVING", "WAITING", "FAULT")
LOADED: tuple[Loaded, ...] = ("CAL", "PERF", "NONE")
FIRST, MIDDLE, LAST = 0, 1, 2


def flag_of(idx: int, count: int) -> int:
    """A data packet's FLAG: LAST for the last of the list (a list of one too), FIRST for the
    first, MIDDLE between (Table 12)."""
    return LAST if idx == count - 1 else (FIRST if idx == 0 else MIDDLE)
_NUMBER = re.compile(r"-?[0-9]+(\.[0-9]+)?\Z")
_INT = re.compile(r"[0-9]+\Z")

# ERR codes (protocol.md)
BAD_FRAME, UNKNOWN_VERB, BAD_ARGUMENTS, WRONG_STATE, LIST_TOO_LONG, VERSION = 10, 11, 12, 13, 14, 15
BUSY = 16  # another client owns the controller: sent with SEQ 0, then the connection closes
OUT_OF_LIMITS, MOTION_ERROR, ABORTED, NOT_ALLOWED = 20, 21, 22, 23

Six = tuple[float, float, float, float, float, float]


def six_of(values: Iterable[float], what: str = "a target") -> Six:
    """Six numbers as a message carries them (a joint target or a pose); ValueError naming
    `what` when there are not six."""
    numbers = tuple(float(v) for v in values)
    if len(numbers) != 6:
        raise ValueError(f"{what} has 6 values, got {len(numbers)}")
    a, b, c, d, e, f = numbers
    return (a, b, c, d, e, f)


# -- messages ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Helo:
    seq: int
    version: int = PROTOCOL_VERSION


@dataclass(frozen=True)
class Stat:
    """The STAT request (no arguments)."""

    seq: int


@dataclass(frozen=True)
class Load:
    seq: int
    list: Lists
    count: int


@dataclass(frozen=True)
class Run:
    seq: int
    list: Lists
    mode: Modes


@dataclass(frozen=True)
class Go:
    seq: int
    idx: int


@dataclass(frozen=True)
class MovJ:
    seq: int
    joints_deg: Six


@dataclass(frozen=True)
class Home:
    seq: int


@dataclass(frozen=True)
class Zero:
    seq: int
    joints_deg: Six


@dataclass(frozen=True)
class Abrt:
    seq: int


@dataclass(frozen=True)
class Bye:
    seq: int


@dataclass(frozen=True)
class Joints:
    """`j` packet: joint space, degrees (4 decimals)."""

    seq: int
    flag: int
    idx: int
    values: Six


@dataclass(frozen=True)
class Pose:
    """`p` packet: tool0 in the base frame, x y z mm (3 decimals), rx ry rz deg (4 decimals),
    R = Rz(rz) Ry(ry) Rx(rx)."""

    seq: int
    flag: int
    idx: int
    values: Six


@dataclass(frozen=True)
class Ack:
    seq: int
    verb: str
    args: tuple[str, ...] = ()


@dataclass(frozen=True)
class Err:
    seq: int
    code: int
    text: str


@dataclass(frozen=True)
class StatReply:
    seq: int
    state: States
    mode: Modes
    list: Loaded
    idx: int
    count: int
    last_seq: int


@dataclass(frozen=True)
class Wait:
    seq: int
    idx: int


@dataclass(frozen=True)
class Done:
    seq: int
    verb: str


Request = Union[Helo, Stat, Load, Run, Go, MovJ, Home, Zero, Abrt, Bye]  # noqa: UP007
Reply = Union[Ack, Err, StatReply, Wait, Done]  # noqa: UP007
Data = Union[Joints, Pose]  # noqa: UP007
Message = Union[Request, Reply, Data]  # noqa: UP007

REQUEST_VERBS = ("HELO", "STAT", "LOAD", "RUN", "GO", "MOVJ", "HOME", "ZERO", "ABRT", "BYE")
REPLY_VERBS = ("ACK", "ERR", "STAT", "WAIT", "DONE")
DATA_VERBS = ("j", "p")


# -- encoding ------------------------------------------------------------------------------------

def _num(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    if "e" in text or "inf" in text or "nan" in text:
        raise ValueError(f"{value!r} cannot be written as a protocol number")
    return "0." + "0" * decimals if float(text) == 0.0 else text  # no "-0.0000"


def _check_seq(msg: Message) -> None:
    low = 0 if isinstance(msg, Err) else 1  # SEQ 0 is the controller's alone (the busy ERR)
    if not low <= msg.seq <= MAX_SEQ:
        raise ValueError(f"SEQ must be {low}..{MAX_SEQ}, got {msg.seq}")


def payload_of(msg: Message) -> str:
    """The payload text of a message (without framing)."""
    _check_seq(msg)
    s = msg.seq
    match msg:
        case Helo():
            return f"{s} HELO {msg.version}"
        case Stat():
            return f"{s} STAT"
        case Load():
            return f"{s} LOAD {msg.list} {msg.count}"
        case Run():
            return f"{s} RUN {msg.list} {msg.mode}"
        case Go():
            return f"{s} GO {msg.idx}"
        case MovJ() | Zero():
            verb = "MOVJ" if isinstance(msg, MovJ) else "ZERO"
            return f"{s} {verb} " + " ".join(_num(v, 4) for v in msg.joints_deg)
        case Home():
            return f"{s} HOME"
        case Abrt():
            return f"{s} ABRT"
        case Bye():
            return f"{s} BYE"
        case Joints():
            return f"{s} j {msg.flag} {msg.idx} " + " ".join(_num(v, 4) for v in msg.values)
        case Pose():
            vals = [_num(v, 3) for v in msg.values[:3]] + [_num(v, 4) for v in msg.values[3:]]
            return f"{s} p {msg.flag} {msg.idx} " + " ".join(vals)
        case Ack():
            return " ".join([str(s), "ACK", msg.verb, *msg.args])
        case Err():
            return f"{s} ERR {msg.code} {msg.text}"
        case StatReply():
            return (f"{s} STAT {msg.state} {msg.mode} {msg.list} {msg.idx} {msg.count} "
                    f"{msg.last_seq}")
        case Wait():
            return f"{s} WAIT {msg.idx}"
        case Done():
            return f"{s} DONE {msg.verb}"
    raise TypeError(f"not a protocol message: {msg!r}")


def frame(payload: str) -> bytes:
    """An 80-byte frame around a payload of 1-79 printable characters without '#'."""
    if not 1 <= len(payload) <= FRAME_LEN - 1:
        raise ValueError(f"payload must be 1-79 characters, got {len(payload)}: {payload!r}")
    if "#" in payload or any(not 0x20 <= ord(c) <= 0x7E for c in payload):
        raise ValueError(f"payload must be printable ASCII without '#': {payload!r}")
    return (payload + "#").ljust(FRAME_LEN).encode("ascii")


def encode(msg: Message) -> bytes:
    return frame(payload_of(msg))


# -- decoding ------------------------------------------------------------------------------------

def unframe(data: bytes) -> str:
    """The payload of one 80-byte frame, or FramingError."""
    if len(data) != FRAME_LEN:
        raise FramingError(f"a frame is {FRAME_LEN} bytes, got {len(data)}")
    bad = [b for b in data if not 0x20 <= b <= 0x7E]
    if bad:
        raise FramingError(f"non-printable byte 0x{bad[0]:02x} in frame")
    end = data.find(b"#")
    if end < 1:
        raise FramingError("no '#' in frame" if end < 0 else "empty payload before '#'")
    if data[end + 1:].strip(b" "):
        raise FramingError("characters other than spaces after '#'")
    return data[:end].decode("ascii")


def _number(tok: str, seq: int) -> float:
    if not _NUMBER.match(tok):
        raise PayloadError(f"'{tok}' is not a protocol number", BAD_ARGUMENTS, seq)
    return float(tok)


def _integer(tok: str, seq: int, what: str, lo: int = 0, hi: int = MAX_SEQ) -> int:
    if not _INT.match(tok) or not lo <= int(tok) <= hi:
        raise PayloadError(f"{what} must be an integer {lo}..{hi}, got '{tok}'", BAD_ARGUMENTS,
                           seq)
    return int(tok)


# What a value may be: a RAPID num is a 32-bit float, and no robot turns a joint more than ten
# times or reaches 100 m; a larger number is a broken peer, never a target.
MAX_JOINT_DEG = 3600.0
MAX_POSITION_MM = 100_000.0
MAX_ANGLE_DEG = 360.0


def _six(args: list[str], seq: int, bounds: tuple[float, ...]) -> Six:
    if len(args) != 6:
        raise PayloadError(f"expected 6 values, got {len(args)}", BAD_ARGUMENTS, seq)
    a, b, c, d, e, f = values = tuple(_number(t, seq) for t in args)
    for k, (v, bound) in enumerate(zip(values, bounds, strict=True)):
        if abs(v) > bound:
            raise PayloadError(f"value {k + 1} is {args[k]}: beyond +-{bound:g}", BAD_ARGUMENTS,
                               seq)
    return (a, b, c, d, e, f)


_JOINT_BOUNDS = (MAX_JOINT_DEG,) * 6
_POSE_BOUNDS = (MAX_POSITION_MM,) * 3 + (MAX_ANGLE_DEG,) * 3


_Word = TypeVar("_Word", bound=str)


def _choice(tok: str, options: tuple[_Word, ...], seq: int, what: str) -> _Word:
    """`tok` as the option it spells (typed as the options are), or PayloadError."""
    for option in options:
        if tok == option:
            return option
    raise PayloadError(f"{what} must be one of {', '.join(options)}, got '{tok}'",
                       BAD_ARGUMENTS, seq)


def parse_payload(payload: str) -> Message:
    """A message from a payload, or PayloadError."""
    if payload != payload.strip(" ") or "  " in payload:
        raise PayloadError("tokens must be separated by single spaces", BAD_FRAME)
    tokens = payload.split(" ")
    if not _INT.match(tokens[0]) or not 0 <= int(tokens[0]) <= MAX_SEQ or (
            int(tokens[0]) == 0 and tokens[1:2] != ["ERR"]):
        raise PayloadError(f"SEQ must be an integer 1..{MAX_SEQ} (0 only on the controller's "
                           f"busy ERR), got '{tokens[0]}'", BAD_FRAME)
    seq = int(tokens[0])
    if len(tokens) < 2:
        raise PayloadError("no verb", UNKNOWN_VERB, seq)
    verb, args = tokens[1], tokens[2:]

    def need(n: int) -> None:
        if len(args) != n:
            raise PayloadError(f"{verb} takes {n} argument(s), got {len(args)}", BAD_ARGUMENTS,
                               seq)

    if verb in ("j", "p"):
        if len(args) != 8:
            raise PayloadError(f"a {verb} packet has FLAG IDX and 6 values", BAD_ARGUMENTS, seq)
        flag = _integer(args[0], seq, "FLAG", 0, 2)
        idx = _integer(args[1], seq, "IDX", 0, MAX_LIST - 1)
        values = _six(args[2:], seq, _JOINT_BOUNDS if verb == "j" else _POSE_BOUNDS)
        return Joints(seq, flag, idx, values) if verb == "j" else Pose(seq, flag, idx, values)
    match verb:
        case "HELO":
            need(1)
            return Helo(seq, _integer(args[0], seq, "version", 0, 999))
        case "STAT" if not args:
            return Stat(seq)
        case "STAT":
            need(6)
            return StatReply(seq, _choice(args[0], STATES, seq, "STATE"),
                             _choice(args[1], MODES, seq, "MODE"),
                             _choice(args[2], LOADED, seq, "LIST"),
                             _integer(args[3], seq, "IDX", 0, MAX_LIST),
                             _integer(args[4], seq, "COUNT", 0, MAX_LIST),
                             _integer(args[5], seq, "LASTSEQ", 0, MAX_SEQ))
        case "LOAD":
            need(2)
            name = _choice(args[0], LISTS, seq, "list")
            if _INT.match(args[1]) and int(args[1]) > MAX_LIST:  # any length of digits
                raise PayloadError(f"a list holds at most {MAX_LIST} poses, not {args[1]}",
                                   LIST_TOO_LONG, seq)
            return Load(seq, name, _integer(args[1], seq, "N", 0, MAX_LIST))
        case "RUN":
            need(2)
            return Run(seq, _choice(args[0], LISTS, seq, "list"),
                       _choice(args[1], MODES, seq, "mode"))
        case "GO":
            need(1)
            return Go(seq, _integer(args[0], seq, "IDX", 0, MAX_LIST - 1))
        case "MOVJ" | "ZERO":
            values = _six(args, seq, _JOINT_BOUNDS)
            return MovJ(seq, values) if verb == "MOVJ" else Zero(seq, values)
        case "HOME" | "ABRT" | "BYE":
            need(0)
            return Home(seq) if verb == "HOME" else Abrt(seq) if verb == "ABRT" else Bye(seq)
        case "ACK":
            if not args:
                raise PayloadError("ACK names the verb it acknowledges", BAD_ARGUMENTS, seq)
            return Ack(seq, args[0], tuple(args[1:]))
        case "ERR":
            if len(args) < 2:
                raise PayloadError("ERR has a CODE and a TEXT", BAD_ARGUMENTS, seq)
            return Err(seq, _integer(args[0], seq, "CODE", 0, 99), " ".join(args[1:]))
        case "WAIT":
            need(1)
            return Wait(seq, _integer(args[0], seq, "IDX", 0, MAX_LIST - 1))
        case "DONE":
            need(1)
            return Done(seq, args[0])
    raise PayloadError(f"unknown verb '{verb}'", UNKNOWN_VERB, seq)


class Decoder:
    """Incremental decoder: feed it any chunks, get whole messages back."""

    def __init__(self) -> None:
        self._buffer = bytearray()
        self._broken: FramingError | None = None

    @property
    def pending_bytes(self) -> int:
        return len(self._buffer)

    def feed(self, data: bytes = b"") -> list[Message]:
        """Messages completed by `data`. Raises FramingError (then and on every later call) or
        PayloadError (the frames after the bad one stay buffered: call `feed()` again)."""
        if self._broken is not None:
            raise FramingError(f"decoder stopped after a framing error: {self._broken}")
        self._buffer += data
        out: list[Message] = []
        while len(self._buffer) >= FRAME_LEN:
            chunk = bytes(self._buffer[:FRAME_LEN])
            del self._buffer[:FRAME_LEN]
            try:
                payload = unframe(chunk)
            except FramingError as err:
                self._broken = err
                if out:  # hand over what came before; the error comes on the next call
                    self._buffer[:0] = chunk
                    self._broken = None
                    return out
                raise
            try:
                out.append(parse_payload(payload))
            except PayloadError:
                if out:  # the good messages first; this frame raises on the next call
                    self._buffer[:0] = chunk
                    return out
                raise
        return out
