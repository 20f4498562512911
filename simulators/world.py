"""The world the emulators share: a true robot (a model with imposed errors), where its encoders
read, and where the measuring arm sits. The IRC5 emulator moves it; the arm emulator measures it.

Joint readings are kept as 32-bit floats, like a RAPID num. The true joint angle is the reading
plus the true model's joint zero; a ZERO correction moves that zero.

With a `Realism` (`simulators.realism`) the true robot also has what real ones have; the world
keeps its true state inside and its interface unchanged: `q_deg` is what the encoders REPORT
(trailing the motion by the read-back lag), `set_joints(q)` still means "arrived at the commanded
joints", and `true_holes_mm()` places the holes from the joints where the links really stand
(backlash, repeatability error), bent under gravity (compliance, payload), with the lengths of
the arm grown by its warm-up (drift over the robot's running time, `running_s`).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from screwcal.calibration.correction import after_zero
from screwcal.calibration.flange import DEFAULT_HOLES_IN_FLANGE_MM
from screwcal.kinematics.compliance import Payload
from screwcal.kinematics.forward import (
    flange_kinematics,
    forward_kinematics,
    joint_bend,
    joint_positions,
)
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, transform_points
from simulators.realism import IDEAL, Realism

DEFAULT_HOLES_MM = np.array(DEFAULT_HOLES_IN_FLANGE_MM)  # P1, P2, P3 in tool0 (thesis 4.2)


@dataclass
class World:
    nominal: SerialModel  # what the controller believes (its CRobT)
    truth: SerialModel  # the real robot; truth.base = arm frame <- robot base
    holes_mm: Array = field(default_factory=lambda: DEFAULT_HOLES_MM.copy())
    q_deg: Array = field(default_factory=lambda: np.zeros(6, dtype=np.float32))
    moving: bool = False
    arrivals: int = 0  # counts completed moves
    arrived: asyncio.Condition | None = None
    observers: list[Callable[[World], None]] = field(default_factory=list)  # after each arrival
    realism: Realism = IDEAL  # the true robot's compliance is in `truth`, drawn with it
    realism_seed: int | None = None  # backlash side, repeatability error
    running_s: float = 0.0  # the robot's own running time (drift), seconds

    def __post_init__(self) -> None:
        self.q_deg = np.asarray(self.q_deg, dtype=np.float32)
        self._commanded = self.q_deg.astype(float)  # where the motors were sent (deg)
        # where the joints really stand minus what the encoders report (deg): a reading set
        # from outside (a test placing the robot) keeps the true joints beside it
        self._true_minus_read = np.zeros(len(self._commanded))
        self._direction = np.zeros(len(self._commanded))  # sign of each joint's last move
        self._rng = np.random.default_rng(self.realism_seed)
        # the drifted robot at one scale, of one true robot (identity-checked: a test or a
        # ZERO may replace `truth`)
        self._drifted: tuple[SerialModel, float, SerialModel] | None = None
        # the true robot rigid and without its tool, whose kinematic tables are built once
        # per true robot (`true_holes_mm`: every reading)
        self._rigid: tuple[SerialModel, SerialModel] | None = None

    @property
    def true_joints_deg(self) -> Array:
        """Where the joints really stand, in the readings' zero (deg): the commanded joints
        with the backlash and the repeatability error, before gravity bends them."""
        return self.q_deg.astype(float) + self._true_minus_read

    def set_payload(self, payload: Payload) -> None:
        """What the flange now carries (the joints bend under it when the robot is compliant)."""
        self.truth = self.truth.derived(payload=payload)
        self._drifted = None

    def _arrive(self, q_deg: Array) -> None:
        """The true state after a move to the commanded `q_deg` (deg)."""
        r = self.realism
        target = np.asarray(q_deg, dtype=float)
        move = target - self._commanded
        self.running_s += float(np.max(np.abs(move), initial=0.0)) / r.speed_deg_s + r.dwell_s
        self._direction = np.where(move != 0.0, np.sign(move), self._direction)
        # Backlash (lost motion b): the link stops b/2 short, on the side it came from.
        link = target - self._direction * np.asarray(r.backlash_deg) / 2.0
        if r.repeatability_deg:
            link = link + self._rng.normal(0.0, r.repeatability_deg, len(target))
        self._commanded = target
        # Read-back lag (calibration.lag's model): q_read = q_true - lag (q_read - q_previous),
        # q_true the encoders' settled reading (the commanded joints), q_previous the last read.
        lag = np.asarray(r.lag)
        previous = self.q_deg.astype(float)
        self.q_deg = ((target + lag * previous) / (1.0 + lag)).astype(np.float32)
        self._true_minus_read = link - self.q_deg.astype(float)

    def _condition(self) -> asyncio.Condition:
        if self.arrived is None:
            self.arrived = asyncio.Condition()
        return self.arrived

    async def set_joints(self, q_deg: Array) -> None:
        """The robot has arrived at these commanded joints (rounded to a RAPID num); `q_deg`
        reports them (with the read-back lag, when the robot has one)."""
        self.arrive(q_deg)
        await self.notify_arrival()

    def arrive(self, q_deg: Array) -> None:
        """set_joints's change of state, from any thread (the RAPID task's): waiters are woken
        by `notify_arrival` in the loop that waits."""
        self._arrive(np.asarray(q_deg, dtype=np.float32))
        self.moving = False
        self.arrivals += 1
        for observer in self.observers:
            observer(self)

    async def notify_arrival(self) -> None:
        async with self._condition():
            self._condition().notify_all()

    async def wait_arrival(self, after: int) -> int:
        """Wait until more than `after` moves have completed; returns the count."""
        async with self._condition():
            await self._condition().wait_for(lambda: self.arrivals > after)
        return self.arrivals

    def set_zero(self, at_deg: Array) -> None:
        """ZERO: the position whose reading is `at_deg` now reads 0 (thesis 4.5)."""
        at = np.asarray(at_deg, dtype=float)
        self.truth = after_zero(self.truth, at)
        self._drifted = None
        self.q_deg = (self.q_deg.astype(float) - at).astype(np.float32)
        self._commanded = self._commanded - at

    def true_model(self) -> SerialModel:
        """The true robot now: its lengths grown by the warm-up so far (thermal drift)."""
        scale = self.realism.drift_scale(self.running_s)
        if scale == 1.0:
            return self.truth
        if self._drifted is None or self._drifted[0] is not self.truth \
                or self._drifted[1] != scale:
            flange = self.truth.home_flange.copy()
            flange[:3, 3] *= scale
            self._drifted = (self.truth, scale, self.truth.derived(
                axis_points_mm=self.truth.axis_points_mm * scale, home_flange=flange))
        return self._drifted[2]

    def _rigid_truth(self) -> SerialModel:
        """The true robot without its tool and its compliance, once per true robot."""
        if self._rigid is None or self._rigid[0] is not self.truth:
            truth = self.truth
            rigid = truth.with_frames(tool=np.eye(4))
            if truth.has_compliance:
                zeros = np.zeros(truth.n_joints)
                zeros.setflags(write=False)
                rigid = rigid.derived(compliance=zeros, compliance_by_mass=None)
            self._rigid = (truth, rigid)
        return self._rigid[1]

    def nominal_tool0(self) -> Array:
        """The controller's idea of tool0 (4, 4) in the robot base frame: nominal FK."""
        q = np.radians(self.q_deg.astype(float))[None]
        return flange_kinematics(self.nominal, q)[0]

    def true_holes_mm(self) -> Array:
        """Where the three holes really are, in the arm's frame (3, 3): the forward kinematics
        of `true_model()` without its tool. The drift scales every length of the chain by s,
        which scales the chain's translation by s about the base (each joint's screw, and so
        their product, is conjugated by diag(s, s, s, 1)): the rigid robot's tables serve every
        reading; a compliant robot's bend is that of the drifted robot, as before."""
        return transform_points(self.true_tool0(), self.holes_mm)

    def true_tool0(self) -> Array:
        """Where tool0 really is (4, 4), in the arm's frame (`true_holes_mm`'s chain)."""
        q = np.radians(self.true_joints_deg)[None]
        scale = self.realism.drift_scale(self.running_s)
        if self.truth.has_compliance:
            q = q + joint_bend(self.true_model(), q)
        T = forward_kinematics(self._rigid_truth(), q)[0]
        if scale != 1.0:
            t_base = self.truth.base[:3, 3]
            T[:3, 3] = t_base + scale * (T[:3, 3] - t_base)
        return T

    def true_skeleton_mm(self) -> Array:
        """The true robot's skeleton in the arm's frame (n + 1, 3): each joint's place along
        the chain, then tool0 (rigid, without drift: for what the links hide, not to measure)."""
        q = np.radians(self.true_joints_deg)[None]
        return joint_positions(self._rigid_truth(), q)[0]
