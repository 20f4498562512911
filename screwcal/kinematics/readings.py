"""Joint readings as a controller reports them, and the model's serial joint angles.

Every model is serial: each joint's angle is measured from the link before it. A FANUC
controller reports J3 as the forearm's angle to the horizontal instead (the J2/J3 coupling of
its parallelogram-era arms, kept on the serial ones): with the library's FANUC axes (J2 about
+y, J3 about -y, both counting positive as FANUC does)

    J3_reading = q3 - q2,   q3 = J3_reading + J2        (J2_reading = q2, others equal)

so at J2 = 30 deg and J3 = 0 the forearm stays horizontal. The files a user reads from or gives
to a controller (measurements, predict's joints, compensate's joint targets) are in the
controller's convention (`--joint-convention`, default the robot's: `fanuc` for the library's
FANUC arms, `serial` for every other); the model, its limits and the numeric code are serial.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from screwcal.kinematics.se3 import Array

JointConvention = Literal["serial", "fanuc"]
JOINT_CONVENTIONS: tuple[JointConvention, ...] = ("serial", "fanuc")


def serial_from_readings(q: ArrayLike, convention: JointConvention) -> Array:
    """Joint readings (..., 6) in `convention` -> the model's serial angles (same units)."""
    out = np.array(q, dtype=float)
    if convention == "fanuc":
        out[..., 2] += out[..., 1]
    return out


def readings_from_serial(q: ArrayLike, convention: JointConvention) -> Array:
    """The model's serial angles (..., 6) -> joint readings in `convention` (same units)."""
    out = np.array(q, dtype=float)
    if convention == "fanuc":
        out[..., 2] -= out[..., 1]
    return out


def robot_convention(robot_name: str) -> JointConvention:
    """How the controller of a library robot reports its joints (`serial` for a robot not in
    the library: a robot file's joints are serial unless the user says otherwise)."""
    from screwcal.kinematics.robots import LIBRARY

    entry = LIBRARY.get(robot_name)
    return "fanuc" if entry is not None and entry.maker == "FANUC" else "serial"
