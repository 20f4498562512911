"""The motion instructions and position functions onto the emulated world: the controller's
nominal kinematics (`world.nominal`) is what CRobT and CalcJointT compute with; the world's
true robot moves.

- MoveAbsJ/MoveJ/MoveL move in joint space at `speed_deg_s` (times the time scale); a target
  outside the controller's joint limits is ERR_ROBLIMIT, nothing moves.
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
from simulators.rapid.library import matrix_of, quaternion_of, wait
from simulators.rapid.values import Record, convert, num, record

_NINE_E9 = 9e9


class Motion:
    """The robot as the RAPID task moves it."""

    def __init__(self, world: Any, loop: asyncio.AbstractEventLoop | None, settings: Any,
                 lag_deg: float = 0.02, settle_s: float = 0.25):
        self.world, self.loop, self.settings = world, loop, settings
        self.lag_deg, self.settle_s = lag_deg, settle_s
        self.moves = 0
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
    def move(self, task: Any, target_deg: np.ndarray) -> None:
        lim = self.world.nominal.limits_deg
        bad = np.flatnonzero((target_deg < lim[:, 0]) | (target_deg > lim[:, 1]))
        if bad.size:
            j = int(bad[0])
            raise RapidError("ERR_ROBLIMIT", f"joint {j + 1} target {target_deg[j]:.4f} outside "
                             f"[{lim[j, 0]:g}, {lim[j, 1]:g}]")
        self.wait_in_position(task)
        start = self.world.q_deg.astype(float)
        travel = float(np.max(np.abs(target_deg - start)))
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

    def robtarget(self, q_deg: np.ndarray) -> Record:
        T = self.tool0(q_deg)  # once: the position, the orient and the branch
        return record("robtarget", [num(v) for v in T[:3, 3]],
                      [num(v) for v in quaternion_of(T[:3, :3])], self.conf(q_deg, T),
                      [_NINE_E9] * 6)

    def solve(self, rt: Record) -> np.ndarray:
        """CalcJointT: the joints (deg) for a robtarget, on its confdata's branch."""
        T = np.eye(4)
        T[:3, :3] = matrix_of(rt.f["rot"])
        T[:3, 3] = [rt.f["trans"].f[k] for k in "xyz"]
        try:
            sol = closed_form_ik(self.world.nominal, T[None], require_all=False)
        except ScrewcalError as err:
            raise RapidError("ERR_OUTSIDE_REACH", str(err)) from None
        conf = rt.f["robconf"].f
        b = int(conf["cfx"])
        if not 0 <= b < 8 or not sol.reachable[0, b]:
            raise RapidError("ERR_OUTSIDE_REACH", f"no solution on branch cfx {b}")
        q = np.degrees(sol.q[0, b])
        lim = self.world.nominal.limits_deg
        for j, cf in ((0, conf["cf1"]), (3, conf["cf4"]), (5, conf["cf6"])):
            middle = cf * 90 + 45
            options = [q[j] + 360 * k for k in (-2, -1, 0, 1, 2)
                       if lim[j, 0] <= q[j] + 360 * k <= lim[j, 1]]
            if options:
                q[j] = min(options, key=lambda v: abs(v - middle))
        bad = np.flatnonzero((q < lim[:, 0]) | (q > lim[:, 1]))
        if bad.size:
            raise RapidError("ERR_ROBLIMIT", f"joint {int(bad[0]) + 1} would be "
                             f"{q[bad[0]]:.3f} deg, outside its limits")
        return q


def _motion(task: Any) -> Motion:
    return task.services["motion"]


def _tool0_only(opt: dict, pos_tool: Any = None) -> None:
    for v in (pos_tool, opt.get("tool")):
        if v is not None and (v.f["tframe"].f["trans"].f != {"x": 0.0, "y": 0.0, "z": 0.0}):
            raise RapidError("ERR_ARGVALERR", "only tool0 is supported")
    w = opt.get("wobj")
    if w is not None and w.f["uframe"].f["trans"].f != {"x": 0.0, "y": 0.0, "z": 0.0}:
        raise RapidError("ERR_ARGVALERR", "only wobj0 is supported")


def _jointtarget(q_deg: np.ndarray) -> Record:
    return record("jointtarget", [num(float(v)) for v in q_deg], [_NINE_E9] * 6)


def _robax(jt: Record | list) -> np.ndarray:
    # an aggregate written in the call, [[j1..j6], [e1..e6]], is a jointtarget once converted
    target: Record = convert("jointtarget", jt) if isinstance(jt, list) else jt
    return np.array([target.f["robax"].f[f"rax_{i}"] for i in range(1, 7)])


@builtin("CJointT", "func")
def _cjointt(task: Any, pos: list, opt: dict) -> Record:
    return _jointtarget(_motion(task).joints())


@builtin("CRobT", "func")
def _crobt(task: Any, pos: list, opt: dict) -> Record:
    _tool0_only(opt)
    m = _motion(task)
    return m.robtarget(m.joints())


@builtin("CalcJointT", "func")
def _calcjointt(task: Any, pos: list, opt: dict) -> Record:
    rt, tool = pos
    _tool0_only(opt, tool)
    return _jointtarget(_motion(task).solve(rt))


@builtin("CalcRobT", "func")
def _calcrobt(task: Any, pos: list, opt: dict) -> Record:
    jt, tool = pos
    _tool0_only(opt, tool)
    return _motion(task).robtarget(_robax(jt))


def _stop_point(task: Any, zone: Record, opt: dict) -> None:
    m = _motion(task)
    if "inpos" in opt:
        m.wait_in_position(task)


@builtin("MoveAbsJ", "proc")
def _moveabsj(task: Any, pos: list, opt: dict) -> None:
    jt, _speed, zone, _tool = pos
    _motion(task).move(task, _robax(jt))
    _stop_point(task, zone, opt)


@builtin("MoveJ", "proc")
def _movej(task: Any, pos: list, opt: dict) -> None:
    rt, _speed, zone, tool = pos
    _tool0_only(opt, tool)
    m = _motion(task)
    m.move(task, m.solve(rt))
    _stop_point(task, zone, opt)


@builtin("MoveL", "proc")
def _movel(task: Any, pos: list, opt: dict) -> None:
    _movej(task, pos, opt)  # in joint space: the emulated world has no path, only arrivals


@builtin("WaitRob", "proc")
def _waitrob(task: Any, pos: list, opt: dict) -> None:
    _motion(task).wait_in_position(task)
