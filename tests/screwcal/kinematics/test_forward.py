import numpy as np
import pytest

from screwcal.kinematics import forward
from screwcal.kinematics.forward import (
    flange_kinematics,
    forward_kinematics,
    joint_axis_lines,
    point_jacobian,
    spatial_jacobian,
)
from screwcal.kinematics.pose import pose_from_transform
from screwcal.kinematics.robots import irb120, irb1600
from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation, twist_from_transform_difference
from tests.conftest import random_model, random_q

# Thesis Figure 37 (section 4.4): nominal joint space -> nominal task space, configurations 37-40.
# The y column of rows 37-38 is garbled in the thesis text (the IRB 1600 spec says so); row 38's q4
# prints truncated as "-172.60...": -172.6003 is the value in [-172.6099, -172.6000] (step 0.0001)
# that best fits the printed pose; every other printed figure of the row then holds.
FIG37_Q = [
    [-53.6383, 45.9603, 6.5768, -9.2281, -83.1463, 55.7123],
    [-47.4142, 36.6110, -10.7416, -172.6003, -46.9143, -71.5455],
    [-36.7788, 42.2791, -5.4277, -41.1306, -42.5693, 73.9340],
    [-48.0725, 32.6161, 17.1309, 133.5450, 57.5433, -61.5798],
]
FIG37_POSE = [
    [548.8550, -728.036, 373.0396, 52.5837, 34.3963, 23.5934],
    [676.1640, -726.654, 544.2590, 165.8620, -11.6539, 21.3408],
    [824.5480, -580.25, 475.8900, 92.8983, 47.8092, 81.8076],
    [594.2670, -602.18, 426.4660, 91.9461, -0.4744, 79.6433],
]


def test_irb1600_home_flange_is_815_0_961_5_pointing_along_x():
    T = forward_kinematics(irb1600(), np.zeros((1, 6)))[0]
    np.testing.assert_allclose(T[:3, 3], [815.0, 0.0, 961.5], atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], [1, 0, 0], atol=1e-12)  # flange z along base +x
    np.testing.assert_allclose(T[:3, 0], [0, 0, -1], atol=1e-12)  # flange x along base -z
    np.testing.assert_allclose(quaternion_wxyz_from_rotation(T[:3, :3]),
                               [np.sqrt(0.5), 0, np.sqrt(0.5), 0], atol=1e-12)


def test_irb120_home_flange():
    T = forward_kinematics(irb120(), np.zeros((1, 6)))[0]
    np.testing.assert_allclose(pose_from_transform(T), [374, 0, 630, 0, 90, 0], atol=1e-9)


def test_thesis_figure_37_rows():
    model = irb1600()
    poses = pose_from_transform(forward_kinematics(model, np.radians(FIG37_Q)))
    expected = np.array(FIG37_POSE)
    # Printed to 4 decimals from joints printed to 4 decimals: 0.0001 deg of a joint moves the
    # flange by up to 0.002 mm at this reach.
    np.testing.assert_allclose(poses[:, [0, 2]], expected[:, [0, 2]], atol=2e-3)
    np.testing.assert_allclose(poses[:, 3:], expected[:, 3:], atol=5e-4)
    np.testing.assert_allclose(poses[:2, 1], expected[:2, 1], atol=2e-3)  # the corrected y
    # Rows 39-40 print y truncated: the model's y must start with the printed digits.
    for got, printed in zip(poses[2:, 1], (-580.25, -602.18), strict=True):
        assert np.trunc(got * 100) / 100 == pytest.approx(printed, abs=1e-9)


@pytest.mark.parametrize("types", ["RRRRRR", "RPRRPR", "PPP", "RRRRRRR"])
def test_batch_equals_one_by_one(rng, types):
    model = random_model(rng, types)
    q = random_q(model, rng, 50)
    batch = forward_kinematics(model, q)
    single = np.stack([forward_kinematics(model, q[k:k + 1])[0] for k in range(len(q))])
    few = np.concatenate([forward_kinematics(model, q[k:k + 10]) for k in range(0, 50, 10)])
    # up to 16 poses take their own path (the exponentials from precomputed combinations of
    # (1, sin, cos), then their product pairwise): equal to rounding, not bit for bit
    for other in (single, few):
        np.testing.assert_allclose(batch, other, rtol=0, atol=1e-12 * np.abs(batch).max())


