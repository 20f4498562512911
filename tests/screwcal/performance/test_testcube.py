import csv

import numpy as np
import pytest

from screwcal.commands.main import main
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.ik import closed_form_ik
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
from screwcal.kinematics.robots import irb1600
from screwcal.performance.testcube import (
    CYCLE_ORDER,
    ArmSphere,
    InfeasibleCubeError,
    TestCube,
    find_test_cube,
    performance_pose_list,
)


def test_points_follow_iso_9283_geometry():
    cube = TestCube(np.array([800.0, 0, 500]), 400.0, np.zeros(3), np.array([0, 0, 50.0]))
    pts = cube.points_mm
    np.testing.assert_allclose(pts["P1"], [800, 0, 500])
    corners = cube.plane_corners_mm
    diag = np.linalg.norm(corners[2] - corners[0])
    for label, corner in zip(("P2", "P3", "P4", "P5"), corners, strict=True):
        assert np.linalg.norm(pts[label] - corner) == pytest.approx(0.1 * diag)
    # All five points on the inclined plane: x - z = const.
    assert len({round(p[0] - p[2], 9) for p in pts.values()}) == 1


@pytest.fixture(scope="module")
def plan():
    model = irb1600()
    arm = ArmSphere((900.0, 600.0, 300.0))
    cube = find_test_cube(model, 400.0, arm=arm)
    return model, cube, arm, performance_pose_list(model, cube, cycles=30)


def test_pose_list_is_reachable_within_limits_and_hits_its_targets(plan):
    model, _, arm, plans = plan
    assert len(plans) == 30 * 5 * 2
    q = np.radians([p.q_deg for p in plans])
    assert model.within_limits(q).all()
    np.testing.assert_allclose(pose_from_transform(forward_kinematics(model, q))[:, :3],
                               np.array([p.pose_cmd for p in plans])[:, :3], atol=1e-6)
    # Every target is preceded by its return point; cycles visit P1, P5, P4, P3, P2.
    for a, t in zip(plans[0::2], plans[1::2], strict=True):
        assert (a.role, t.role) == ("approach", "target") and a.point == t.point
        np.testing.assert_allclose(np.subtract(a.pose_cmd[:3], t.pose_cmd[:3]), [0, 0, 50])
    assert tuple(p.point for p in plans[1:10:2]) == CYCLE_ORDER
    # Inside the arm's reach.
    positions = np.array([p.pose_cmd[:3] for p in plans])
    assert (np.linalg.norm(positions - arm.centre_mm, axis=1) <= arm.radius_mm).all()


def test_every_cube_point_is_reachable(plan):
    model, cube, _, _ = plan
    poses = cube.poses(np.vstack([cube.corners_mm, list(cube.points_mm.values())]))
    sol = closed_form_ik(model, transform_from_pose(poses))
    assert sol.valid.any(axis=1).all()


def test_a_given_cube_is_checked_not_searched():
    cube = find_test_cube(irb1600(), 300.0, centre_mm=(800.0, 100.0, 500.0))
    np.testing.assert_allclose(cube.centre_mm, [800, 100, 500])
    with pytest.raises(InfeasibleCubeError):
        find_test_cube(irb1600(), 300.0, centre_mm=(100.0, 0.0, 500.0))  # inside the robot


def test_impossible_cube_is_refused():
    with pytest.raises(InfeasibleCubeError, match="try a smaller edge"):
        find_test_cube(irb1600(), 3000.0)


def test_testcube_command_writes_list_and_plot(tmp_path, capsys):
    out, png = tmp_path / "perf.csv", tmp_path / "cube.png"
    assert main(["testcube", "--robot", "irb1600", "--edge-mm", "300", "--cycles", "3",
                 "--out", str(out), "--plot", str(png)]) == 0
    with out.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 30 and rows[0]["role"] == "approach"
    assert png.stat().st_size > 10_000
    assert "P1:" in capsys.readouterr().out


@pytest.mark.parametrize("robot", ["kr16", "lrmate200id", "ur5e"])
def test_other_makers_arms_get_a_cube_whose_joints_reach_it(robot):
    """KUKA's and FANUC's joints that count the other way, UR's offset wrist: the cube is found
    with their closed forms (it was 'not an ideal ABB-type arm ... use numerical_ik')."""
    from screwcal.kinematics.robots import builtin_model

    model = builtin_model(robot)
    plans = performance_pose_list(model, find_test_cube(model), cycles=1)
    q = np.radians([p.q_deg for p in plans])
    reached = forward_kinematics(model, q)
    wanted = transform_from_pose(np.array([p.pose_cmd for p in plans]))
    assert np.abs(reached - wanted).max() < 1e-6
    assert model.within_limits(q).all()
