"""The motion instructions and position functions onto the emulated world: the controller's
nominal kinematics (`world.nominal`) is what CRobT and CalcJointT compute with; the world's
true robot moves.

- MoveAbsJ/MoveJ/MoveL/MoveC move in joint space at `speed_deg_s` (times the time scale); a
  target outside the controller's joint limits is ERR_ROBLIMIT, nothing moves. \\V, \\T, \\Z
  and \\Conc change a real path's timing and shape, not where it ends: accepted, no effect
  (nor has \\NoEOffs: there are no external axes).
- Robtargets are the TCP in the work object (`frames`: tooldata and wobjdata, robhold either
  side); the move's tool and work object stay active for CRobT, CPos, CTool and CWObj.
  MoveC passes its CirPoint (three points too close or on a line are refused).
- ConfL/ConfJ \\Off: the solution nearest the joints now; \\On (the default): the robtarget's
  confdata. CalcJointT always takes the confdata. SingArea is kept, with no effect (no path
  passes a singularity here).
- A stop point (`fine`) ends the instruction when the path's reference arrives; the servo then
  settles for `settle_s` (times the time scale), the encoders lagging behind by up to
  `lag_deg` meanwhile. `\\Inpos` stop-point data, `WaitTime \\InPos` and `WaitRob \\InPos`
  wait until it has settled: only then do CJointT and CRobT read where the robot stands.
- confdata: cf1, cf4, cf6 the quadrants of axes 1, 4, 6 (floor(q / 90 deg)); cfx the arm's
  branch 0..7 (shoulder front/back x elbow up/down x wrist no-flip/flip, in that bit order).
  CalcJointT takes cfx's branch and turns axes 1, 4, 6 toward their quadrant's middle.
- Injected motion fault (`FaultPlan.collision_at_move`): that move stops halfway with
  ERR_COLL_STOP.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from typing import Any

import numpy as np

from screwcal.errors import ScrewcalError
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.ik import closed_form_ik
from simulators.rapid.builtins import builtin
from simulators.rapid.errors import RapidError
from simulators.rapid.frames import Frames, matrix_of_pose
from simulators.rapid.library import quaternion_of, wait
from simulators.rapid.values import Record, convert, num, record

_NINE_E9 = 9e9


class Motion:
    """The robot as the RAPID task moves it."""

    def __init__(self, world: Any, loop: asyncio.AbstractEventLoop | None, settings: Any,
                 lag_deg: float = 0.02, settle_s: float = 0.25):
        self.world, self.loop, self.settings = world, loop, settings
        self.lag_deg, self.settle_s = lag_deg, settle_s
        self.moves = 0
        self.tool: Record | None = None  # the active tool and work object (None: tool0, wobj0)
        self.wobj: Record | None = None
        self.conf_l = self.conf_j = True  # ConfL, ConfJ \\On
        self.sing_area = "off"
        self._lag = np.zeros(6)
        self._settle_end = 0.0
        self._settle_len = 0.0

    # -- where the robot is
    def joints(self) -> np.ndarray:
        """The encoders now (deg): the target plus what the servo has not yet settled."""
        q = self.world.q_deg.astype(float)
        left = self._settle_end - time.monotonic()
        if left > 0 and self._settle_len > 0:
            q = q + self._lag * (left / self._settle_len)
        return q

    def wait_in_position(self, task: Any) -> None:
        left = self._settle_end - time.monotonic()
        if left > 0:
            wait(task, left)

    # -- moving
    def move(self, task: Any, target_deg: np.ndarray, via: np.ndarray | None = None) -> None:
        """To `target_deg`, timed through `via` when given (MoveC's CirPoint)."""
        lim = self.world.nominal.limits_deg
        for q in (target_deg,) if via is None else (via, target_deg):
            bad = np.flatnonzero((q < lim[:, 0]) | (q > lim[:, 1]))
            if bad.size:
                j = int(bad[0])
                raise RapidError("ERR_ROBLIMIT", f"joint {j + 1} target {q[j]:.4f} outside "
                                 f"[{lim[j, 0]:g}, {lim[j, 1]:g}]")
        self.wait_in_position(task)
        start = self.world.q_deg.astype(float)
        travel = float(np.max(np.abs(target_deg - start))) if via is None else \
            float(np.max(np.abs(via - start)) + np.max(np.abs(target_deg - via)))
        scale = self.settings.time_scale
        duration = travel / self.settings.speed_deg_s * scale
        faults = self.settings.faults
        collide = faults.take("collision_at_move", self.moves)
        self.moves += 1
        self.world.moving = True
        if collide:
            wait(task, duration / 2)
            self._arrive((start + target_deg) / 2)
            raise RapidError("ERR_COLL_STOP", "collision detected, motion stopped")
        wait(task, duration)
        self._arrive(target_deg)
        if scale > 0 and travel > 0:
            self._lag = -np.sign(target_deg - start) * self.lag_deg
            self._settle_len = self.settle_s * scale
            self._settle_end = time.monotonic() + self._settle_len

    def _arrive(self, q_deg: np.ndarray) -> None:
        """The world has the robot there now; its waiters (in the emulator's loop) are told."""
        self.world.arrive(np.asarray(q_deg, dtype=np.float32))
        if self.loop is not None:
            with contextlib.suppress(RuntimeError):  # the loop has closed: the test is over
                self.loop.call_soon_threadsafe(self._notify)

    def _notify(self) -> None:
        if self.loop is not None:  # called back on that loop (`arrive`), which never unsets it
            self.loop.create_task(self.world.notify_arrival())

    # -- kinematics (the controller's nominal model)
    def tool0(self, q_deg: np.ndarray) -> np.ndarray:
        return flange_kinematics(self.world.nominal, np.radians(q_deg)[None])[0]

    def branch(self, q_deg: np.ndarray, T: np.ndarray) -> int:
        """cfx: which of the eight IK branches this joint vector is (T: its tool0 pose)."""
        sol = closed_form_ik(self.world.nominal, T[None], require_all=False, check=False)
        q = np.radians(q_deg)
        d = np.angle(np.exp(1j * (sol.q[0] - q[None, :])))
        d = np.where(np.isnan(d), np.inf, np.abs(d))
        return int(np.argmin(d.max(axis=1)))

    def conf(self, q_deg: np.ndarray, T: np.ndarray) -> list[float]:
        """confdata of a joint vector whose tool0 pose is T."""
        return [float(math.floor(q_deg[0] / 90)), float(math.floor(q_deg[3] / 90)),
                float(math.floor(q_deg[5] / 90)), float(self.branch(q_deg, T))]

    def robtarget(self, q_deg: np.ndarray, frames: Frames) -> Record:
        """The robtarget of a joint vector: the TCP in the work object's object frame."""
        T = self.tool0(q_deg)  # once: the pose, the orient and the branch
        P = frames.target_of(T)
        return record("robtarget", [num(v) for v in P[:3, 3]],
                      [num(v) for v in quaternion_of(P[:3, :3])], self.conf(q_deg, T),
                      [_NINE_E9] * 6)

    def solve(self, rt: Record, frames: Frames, conf_on: bool = True) -> np.ndarray:
        """CalcJointT and the moves: the joints (deg) for a robtarget with a tool and a work
        object. Configuration control on (ConfJ/ConfL \\On): the branch of its confdata, axes
        1, 4, 6 in its quadrants; off: the solution nearest the joints now."""
        T = frames.flange_of(matrix_of_pose(rt.f["trans"], rt.f["rot"]))
        try:
            sol = closed_form_ik(self.world.nominal, T[None], require_all=False)
        except ScrewcalError as err:
            raise RapidError("ERR_OUTSIDE_REACH", str(err)) from None
        lim = self.world.nominal.limits_deg
        if not conf_on:
            return self._nearest(np.degrees(sol.q[0]), sol.reachable[0], lim)
        conf = rt.f["robconf"].f
        b = int(conf["cfx"])
        if not 0 <= b < 8 or not sol.reachable[0, b]:
            raise RapidError("ERR_OUTSIDE_REACH", f"no solution on branch cfx {b}")
        q = np.degrees(sol.q[0, b])
        for j, cf in ((0, conf["cf1"]), (3, conf["cf4"]), (5, conf["cf6"])):
            middle = cf * 90 + 45
            options = [q[j] + 360 * k for k in (-2, -1, 0, 1, 2)
                       if lim[j, 0] <= q[j] + 360 * k <= lim[j, 1]]
            if options:
                q[j] = min(options, key=lambda v: abs(v - middle))
        _within(q, lim)
        return q

    def _nearest(self, branches_deg: np.ndarray, reachable: np.ndarray,
                 lim: np.ndarray) -> np.ndarray:
        """Of the reachable branches (8, 6) within the limits (axes turned by whole turns
        toward the joints now), the one nearest the joints now (largest joint move)."""
        now = self.world.q_deg.astype(float)
        best: np.ndarray | None = None
        for q, ok in zip(branches_deg, reachable, strict=True):
            if not ok or np.isnan(q).any():
                continue
            q = q + 360.0 * np.round((now - q) / 360.0)
            for j in range(6):  # a whole turn back inside the limits where one went out
                if q[j] > lim[j, 1]:
                    q[j] -= 360.0
                elif q[j] < lim[j, 0]:
                    q[j] += 360.0
            if ((q < lim[:, 0]) | (q > lim[:, 1])).any():
                continue
            if best is None or np.max(np.abs(q - now)) < np.max(np.abs(best - now)):
                best = q
        if best is None:
            raise RapidError("ERR_ROBLIMIT", "no solution within the joint limits")
        return best


def _within(q: np.ndarray, lim: np.ndarray) -> None:
    bad = np.flatnonzero((q < lim[:, 0]) | (q > lim[:, 1]))
    if bad.size:
        raise RapidError("ERR_ROBLIMIT", f"joint {int(bad[0]) + 1} would be "
                         f"{q[bad[0]]:.3f} deg, outside its limits")


def _motion(task: Any) -> Motion:
    return task.services["motion"]


def _frames(tool: Record | None, wobj: Record | None) -> Frames:
    return Frames(tool, wobj)


def _jointtarget(q_deg: np.ndarray) -> Record:
    return record("jointtarget", [num(float(v)) for v in q_deg], [_NINE_E9] * 6)


def _robtarget(rt: Record | list) -> Record:
    """A robtarget written as an aggregate in the call is one once converted."""
    return convert("robtarget", rt) if isinstance(rt, list) else rt


def _robax(jt: Record | list) -> np.ndarray:
    # an aggregate written in the call, [[j1..j6], [e1..e6]], is a jointtarget once converted
    target: Record = convert("jointtarget", jt) if isinstance(jt, list) else jt
    return np.array([target.f["robax"].f[f"rax_{i}"] for i in range(1, 7)])


@builtin("CJointT", "func")
def _cjointt(task: Any, pos: list, opt: dict) -> Record:
    return _jointtarget(_motion(task).joints())


@builtin("CRobT", "func", opts=("Tool", "WObj"))
def _crobt(task: Any, pos: list, opt: dict) -> Record:
    """Where the TCP is, in the tool and work object given, else the active ones (those of
    the last move instruction)."""
    m = _motion(task)
    frames = _frames(opt.get("tool", m.tool), opt.get("wobj", m.wobj))
    return m.robtarget(m.joints(), frames)


@builtin("CPos", "func", opts=("Tool", "WObj"))
def _cpos(task: Any, pos: list, opt: dict) -> Record:
    """CRobT's position only."""
    rt: Record = _crobt(task, pos, opt).f["trans"]
    return rt


@builtin("CTool", "func")
def _ctool(task: Any, pos: list, opt: dict) -> Record:
    """The active tool (the last move instruction's; tool0 before any)."""
    tool = _motion(task).tool
    return task.system["tool0"].value.copy() if tool is None else tool.copy()


@builtin("CWObj", "func")
def _cwobj(task: Any, pos: list, opt: dict) -> Record:
    """The active work object (the last move instruction's; wobj0 before any)."""
    wobj = _motion(task).wobj
    return task.system["wobj0"].value.copy() if wobj is None else wobj.copy()


@builtin("StopMove", "proc")
def _stopmove(task: Any, pos: list, opt: dict) -> None:
    """Nothing moves while the task runs an instruction after its move (the emulated world's
    moves end in their instruction): nothing to stop, resume or clear. Run from another task
    (multitasking), which this controller does not emulate, they would matter."""


@builtin("StartMove", "proc")
def _startmove(task: Any, pos: list, opt: dict) -> None:
    """See StopMove."""


@builtin("ClearPath", "proc")
def _clearpath(task: Any, pos: list, opt: dict) -> None:
    """See StopMove."""


@builtin("CalcJointT", "func", opts=("WObj",))
def _calcjointt(task: Any, pos: list, opt: dict) -> Record:
    """The joints of a robtarget on its confdata's branch (ConfL/ConfJ do not apply)."""
    rt, tool = pos
    m = _motion(task)
    return _jointtarget(m.solve(_robtarget(rt), _frames(tool, opt.get("wobj"))))


@builtin("CalcRobT", "func", opts=("WObj",))
def _calcrobt(task: Any, pos: list, opt: dict) -> Record:
    jt, tool = pos
    return _motion(task).robtarget(_robax(jt), _frames(tool, opt.get("wobj")))


def _stop_point(task: Any, zone: Record, opt: dict) -> None:
    m = _motion(task)
    if "inpos" in opt:
        m.wait_in_position(task)


def _activate(m: Motion, tool: Record, opt: dict) -> Frames:
    """The move's tool and work object (checked), active from now on for CRobT."""
    wobj = opt.get("wobj")
    frames = _frames(tool, wobj)
    m.tool, m.wobj = tool, wobj
    return frames


@builtin("MoveAbsJ", "proc", opts=("Conc", "V", "T", "Z", "Inpos", "WObj", "NoEOffs"))
def _moveabsj(task: Any, pos: list, opt: dict) -> None:
    jt, _speed, zone, tool = pos
    m = _motion(task)
    _activate(m, tool, opt)
    m.move(task, _robax(jt))
    _stop_point(task, zone, opt)


@builtin("MoveJ", "proc", opts=("Conc", "V", "T", "Z", "Inpos", "WObj"))
def _movej(task: Any, pos: list, opt: dict) -> None:
    _move_to(task, pos, opt, _motion(task).conf_j)


@builtin("MoveL", "proc", opts=("Conc", "V", "T", "Z", "Inpos", "WObj"))
def _movel(task: Any, pos: list, opt: dict) -> None:
    """In joint space: the emulated world has no path, only arrivals."""
    _move_to(task, pos, opt, _motion(task).conf_l)


def _move_to(task: Any, pos: list, opt: dict, conf_on: bool) -> None:
    rt, _speed, zone, tool = pos
    m = _motion(task)
    m.move(task, m.solve(_robtarget(rt), _activate(m, tool, opt), conf_on))
    _stop_point(task, zone, opt)


@builtin("MoveC", "proc", opts=("Conc", "V", "T", "Z", "Inpos", "WObj"))
def _movec(task: Any, pos: list, opt: dict) -> None:
    """MoveC CirPoint, ToPoint, speed, zone, tool [\\WObj]: the circle through the TCP now,
    CirPoint and ToPoint (in the work object). The three must be apart and not on one line
    (the controller's "circle points too close"); the robot passes CirPoint and arrives at
    ToPoint (the emulated world has arrivals, not paths: the travel is timed through both)."""
    cir, to, _speed, zone, tool = pos
    m = _motion(task)
    frames = _activate(m, tool, opt)
    cir, to = _robtarget(cir), _robtarget(to)
    start = frames.target_of(m.tool0(m.world.q_deg.astype(float)))[:3, 3]
    points = [start] + [np.array([r.f["trans"].f[k] for k in "xyz"]) for r in (cir, to)]
    _check_circle(*points)
    q_cir = m.solve(cir, frames, m.conf_l)
    q_to = m.solve(to, frames, m.conf_l)
    m.move(task, q_to, via=q_cir)
    _stop_point(task, zone, opt)


CIRCLE_MIN_MM = 0.1  # the circle's points at least this far apart


def _check_circle(start: np.ndarray, cir: np.ndarray, to: np.ndarray) -> None:
    for a, b, what in ((start, cir, "start and CirPoint"), (cir, to, "CirPoint and ToPoint"),
                       (start, to, "start and ToPoint")):
        if float(np.linalg.norm(a - b)) < CIRCLE_MIN_MM:
            raise RapidError("ERR_ARGVALERR", f"circle points too close: {what} less than "
                             f"{CIRCLE_MIN_MM:g} mm apart")
    u, v = cir - start, to - start
    sine = float(np.linalg.norm(np.cross(u, v))) / float(np.linalg.norm(u) * np.linalg.norm(v))
    if sine < 1e-3:
        raise RapidError("ERR_ARGVALERR", "circle points on one line: no circle through them")


@builtin("ConfL", "proc", opts=("On", "Off"))
def _confl(task: Any, pos: list, opt: dict) -> None:
    _motion(task).conf_l = _on_off(opt, "ConfL")


@builtin("ConfJ", "proc", opts=("On", "Off"))
def _confj(task: Any, pos: list, opt: dict) -> None:
    _motion(task).conf_j = _on_off(opt, "ConfJ")


def _on_off(opt: dict, name: str) -> bool:
    if bool(opt.get("on")) == bool(opt.get("off")):
        raise RapidError("ERR_ARGVALERR", f"{name} takes one of \\On and \\Off")
    return bool(opt.get("on"))


@builtin("SingArea", "proc", opts=("Wrist", "LockAxis4", "Off"))
def _singarea(task: Any, pos: list, opt: dict) -> None:
    """How paths pass a singularity (\\Wrist, \\LockAxis4, \\Off): kept; the emulated world
    moves in joint space (no path passes a singularity)."""
    chosen = [k for k in ("wrist", "lockaxis4", "off") if opt.get(k)]
    if len(chosen) != 1:
        raise RapidError("ERR_ARGVALERR", "SingArea takes one of \\Wrist, \\LockAxis4, \\Off")
    _motion(task).sing_area = chosen[0]


@builtin("WaitRob", "proc", opts=("InPos", "ZeroSpeed"))
def _waitrob(task: Any, pos: list, opt: dict) -> None:
    _motion(task).wait_in_position(task)


@builtin("Offs", "func")
def _offs(task: Any, pos: list, opt: dict) -> Record:
    """The robtarget moved by (x, y, z) mm in its work object's object frame."""
    rt, dx, dy, dz = pos
    out = _robtarget(rt).copy()
    t = out.f["trans"].f
    t["x"], t["y"], t["z"] = num(t["x"] + dx), num(t["y"] + dy), num(t["z"] + dz)
    return out


@builtin("RelTool", "func", opts=("Rx", "Ry", "Rz"))
def _reltool(task: Any, pos: list, opt: dict) -> Record:
    """The robtarget moved by (x, y, z) mm in its own (the tool's) frame, then turned by \\Rx,
    \\Ry, \\Rz degrees about the tool's axes (in that order)."""
    rt, dx, dy, dz = pos
    out = _robtarget(rt).copy()
    T = matrix_of_pose(out.f["trans"], out.f["rot"])
    p = T[:3, 3] + T[:3, :3] @ np.array([dx, dy, dz])
    R = T[:3, :3]
    for axis, key in ((0, "rx"), (1, "ry"), (2, "rz")):
        angle = math.radians(opt.get(key, 0.0))
        if angle:
            c, s = math.cos(angle), math.sin(angle)
            i, j = [k for k in range(3) if k != axis]
            turn = np.eye(3)
            turn[i, i], turn[i, j], turn[j, i], turn[j, j] = c, -s, s, c
            R = R @ turn
    out.f["trans"] = record("pos", *[num(v) for v in p])
    out.f["rot"] = record("orient", *[num(v) for v in quaternion_of(R)])
    return out
