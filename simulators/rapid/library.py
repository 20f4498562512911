"""The RAPID built-ins that are neither sockets, motion nor strings: arithmetic, orientations,
the operator interface, waiting and stopping, the event log, clocks and dates."""

from __future__ import annotations

import functools
import math
import struct
import time
from typing import Any

import numpy as np

from screwcal.kinematics.pose import (
    euler_zyx_deg_from_rotation,
    rotation_from_euler_zyx_deg,
    rotation_from_quaternion_wxyz,
)
from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation
from screwcal.rapid import ast as A  # noqa: N812 - the node classes
from simulators.rapid.builtins import Lazy, builtin
from simulators.rapid.control import ExitCycle, Stopped
from simulators.rapid.errors import RapidError
from simulators.rapid.frames import unit_wxyz
from simulators.rapid.strings import valtostr
from simulators.rapid.values import RArray, Record, convert, is_integer, num, record, string

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


def _math(name: str, fn: Any, domain: str = "") -> None:
    """A one-argument function of RAPID's arithmetic (angles in degrees); outside its domain
    ERR_ARGVALERR."""
    def call(task: Any, pos: list, opt: dict) -> float:
        try:
            return num(fn(pos[0]))
        except (ValueError, OverflowError):
            raise RapidError("ERR_ARGVALERR", f"{name}({pos[0]:g}): outside {domain}") from None
    builtin(name, "func")(call)


_math("Sin", lambda a: math.sin(math.radians(a)))
_math("Cos", lambda a: math.cos(math.radians(a)))
_math("Tan", lambda a: math.tan(math.radians(a)))
_math("ASin", lambda v: math.degrees(math.asin(v)), "-1..1")
_math("ACos", lambda v: math.degrees(math.acos(v)), "-1..1")
_math("ATan", lambda v: math.degrees(math.atan(v)))
_math("Exp", math.exp, "what a num holds")


@builtin("Pow", "func")
def _pow(task: Any, pos: list, opt: dict) -> float:
    """Base ^ Exponent (a negative base with a whole exponent only)."""
    base, exponent = pos
    if base < 0 and not is_integer(exponent):
        raise RapidError("ERR_ARGVALERR", f"Pow({base:g}, {exponent:g}): no real value")
    try:
        return num(math.pow(base, exponent))
    except (ValueError, OverflowError, ZeroDivisionError):
        raise RapidError("ERR_ARGVALERR", f"Pow({base:g}, {exponent:g})") from None


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
        text += valtostr(task, [opt["num"]], {})
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
