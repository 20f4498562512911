"""Levenberg-Marquardt next to a singularity (`singular_fit.fit_poses`): it meets what the
calibrated arm can reach, and a target already met or settled costs no further iteration."""

from dataclasses import replace

import numpy as np

from screwcal.calibration.singular_fit import fit_poses, within_singular_tolerances
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.ik import pose_error
from screwcal.kinematics.pose import transform_from_pose
from screwcal.kinematics.robots import builtin_model

# A KR 16 whose axes are 0.3 mm off (mm), and a target of a 10,000-target KRL program that
# Gauss-Newton from the nominal joints did not reach. With a fixed damping factor (/3 on a
# success, x4 on a failure) Levenberg-Marquardt crawled along the valley and was still 0.006
# mm away after its 200 iterations: the reachable target was refused.
_SHIFT_MM = np.array([[-0.327, -0.178, 0.18], [0.71, -0.553, -0.123], [0.242, 0.367, -0.235],
                      [0.617, -0.168, 0.365], [0.096, 0.003, 0.278], [0.281, -0.141, -0.278]])
_TARGET = [-75.7239, 113.4439, 2033.2446, 48.1305, 40.777, -176.5876]  # mm, deg (flange)
_START_DEG = [108.501, -86.554, -33.09, -72.965, -45.532, 172.427]


def _crawling_case() -> tuple:
    nominal = builtin_model("kr16")
    robot = replace(nominal, axis_points_mm=nominal.axis_points_mm + _SHIFT_MM)
    return robot, transform_from_pose(_TARGET)[None], np.radians(_START_DEG)[None]


def test_a_reachable_target_in_a_curved_valley_is_met():
    robot, T, q0 = _crawling_case()
    q, cost = fit_poses(robot, T, q0)
    assert within_singular_tolerances(pose_error(T, forward_kinematics(robot, q))).all()
    assert cost[0] < 1e-18


def test_a_target_already_met_is_left_exactly_where_it_is():
    robot, T, q0 = _crawling_case()
    q_met, _ = fit_poses(robot, T, q0)
    both = np.concatenate([q_met, q0])
    q, cost = fit_poses(robot, np.repeat(T, 2, axis=0), both)
    np.testing.assert_array_equal(q[0], q_met[0])  # met to rounding: not one step taken
    assert cost[1] < 1e-18


def test_an_unreachable_target_settles_at_its_nearest_pose():
    robot, T, q0 = _crawling_case()
    far = T.copy()
    far[0, 2, 3] += 1500.0  # far above the arm's reach
    q, cost = fit_poses(robot, far, q0)
    gap_mm = np.linalg.norm(pose_error(far, forward_kinematics(robot, q))[0, :3])
    assert 0 < gap_mm < 1500.0 and np.isfinite(cost).all()
    assert not within_singular_tolerances(pose_error(far, forward_kinematics(robot, q))).any()
