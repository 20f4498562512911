"""The robot the identification benchmarks measure (`calibration.py`, `identify_cost.py`): the
IRB 1600 with the thesis's Table 11 errors, seen from a measuring system about 1.5 m away and
turned, through a measured point off the flange; both frames unknown to the identification."""

from __future__ import annotations

from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist


def table11_robot_in_a_cell() -> SerialModel:
    """The true robot: Table 11's errors, a measuring frame and a tool offset."""
    return apply_virtual_joints(irb1600(), THESIS_TABLE11).with_frames(
        exp_twist([0.1, -0.2, 0.3, 1500, -300, 200]), exp_twist([0, 0, 0, 30, -20, 80]))
