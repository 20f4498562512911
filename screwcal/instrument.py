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

POSITION_NOISE_MM = 0.013
HOLE_SPACING_MM = 50.0
ORIENTATION_NOISE_RAD = POSITION_NOISE_MM * math.sqrt(2.0) / HOLE_SPACING_MM
ORIENTATION_NOISE_DEG = math.degrees(ORIENTATION_NOISE_RAD)
JOINT_ERROR_DEG = 0.05
REACH_MM = 1200.0
STAND_MM = (500.0, 0.0, 600.0)
