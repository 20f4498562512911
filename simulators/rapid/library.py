"""The RAPID built-ins that are neither sockets nor motion: strings, arithmetic, orientations,
the operator interface, waiting and stopping, the event log."""

from __future__ import annotations

import functools
import math
import re
import struct
import time
from typing import Any

import numpy as np

from screwcal.kinematics.pose import (
    euler_zyx_deg_from_rotation,
    quaternion_wxyz_from_rotation,
    rotation_from_euler_zyx_deg,
    rotation_from_quaternion_wxyz,
)
from screwcal.rapid import ast as A  # noqa: N812 - the node classes
from simulators.rapid.builtins import Lazy, builtin
from simulators.rapid.control import ExitCycle, Stopped
from simulators.rapid.errors import RapidError
from simulators.rapid.frames import unit_wxyz
from simulators.rapid.values import RArray, Record, convert, is_integer, num, record, string

# ------------------------------------------------------------------ strings


def _pos_arg(s: str, pos: float, what: str, allow_end: bool = True) -> int:
    if not is_integer(pos) or not 1 <= pos <= len(s) + (1 if allow_end else 0):
        raise RapidError("ERR_ARGVALERR", f"{what} {pos:g} outside the string of {len(s)}")
    return int(pos)


@builtin("StrLen", "func")
def _strlen(task: Any, pos: list, opt: dict) -> float:
    return float(len(pos[0]))


@builtin("StrPart", "func")
def _strpart(task: Any, pos: list, opt: dict) -> str:
    s, start, n = pos
    if not (is_integer(start) and is_integer(n)) or start < 1 or n < 0 or \
            start + n - 1 > len(s):
        raise RapidError("ERR_ARGVALERR",
                         f"StrPart({start:g}, {n:g}) outside the string of {len(s)}")
    return s[int(start) - 1:int(start) - 1 + int(n)]


@builtin("StrFind", "func", opts=("NotInSet",))
def _strfind(task: Any, pos: list, opt: dict) -> float:
    """The first position from ChPos holding a character of Set (\\NotInSet: not of Set);
    StrLen + 1 when there is none."""
    s, start, chars = pos
    i = _pos_arg(s, start, "StrFind position")
    found = _char_set(chars, bool(opt.get("notinset"))).search(s, i - 1)
    return float(len(s) + 1 if found is None else found.start() + 1)


_CHAR_SETS: dict[tuple[str, bool], re.Pattern[str]] = {}


def _char_set(chars: str, outside: bool) -> re.Pattern[str]:
    """One character of `chars` (`outside`: any other character), compiled once per set (a
    program's sets are its constants; a set made at run time is kept among 256 at most)."""
    pattern = _CHAR_SETS.get((chars, outside))
    if pattern is None:
        if len(_CHAR_SETS) >= 256:
            _CHAR_SETS.clear()
        members = "".join(re.escape(c) for c in dict.fromkeys(chars))
        text = ("[^" + members + "]" if outside else "[" + members + "]") if members else \
            ("(?s:.)" if outside else "(?!)")
        pattern = _CHAR_SETS[(chars, outside)] = re.compile(text)
    return pattern


@builtin("StrMemb", "func")
def _strmemb(task: Any, pos: list, opt: dict) -> bool:
    s, at, chars = pos
    return s[_pos_arg(s, at, "StrMemb position", allow_end=False) - 1] in chars


@builtin("StrMatch", "func")
def _strmatch(task: Any, pos: list, opt: dict) -> float:
    s, start, pattern = pos
    i = _pos_arg(s, start, "StrMatch position")
    k = s.find(pattern, i - 1)
    return float(len(s) + 1 if k < 0 else k + 1)


_NUM_TEXT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\Z")


@builtin("StrToVal", "func", refs=(1,))
def _strtoval(task: Any, pos: list, opt: dict) -> bool:
    """A num's text (RAPID literal syntax) into Val: TRUE, or FALSE and Val unchanged."""
    s, target = pos
    if isinstance(target.value, float):
        if not _NUM_TEXT.match(s):
            return False
        try:
            target.value = num(float(s))
        except RapidError:
            return False
        return True
    if isinstance(target.value, bool):
        if s not in ("TRUE", "FALSE"):
            return False
        target.value = s == "TRUE"
        return True
    if isinstance(target.value, str):
        target.value = string(s)
        return True
    raise RapidError("ERR_ARGVALERR", "StrToVal into this data type is not supported")


@builtin("NumToStr", "func")
def _numtostr(task: Any, pos: list, opt: dict) -> str:
    value, dec = pos
    if not is_integer(dec) or dec < 0:
        raise RapidError("ERR_ARGVALERR", f"NumToStr decimals {dec:g}")
    text = f"{value:.{int(dec)}f}"
    if float(text) == 0.0:
        text = text.lstrip("-")
    return string(text)


