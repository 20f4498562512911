"""The world the emulators share: a true robot (a model with imposed errors), where its encoders
read, and where the measuring arm sits. The IRC5 emulator moves it; the arm emulator measures it.

Joint readings are kept as 32-bit floats, like a RAPID num. The true joint angle is the reading
plus the true model's joint zero; a ZERO correction moves that zero.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from screwcal.calibration.correction import after_zero
from screwcal.calibration.flange import DEFAULT_HOLES_IN_FLANGE_MM
from screwcal.kinematics.forward import flange_kinematics, forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, transform_points

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

    def __post_init__(self) -> None:
        self.q_deg = np.asarray(self.q_deg, dtype=np.float32)

    def _condition(self) -> asyncio.Condition:
        if self.arrived is None:
            self.arrived = asyncio.Condition()
        return self.arrived

    async def set_joints(self, q_deg: Array) -> None:
        """The robot has arrived at these encoder readings (rounded to a RAPID num)."""
        self.q_deg = np.asarray(q_deg, dtype=np.float32)
        self.moving = False
        self.arrivals += 1
        for observer in self.observers:
            observer(self)
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
        self.q_deg = (self.q_deg.astype(float) - at).astype(np.float32)

    def nominal_tool0(self) -> Array:
        """The controller's idea of tool0 (4, 4) in the robot base frame: nominal FK."""
        q = np.radians(self.q_deg.astype(float))[None]
        return flange_kinematics(self.nominal, q)[0]

    def true_holes_mm(self) -> Array:
        """Where the three holes really are, in the arm's frame (3, 3)."""
        q = np.radians(self.q_deg.astype(float))[None]
        T = forward_kinematics(self.truth.with_frames(tool=np.eye(4)), q)[0]
        return transform_points(T, self.holes_mm)
