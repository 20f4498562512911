import numpy as np
import pytest

from screwcal.calibration.flange import MeasuringFlange, check_holes, frame_from_holes
from screwcal.errors import FlangeError
from screwcal.kinematics.se3 import exp_twist, invert_transform

HOLES_IN_TCP = np.array([[0.0, 0, 0], [30.0, 40.0, 0], [60.0, 0, 0]])  # P1, P2, P3


def test_gram_schmidt_frame_eqs_4_1_to_4_4():
    T = frame_from_holes(HOLES_IN_TCP)[0]
    np.testing.assert_allclose(T, np.eye(4), atol=1e-12)  # x along P1P3, z = x cross P1P2
    pose = exp_twist([0.3, -0.2, 0.5, 100, 200, 300])
    moved = HOLES_IN_TCP @ pose[:3, :3].T + pose[:3, 3]
    np.testing.assert_allclose(frame_from_holes(moved)[0], pose, atol=1e-12)


def test_flange_pose_from_bench_and_eq_4_6(rng):
    tcp_in_ef = exp_twist([0.0, 0.0, 0.2, 10, -20, 35])  # the bench truth
    bench = exp_twist([0.1, 0.2, 0.3, 500, 0, 100])  # the bench frame, arbitrary
    holes_bench = (bench @ tcp_in_ef)[:3, :3] @ HOLES_IN_TCP.T
    holes_bench = holes_bench.T + (bench @ tcp_in_ef)[:3, 3]
    ef_pts = [bench[:3, 3], bench[:3, 3] + 50 * bench[:3, 2], bench[:3, 3] + 40 * bench[:3, 0]]
    flange = MeasuringFlange.from_bench(holes_bench, *ef_pts)
    np.testing.assert_allclose(flange.tcp_in_ef, tcp_in_ef, atol=1e-9)
    # On the robot: holes probed at a flange pose T_ef^b give back T_ef^b (Eq. 4.6).
    T_ef = exp_twist([0.4, -0.1, 1.2, 800, 300, 600])
    tcp = T_ef @ tcp_in_ef
    probed = HOLES_IN_TCP @ tcp[:3, :3].T + tcp[:3, 3]
    np.testing.assert_allclose(flange.flange_poses(probed)[0], T_ef, atol=1e-9)
    np.testing.assert_allclose(invert_transform(flange.flange_poses(probed))[0] @ T_ef,
                               np.eye(4), atol=1e-9)


@pytest.mark.parametrize(("holes", "message"), [
    (np.array([[0.0, 0, 0], [0.2, 0, 0], [60.0, 0, 0]]), r"P1 and P2 .* probed twice"),
    (np.array([[0.0, 0, 0], [30.0, 0.5, 0], [60.0, 0, 0]]), r"collinear"),
])
def test_degenerate_holes_are_refused(holes, message):
    with pytest.raises(FlangeError, match=message):
        check_holes(holes)


def test_swapped_and_wrong_holes_are_refused():
    nominal = [50.0, 60.0, 50.0]  # |P1P2|, |P1P3|, |P2P3| of HOLES_IN_TCP
    check_holes(HOLES_IN_TCP, nominal)
    with pytest.raises(FlangeError, match="labels look swapped"):
        check_holes(HOLES_IN_TCP[[1, 0, 2]], nominal)
    with pytest.raises(FlangeError, match="does not match the flange's"):
        check_holes(HOLES_IN_TCP * 1.1, nominal)