_BYTE_BASES = (("hex", 16, "{:02X}"), ("okt", 8, "{:03o}"), ("bin", 2, "{:08b}"))


@builtin("StrToByte", "func", opts=("Hex", "Okt", "Bin", "Char"))
def _strtobyte(task: Any, pos: list, opt: dict) -> float:
    """A byte from its text: decimal, or \\Hex, \\Okt, \\Bin digits, or \\Char a character."""
    text = pos[0]
    if opt.get("char"):
        if len(text) != 1:
            raise RapidError("ERR_ARGVALERR", f"StrToByte \\Char of {text!r}: one character")
        return float(ord(text))
    base = next((b for key, b, _ in _BYTE_BASES if opt.get(key)), 10)
    try:
        value = int(text, base)
    except ValueError:
        value = -1
    if not 0 <= value <= 255:
        raise RapidError("ERR_ARGVALERR", f"StrToByte of {text!r}: no byte in base {base}")
    return float(value)


@builtin("ByteToStr", "func", opts=("Hex", "Okt", "Bin", "Char"))
def _bytetostr(task: Any, pos: list, opt: dict) -> str:
    """A byte's text: decimal, or \\Hex (2 digits), \\Okt (3), \\Bin (8), \\Char."""
    b = pos[0]
    if not (is_integer(b) and 0 <= b <= 255):
        raise RapidError("ERR_ARGVALERR", f"ByteToStr of {b!r}: no byte (0..255)")
    if opt.get("char"):
        return chr(int(b))
    fmt = next((f for key, _, f in _BYTE_BASES if opt.get(key)), "{:d}")
    return fmt.format(int(b))


@builtin("ValToStr", "func")
def _valtostr(task: Any, pos: list, opt: dict) -> str:
    v = pos[0]
    if isinstance(v, bool):
        return "TRUE" if v else "FALSE"
    if isinstance(v, float):
        return string(f"{v:.9g}" if not is_integer(v) else f"{int(v)}")
    return string(repr(v) if not isinstance(v, str) else v)


# ------------------------------------------------------------------ arithmetic


@builtin("Trunc", "func", opts=("Dec",))
def _trunc(task: Any, pos: list, opt: dict) -> float:
    dec = int(opt.get("dec", 0.0))
    f = 10.0 ** dec
    return num(math.trunc(pos[0] * f) / f)


@builtin("Round", "func", opts=("Dec",))
def _round(task: Any, pos: list, opt: dict) -> float:
    dec = int(opt.get("dec", 0.0))
    f = 10.0 ** dec
    v = pos[0] * f
    return num(math.floor(abs(v) + 0.5) * math.copysign(1, v) / f)


@builtin("Abs", "func")
def _abs(task: Any, pos: list, opt: dict) -> float:
    return abs(pos[0])


@builtin("Sqrt", "func")
def _sqrt(task: Any, pos: list, opt: dict) -> float:
    if pos[0] < 0:
        raise RapidError("ERR_ARGVALERR", "Sqrt of a negative num")
    return num(math.sqrt(pos[0]))


@builtin("ATan2", "func")
def _atan2(task: Any, pos: list, opt: dict) -> float:
    return num(math.degrees(math.atan2(pos[0], pos[1])))


@builtin("Incr", "proc", refs=(0,))
def _incr(task: Any, pos: list, opt: dict) -> None:
    pos[0].value = num(pos[0].value + 1)


@builtin("Decr", "proc", refs=(0,))
def _decr(task: Any, pos: list, opt: dict) -> None:
    pos[0].value = num(pos[0].value - 1)


@builtin("Add", "proc", refs=(0,))
def _addp(task: Any, pos: list, opt: dict) -> None:
    pos[0].value = num(pos[0].value + pos[1])


@builtin("Dim", "func")
def _dim(task: Any, pos: list, opt: dict) -> float:
    arr, n = pos
    for _ in range(int(n) - 1):
        arr = arr.items[0]
    if not isinstance(arr, RArray):
        raise RapidError("ERR_ARGVALERR", "Dim of what is no array")
    return float(len(arr.items))


# ------------------------------------------------------------------ orientations (R = Rz Ry Rx)


def quaternion_of(R: np.ndarray) -> tuple[float, float, float, float]:
    """(q1 = w, q2, q3, q4) of a rotation matrix, w >= 0 (RAPID's orient)."""
    w, x, y, z = quaternion_wxyz_from_rotation(R).tolist()
    return (w, x, y, z)


def _rotation_of_wxyz(q: tuple[float, float, float, float]) -> np.ndarray:
    """The rotation of an orient's four numbers (q1..q4), normalised as the controller does
    (`frames.unit_wxyz`: an unusable one is ERR_ARGVALERR)."""
    R: np.ndarray = rotation_from_quaternion_wxyz(unit_wxyz(q))
    return R


