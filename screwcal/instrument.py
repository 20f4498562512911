"""The measuring system, once: the thesis's FARO arm (thesis 4.1) and where it stands.

Every figure of the instrument the project assumes lives here; the identification's starting
noise levels, the experiment designs, the studies' simulations and the arm emulator read them.

- `POSITION_NOISE_MM`: one probed point, standard deviation per coordinate (0.013 mm, the arm's
  single-point repeatability).
- `HOLE_SPACING_MM`: the holes of the measuring flange are about 50 mm apart, so an orientation
  built from them carries `ORIENTATION_NOISE_RAD` = 0.013 sqrt(2) / 50 rad.
- `JOINT_ERROR_DEG`: the joint-reading error the thesis simulates (uniform +-0.05 deg).
- `REACH_MM`: the arm measures within 1200 mm of its origin.
- `STAND_MM`: where the arm stands by default, mm in the robot's base frame (500, 0, 600).
"""

from __future__ import annotations

import math

import numpy as np

POSITION_NOISE_MM = 0.013
HOLE_SPACING_MM = 50.0
ORIENTATION_NOISE_RAD = POSITION_NOISE_MM * math.sqrt(2.0) / HOLE_SPACING_MM
ORIENTATION_NOISE_DEG = math.degrees(ORIENTATION_NOISE_RAD)
JOINT_ERROR_DEG = 0.05
REACH_MM = 1200.0
STAND_MM = (500.0, 0.0, 600.0)

# The laser tracker (a Leica AT40x-class tracker over emScon; issue 40). Its maximum permissible
# error of a point is U = `TRACKER_MPE_CONSTANT_MM` + `TRACKER_MPE_PER_M_MM` per metre of range
# (15 um + 6 um/m, k = 2), almost all of it lateral (the two angles); the distance meter's part
# is `TRACKER_RADIAL_NOISE_MM` (one standard deviation, constant over the range). A reflector
# (1.5" SMR) is seen within `SMR_ACCEPTANCE_DEG` of its axis. `TRACKER_STAND_MM` is where the
# tracker stands by default, mm in the robot's base frame: 3 m in front of the robot, facing it.
TRACKER_MPE_CONSTANT_MM = 0.015
TRACKER_MPE_PER_M_MM = 0.006
TRACKER_RADIAL_NOISE_MM = 0.005
TRACKER_RANGE_MM = (800.0, 30000.0)
SMR_ACCEPTANCE_DEG = 30.0
TRACKER_STAND_MM = (3000.0, 0.0, 900.0)


def tracker_noise_mm(distance_mm: float) -> tuple[float, float]:
    """The tracker's standard deviations at this range, mm: (radial, lateral per direction).
    The lateral one is half the MPE (k = 2) at that range."""
    lateral = (TRACKER_MPE_CONSTANT_MM + TRACKER_MPE_PER_M_MM * distance_mm / 1000.0) / 2.0
    return TRACKER_RADIAL_NOISE_MM, lateral


def tracker_covariance_mm2(points_mm: np.ndarray) -> np.ndarray:
    """The covariance (N, 3, 3) mm^2 of points (N, 3) measured by a tracker at the origin of
    their frame: `tracker_noise_mm` along the beam and across it."""
    p = np.asarray(points_mm, dtype=float)
    distance = np.linalg.norm(p, axis=1)
    u = p / distance[:, None]
    radial, lateral = np.vectorize(tracker_noise_mm)(distance)
    along = u[:, :, None] * u[:, None, :]
    return (radial**2)[:, None, None] * along + \
        (lateral**2)[:, None, None] * (np.eye(3) - along)

