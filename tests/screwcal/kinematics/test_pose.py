import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from screwcal.kinematics.pose import (
    pose_from_transform,
    rotation_from_euler_zyx_deg,
    rotation_from_quaternion_wxyz,
    transform_from_pose,
)
from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_orientation_convention_is_rz_ry_rx():
    rx, ry, rz = 52.5837, 34.3963, 23.5934
    expected = _rz(np.radians(rz)) @ _ry(np.radians(ry)) @ _rx(np.radians(rx))
    np.testing.assert_allclose(rotation_from_euler_zyx_deg([rx, ry, rz]), expected, atol=1e-14)


angles = st.tuples(st.floats(-179.9, 179.9), st.floats(-89.9, 89.9), st.floats(-179.9, 179.9))
positions = st.tuples(*[st.floats(-3000, 3000)] * 3)


@given(positions, angles)
def test_pose_round_trip(p, a):
    pose = np.array(p + a)
    np.testing.assert_allclose(pose_from_transform(transform_from_pose(pose)), pose, atol=1e-9)


@given(angles)
def test_quaternion_round_trip_w_first_and_non_negative(a):
    R = rotation_from_euler_zyx_deg(a)
    q = quaternion_wxyz_from_rotation(R)
    assert q[0] >= 0 and abs(np.linalg.norm(q) - 1) < 1e-12
    np.testing.assert_allclose(rotation_from_quaternion_wxyz(q), R, atol=1e-12)


def test_batches_keep_their_shape():
    poses = np.zeros((3, 4, 6))
    assert transform_from_pose(poses).shape == (3, 4, 4, 4)
    assert pose_from_transform(transform_from_pose(poses)).shape == (3, 4, 6)


def test_rodrigues_exp_and_log_match_scipy(rng):
    from scipy.spatial.transform import Rotation

    from screwcal.kinematics.se3 import rotation_from_rotvec, rotvec_from_rotation

    phi = np.concatenate([rng.normal(0, 1, (200, 3)), rng.normal(0, 1e-8, (5, 3)),
                          np.pi * np.array([[1.0, 0, 0], [0, 0.6, 0.8]]) * 0.999])
    R = rotation_from_rotvec(phi)
    np.testing.assert_allclose(R, Rotation.from_rotvec(phi).as_matrix(), atol=1e-12)
    np.testing.assert_allclose(rotvec_from_rotation(R), Rotation.from_matrix(R).as_rotvec(),
                               atol=1e-9)


def test_log_near_a_half_turn_matches_scipy_without_importing_it(rng):
    """Within 0.1 rad of 180 deg the rotation vector comes from the quaternion (the trace
    formula loses its precision there); exactly at 180 deg it is one of the two valid ones."""
    import subprocess
    import sys

    from scipy.spatial.transform import Rotation

    from screwcal.kinematics.se3 import rotation_from_rotvec, rotvec_from_rotation

    axis = rng.normal(size=(2000, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = np.concatenate([rng.uniform(np.pi - 0.12, np.pi - 1e-9, 1997), [np.pi] * 3])
    axis[-3:] = np.eye(3)
    R = Rotation.from_rotvec(axis * angle[:, None]).as_matrix()
    phi = rotvec_from_rotation(R)
    np.testing.assert_allclose(phi[:-3], Rotation.from_matrix(R[:-3]).as_rotvec(), atol=1e-12)
    np.testing.assert_allclose(rotation_from_rotvec(phi), R, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(phi, axis=1), angle, atol=1e-12)
    code = ("import sys, numpy as np; from screwcal.kinematics.se3 import rotvec_from_rotation;"
            "rotvec_from_rotation(np.diag([1.0, -1.0, -1.0])[None]);"
            "print('scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


def test_euler_triple_nearest_the_reference():
    from screwcal.kinematics.pose import euler_zyx_deg_near

    R = rotation_from_euler_zyx_deg([179.9, 0.2, -179.5])  # near flange-down (180, 0, 180)
    np.testing.assert_allclose(euler_zyx_deg_near(R, [180, 0, 180]), [179.9, 0.2, 180.5],
                               atol=1e-9)
    np.testing.assert_allclose(rotation_from_euler_zyx_deg(euler_zyx_deg_near(R, [0, 180, 0])),
                               R, atol=1e-12)
    np.testing.assert_allclose(euler_zyx_deg_near(R, [0, 180, 0]), [-0.1, 179.8, 0.5],
                               atol=1e-9)


def test_conversions_agree_with_scipy_everywhere():
    """The written-out conversions (scipy.spatial is a third of a second to import) against
    scipy's Rotation on random rotations and the special ones: half turns, gimbal lock."""
    import warnings

    from scipy.spatial.transform import Rotation

    from screwcal.kinematics.pose import (
        euler_zyx_deg_from_rotation,
        rotation_angle_deg,
        rotation_from_euler_zyx_deg,
        rotation_from_quaternion_wxyz,
    )
    from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation

    special = [np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1]),
               *(Rotation.from_euler("ZYX", [30, s * 90, 0], degrees=True).as_matrix()
                 for s in (1, -1))]
    R = np.concatenate([Rotation.random(2000, random_state=1).as_matrix(), special])
    q = quaternion_wxyz_from_rotation(R)
    np.testing.assert_allclose(q, Rotation.from_matrix(R).as_quat(canonical=True,
                                                                   scalar_first=True), atol=1e-12)
    np.testing.assert_allclose(rotation_from_quaternion_wxyz(q), R, atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = Rotation.from_matrix(R).as_euler("ZYX", degrees=True)[:, ::-1]
    e = euler_zyx_deg_from_rotation(R)
    np.testing.assert_allclose(e, expected, atol=1e-9)
    np.testing.assert_allclose(rotation_from_euler_zyx_deg(e), R, atol=1e-12)
    relative = (Rotation.from_matrix(R[:-1]).inv() * Rotation.from_matrix(R[1:])).magnitude()
    np.testing.assert_allclose(rotation_angle_deg(R[:-1], R[1:]), np.degrees(relative),
                               atol=1e-9)


def test_one_rotation_takes_the_float_path_and_agrees_with_the_batch():
    """One (3, 3) rotation goes through the same formulas on floats (the emulated controller's
    CRobT, every pose): equal to the batch form for random rotations, each of Shepperd's four
    cases and w = 0 (half turns, where the sign rule decides)."""
    from scipy.spatial.transform import Rotation

    from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation

    half = [Rotation.from_rotvec(np.pi * np.array(a) / np.linalg.norm(a)).as_matrix()
            for a in ([1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, -1, 1], [-1, 0, 0])]
    Rs = np.concatenate([Rotation.random(200, random_state=3).as_matrix(), np.eye(3)[None],
                         np.array(half)])
    batch = quaternion_wxyz_from_rotation(Rs)
    one = np.array([quaternion_wxyz_from_rotation(R) for R in Rs])
    np.testing.assert_allclose(one, batch, atol=1e-15)
    assert one.shape == (len(Rs), 4)