@builtin("NOrient", "func")
def _norient(task: Any, pos: list, opt: dict) -> Record:
    """The orient normalised (an unusable one, its norm more than 0.1 from 1: ERR_ARGVALERR)."""
    o = pos[0]
    f = (convert("orient", o) if isinstance(o, list) else o).f
    return record("orient", *unit_wxyz((f["q1"], f["q2"], f["q3"], f["q4"])).tolist())


@builtin("OrientZYX", "func")
def _orientzyx(task: Any, pos: list, opt: dict) -> Record:
    """orient from Euler angles (deg) about Z, then Y, then X: R = Rz Ry Rx."""
    z, y, x = pos
    return record("orient", *quaternion_of(rotation_from_euler_zyx_deg([x, y, z])))


_FOUR = struct.Struct("<4d")


@functools.lru_cache(maxsize=8)
def _euler_zyx_deg(packed: bytes) -> tuple[float, float, float]:
    """The Euler angles of one orient (its four numbers packed: -0.0 is not 0.0 here), kept
    for the next calls: a program asks for X, Y and Z of the same orient in turn (a refused
    orient raises every time: nothing is kept)."""
    w, x, y, z = _FOUR.unpack(packed)
    rx, ry, rz = euler_zyx_deg_from_rotation(_rotation_of_wxyz((w, x, y, z))).tolist()
    return rx, ry, rz


@builtin("EulerZYX", "func", opts=("X", "Y", "Z"))
def _eulerzyx(task: Any, pos: list, opt: dict) -> float:
    """One Euler angle (deg) of an orient: \\X, \\Y or \\Z of R = Rz Ry Rx."""
    q = pos[0]
    rx, ry, rz = _euler_zyx_deg(_FOUR.pack(q.f["q1"], q.f["q2"], q.f["q3"], q.f["q4"]))
    for name, angle in (("x", rx), ("y", ry), ("z", rz)):
        if opt.get(name):
            return num(angle)
    raise RapidError("ERR_ARGVALERR", "EulerZYX needs \\X, \\Y or \\Z")


# ------------------------------------------------------------------ operator interface


@builtin("TPWrite", "proc", opts=("Num",))
def _tpwrite(task: Any, pos: list, opt: dict) -> None:
    text = pos[0]
    if "num" in opt:
        text += _valtostr(task, [opt["num"]], {})
    task.pendant.write(string(text))


@builtin("TPErase", "proc")
def _tperase(task: Any, pos: list, opt: dict) -> None:
    task.pendant.erase()


@builtin("TPReadFK", "proc", refs=(0,), optrefs=("BreakFlag",), opts=("MaxTime", "BreakFlag"))
def _tpreadfk(task: Any, pos: list, opt: dict) -> None:
    """TPReadFK answer, text, FK1..FK5 [\\MaxTime] [\\BreakFlag]: the key pressed (1..5); no
    key within MaxTime is ERR_TP_MAXTIME (into BreakFlag when given, else raised)."""
    answer, text, *keys = pos
    if len(keys) != 5:
        raise RapidError("ERR_ARGVALERR", "TPReadFK takes five function-key texts")
    max_time = opt.get("maxtime")
    key = task.pendant.ask(text, tuple(keys), max_time, task.stopping)
    if key is None and task.stopping():
        raise Stopped("stopped by the controller")
    flag = opt.get("breakflag")
    if key is None:
        error = RapidError("ERR_TP_MAXTIME", f"no key pressed within {max_time:g} s")
        if flag is None:
            raise error
        flag.value = float(error.errno)
        answer.value = 0.0
        return
    if flag is not None:
        flag.value = 0.0
    answer.value = float(key)


@builtin("ErrWrite", "proc", opts=("W", "I", "RL2", "RL3", "RL4"))
def _errwrite(task: Any, pos: list, opt: dict) -> None:
    kind = "warning" if opt.get("w") else "info" if opt.get("i") else "error"
    header, reason = pos
    more = [opt[k] for k in ("rl2", "rl3", "rl4") if k in opt]
    task.log.write(kind, string(header), " ".join(string(r) for r in [reason, *more]))


@builtin("SkipWarn", "proc")
def _skipwarn(task: Any, pos: list, opt: dict) -> None:
    task.skip_warning()


# ------------------------------------------------------------------ waiting, stopping


def wait(task: Any, seconds: float) -> None:
    """Sleep `seconds`, in slices, so that a stop is seen."""

    end = time.monotonic() + max(0.0, seconds)
    while True:
        if task.stopping():
            raise Stopped("stopped by the controller")
        left = end - time.monotonic()
        if left <= 0:
            return
        time.sleep(min(left, 0.05))


