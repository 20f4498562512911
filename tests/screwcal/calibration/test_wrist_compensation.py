"""Compensation near the wrist singularity (correction._wrist_solutions)."""

import numpy as np
import pytest

from screwcal.calibration.correction import PLAUSIBLE_CHANGE_DEG, compensate
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.robots import irb1600

# Nominal solutions of targets in benchmarks/rapid_filter.py's module with joint 5 within 4 deg
# of zero: compensating Table 11's errors there crosses the singularity. The scalar
# Levenberg-Marquardt with a finite-difference Jacobian went to the flipped wrist (joints 4 and
# 6 turned by 180 deg, 353 deg from the reference) and refused them as implausible.
NEAR_SINGULAR_DEG = [[41.1542, 0.0012, -62.6837, -71.051, -3.5381, 134.8259],
                     [44.1099, 61.9079, -6.4599, 122.3046, -3.7482, -135.9751],
                     [-16.0505, 24.9508, -60.6681, 15.6267, -3.8501, 47.1642]]


@pytest.mark.parametrize("q_deg", NEAR_SINGULAR_DEG)
def test_compensation_across_the_wrist_singularity_stays_near_the_reference(q_deg):
    nominal = irb1600()
    calibrated = apply_virtual_joints(nominal, THESIS_TABLE11)
    q_ref = np.radians([q_deg])
    wanted = flange_kinematics(nominal, q_ref)
    comp = compensate(calibrated, nominal, wanted, q_ref, frame="base")  # strict: raises
    reached = flange_kinematics(calibrated.with_frames(np.eye(4), np.eye(4)), comp.q_rad)
    assert np.linalg.norm(reached[0, :3, 3] - wanted[0, :3, 3]) < 1e-3
    change = comp.change_deg[0]
    assert np.abs(change).max() <= PLAUSIBLE_CHANGE_DEG  # the near solution, not the flip