@pytest.mark.parametrize("n", [1, 2, 3, 6, 7])
def test_the_exponentials_are_chained_in_one_order_for_one_pose_and_for_several(rng, n):
    """One pose's product (2-D) and a stack's are the same products in the same order: the
    pairs (E1 E2)(E3 E4)... then left to right, bit for bit."""
    E = np.stack([forward_kinematics(random_model(rng), random_q(irb1600(), rng, n))
                  for _ in range(4)], axis=0)  # (4 configurations, n matrices, 4, 4)
    stacked = forward._chained(E)
    alone = np.stack([forward._chained(E[k]) for k in range(4)])
    np.testing.assert_array_equal(stacked, alone)
    expected = [np.linalg.multi_dot(list(E[k])) if n > 1 else E[k, 0] for k in range(4)]
    np.testing.assert_allclose(stacked, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("types", ["RRRRRR", "RPRRPR", "PPP", "RRRRRRR"])
def test_many_poses_in_blocks_equal_the_jacobians_chain(rng, types, monkeypatch):
    """The batch path works in blocks with the configurations along the last axis: blocks of 8
    here (two full, one of 5) against the product of successive screws the Jacobians build."""
    monkeypatch.setattr(forward, "_BLOCK", 8)
    model = random_model(rng, types)
    q = random_q(model, rng, 21)
    A, _ = forward.screw_chain(model, q, keep=False)
    chain = (A.reshape(-1, 4) @ (model.home_flange @ model.tool)).reshape(-1, 3, 4)
    T = forward_kinematics(model, q)
    np.testing.assert_allclose(T[:, :3], chain, rtol=0, atol=1e-12 * np.abs(chain).max())
    np.testing.assert_array_equal(T[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (21, 1)))


def test_fk_rejects_wrong_shapes():
    with pytest.raises(ValueError, match=r"shape \(N, 6\)"):
        forward_kinematics(irb1600(), np.zeros(6))
    with pytest.raises(ValueError, match=r"shape \(N, 6\)"):
        forward_kinematics(irb1600(), np.zeros((3, 5)))


def test_flange_kinematics_ignores_base_and_tool(rng):
    model = random_model(rng)
    q = random_q(model, rng, 5)
    T = forward_kinematics(model, q)
    np.testing.assert_allclose(model.base @ flange_kinematics(model, q) @ model.tool, T,
                               atol=1e-9)


@pytest.mark.parametrize("types", ["RRRRRR", "RPRRPR", "PPP"])
def test_spatial_jacobian_matches_finite_differences(rng, types):
    model = random_model(rng, types)
    q = random_q(model, rng, 20)
    J = spatial_jacobian(model, q)
    T = forward_kinematics(model, q)
    h = 1e-6
    for i in range(model.n_joints):
        dq = np.zeros(model.n_joints)
        dq[i] = h
        fd = twist_from_transform_difference(forward_kinematics(model, q + dq),
                                             forward_kinematics(model, q - dq), T, h)
        np.testing.assert_allclose(J[:, :, i], fd, atol=2e-6 * max(1, np.abs(fd).max()))


@pytest.mark.parametrize("joints", [1, 5, 6])
def test_joint_axis_lines_are_the_spatial_jacobian_columns(rng, joints):
    """Each line's direction is a column's omega and its point (nearest the origin) lies on
    the column's screw axis: v = p x omega, p . omega = 0."""
    model = random_model(rng)
    q = random_q(model, rng, 30)
    w, p = joint_axis_lines(model, q, joints)
    J = spatial_jacobian(model, q)[:, :, :joints]
    assert w.shape == p.shape == (30, joints, 3)
    np.testing.assert_allclose(w, np.swapaxes(J[:, :3], 1, 2), atol=1e-12)
    np.testing.assert_allclose(np.cross(p, w), np.swapaxes(J[:, 3:], 1, 2), atol=1e-9)
    np.testing.assert_allclose(np.sum(p * w, axis=-1), 0.0, atol=1e-9)


def test_point_jacobian_gives_position_and_rotation_rates(rng):
    model = random_model(rng)
    q = random_q(model, rng, 10)
    T = forward_kinematics(model, q)
    Jp = point_jacobian(spatial_jacobian(model, q), T)
    h = 1e-6
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = h
        Tp, Tm = forward_kinematics(model, q + dq), forward_kinematics(model, q - dq)
        np.testing.assert_allclose(Jp[:, :3, i], (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h),
                                   atol=1e-5 * 1000)
        np.testing.assert_allclose(Jp[:, 3:, i],
                                   twist_from_transform_difference(Tp, Tm, T, h)[:, :3],
                                   atol=1e-6)


def test_with_frames_checks_the_new_frames_only():
    import pytest

    from screwcal.errors import ModelError

    model = irb1600()
    bad = np.eye(4)
    bad[:3, :3] *= 2.0
    with pytest.raises(ModelError, match="base: the rotation part"):
        model.with_frames(base=bad)
    with pytest.raises(ModelError, match="tool: every value must be a finite"):
        model.with_frames(tool=np.full((4, 4), np.nan))
    moved = model.with_frames(base=np.eye(4))
    assert moved.axis_dirs is model.axis_dirs and not moved.base.flags.writeable