@builtin("Present", "func", lazy=(0,))
def _present(task: Any, pos: list, opt: dict) -> bool:
    """Whether the routine's optional parameter was given in this call."""
    arg: Lazy = pos[0]
    if not isinstance(arg.node, A.Name):
        raise RapidError("ERR_ARGVALERR", "Present takes an optional parameter's name")
    return arg.node.key in arg.frame.vars


WAIT_UNTIL_POLL_S = 0.1  # WaitUntil's default \\PollRate


@builtin("WaitUntil", "proc", lazy=(0,), optrefs=("TimeFlag",),
         opts=("InPos", "MaxTime", "TimeFlag", "PollRate"))
def _waituntil(task: Any, pos: list, opt: dict) -> None:
    """Until the condition is TRUE, evaluated every \\PollRate s (0.1; at least 0.04); past
    \\MaxTime: TimeFlag TRUE when given, else ERR_WAIT_MAXTIME."""
    condition: Lazy = pos[0]
    poll = max(0.04, float(opt.get("pollrate", WAIT_UNTIL_POLL_S)))
    end = None if "maxtime" not in opt else time.monotonic() + float(opt["maxtime"])
    flag = opt.get("timeflag")
    while True:
        ok = condition()
        if not isinstance(ok, bool):
            raise RapidError("ERR_ARGVALERR", "WaitUntil needs a bool condition")
        if ok:
            break
        if end is not None and time.monotonic() >= end:
            if flag is None:
                raise RapidError("ERR_WAIT_MAXTIME", "WaitUntil: the condition stayed FALSE")
            flag.value = True
            return
        wait(task, poll)
    if flag is not None:
        flag.value = False
    if opt.get("inpos") and "motion" in task.services:
        task.services["motion"].wait_in_position(task)


@builtin("WaitTime", "proc", opts=("InPos",))
def _waittime(task: Any, pos: list, opt: dict) -> None:
    if pos[0] < 0:
        raise RapidError("ERR_ARGVALERR", "WaitTime of a negative time")
    if opt.get("inpos") and "motion" in task.services:
        task.services["motion"].wait_in_position(task)
    wait(task, pos[0])


@builtin("Stop", "proc")
def _stop(task: Any, pos: list, opt: dict) -> None:
    raise Stopped("Stop instruction")


@builtin("ExitCycle", "proc")
def _exitcycle(task: Any, pos: list, opt: dict) -> None:
    raise ExitCycle()


@builtin("GetSysInfo", "func",
         opts=("SerialNo", "SWVersion", "RobotType", "CtrlId", "LanIp", "SystemName"))
def _getsysinfo(task: Any, pos: list, opt: dict) -> str:
    info = task.services.get("sysinfo", {})
    for key in ("lanip", "serialno", "swversion", "robottype", "ctrlid", "systemname"):
        if opt.get(key):
            return string(info.get(key, ""))
    raise RapidError("ERR_ARGVALERR", "GetSysInfo needs one of its switches")


# ------------------------------------------------------------------ clocks


@builtin("ClkReset", "proc")
def _clkreset(task: Any, pos: list, opt: dict) -> None:
    pos[0].total, pos[0].since = 0.0, None


@builtin("ClkStart", "proc")
def _clkstart(task: Any, pos: list, opt: dict) -> None:
    if pos[0].since is None:
        pos[0].since = time.monotonic()


@builtin("ClkStop", "proc")
def _clkstop(task: Any, pos: list, opt: dict) -> None:
    c = pos[0]
    if c.since is not None:
        c.total += time.monotonic() - c.since
        c.since = None


@builtin("CDate", "func")
def _cdate(task: Any, pos: list, opt: dict) -> str:
    """The controller's date, "YYYY-MM-DD"."""
    return time.strftime("%Y-%m-%d")


@builtin("CTime", "func")
def _ctime(task: Any, pos: list, opt: dict) -> str:
    """The controller's time of day, "HH:MM:SS"."""
    return time.strftime("%H:%M:%S")


@builtin("GetTime", "func", opts=("WDay", "Hour", "Min", "Sec"))
def _gettime(task: Any, pos: list, opt: dict) -> float:
    """One part of the time now: \\WDay (1 Monday .. 7 Sunday), \\Hour, \\Min, \\Sec."""
    now = time.localtime()
    for key, v in (("wday", now.tm_wday + 1), ("hour", now.tm_hour), ("min", now.tm_min),
                   ("sec", now.tm_sec)):
        if opt.get(key):
            return float(v)
    raise RapidError("ERR_ARGVALERR", "GetTime needs \\WDay, \\Hour, \\Min or \\Sec")


@builtin("ClkRead", "func", opts=("HighRes",))
def _clkread(task: Any, pos: list, opt: dict) -> float:
    c = pos[0]
    running = 0.0 if c.since is None else time.monotonic() - c.since
    return num(c.total + running)
