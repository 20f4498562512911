import numpy as np
import pytest

from screwcal.errors import ScrewcalError
from screwcal.performance.iso9283 import pose_metrics, wrap_deg
from screwcal.performance.straightness import straightness


def test_known_bias_and_spread_come_back(rng):
    """A cloud with a known bias and a known spread (30 cycles x many points)."""
    bias = np.array([0.4, -0.3, 1.2])
    p_cmd = np.array([900.0, 100.0, 500.0])
    ap, rp, s_l = [], [], []
    for _ in range(300):
        p = p_cmd + bias + rng.normal(0, 0.02, (30, 3))
        m = pose_metrics(p_cmd, p)
        ap.append(m.ap_mm)
        rp.append(m.rp_mm)
        s_l.append(m.rp_thesis_eq2_8_mm)
    assert np.mean(ap) == pytest.approx(np.linalg.norm(bias), abs=2e-3)
    # l = |N(0, s^2 I3)| is Maxwell: mean 2 s sqrt(2/pi), std s sqrt(3 - 8/pi).
    s = 0.02
    assert np.mean(s_l) == pytest.approx(s * np.sqrt(3 - 8 / np.pi), rel=0.03)
    assert np.mean(rp) == pytest.approx(2 * s * np.sqrt(2 / np.pi) + 3 * s * np.sqrt(3 - 8 / np.pi),
                                        rel=0.03)


def test_exact_small_example():
    p_cmd = np.zeros(3)
    p = np.array([[2.0, 1, 0], [2.0, -1, 0], [2.0, 0, 1], [2.0, 0, -1]])  # all at distance 1
    m = pose_metrics(p_cmd, p, np.zeros(3), np.array([[1.0, 0, 179], [3.0, 0, -179],
                                                      [1.0, 0, 179], [3.0, 0, -179]]))
    assert m.ap_mm == pytest.approx(2.0)
    assert m.ap_xyz_mm == pytest.approx((2.0, 0.0, 0.0))
    assert m.rp_mm == pytest.approx(1.0)  # l = 1 everywhere: S_l = 0
    assert m.ap_abc_deg[0] == pytest.approx(2.0)
    # rz around the +-180 cut: attained 179 and -179 for a commanded 0 -> deviations 179, -179,
    # their mean is 0: the wrap happens about the commanded value.
    assert m.ap_abc_deg[2] == pytest.approx(0.0)
    assert m.rp_abc_deg[0] == pytest.approx(3 * np.std([1, 3, 1, 3], ddof=1))


def test_orientation_mean_does_not_cross_the_cut():
    m = pose_metrics(np.zeros(3), np.array([[0, 0, 0], [0, 0, 1e-3]]),
                     np.array([0, 0, 180.0]), np.array([[0, 0, 179.0], [0, 0, -179.0]]))
    assert m.ap_abc_deg[2] == pytest.approx(0.0)
    assert m.rp_abc_deg[2] == pytest.approx(3 * np.std([-1, 1], ddof=1))
    np.testing.assert_allclose(wrap_deg([181, -181, 180, 540]), [-179, 179, 180, 180])


def test_bad_inputs_are_refused():
    with pytest.raises(ScrewcalError, match="at least 2 cycles"):
        pose_metrics(np.zeros(3), np.zeros((1, 3)))
    with pytest.raises(ScrewcalError, match="both commanded and attained"):
        pose_metrics(np.zeros(3), np.zeros((3, 3)), np.zeros(3))


def test_straightness_of_a_line_with_known_peak_and_valley(rng):
    """A 3-D line, deviations in a known normal direction with zero mean and no linear trend
    (which the least-squares line would absorb): peak 0.05, valley 0.08."""
    d = np.array([1.0, 2.0, 2.0]) / 3
    u = np.array([2.0, -1.0, 0.0]) / np.sqrt(5)
    t = np.linspace(-250, 250, 41)
    dev = np.zeros_like(t)
    dev[[10, 30]] = 0.05  # symmetric about the middle: no trend
    dev[20] = -0.08
    dev[[0, 40]] = -0.01  # zero mean: 0.1 - 0.08 - 0.02
    assert abs(dev.sum()) < 1e-12 and abs(np.dot(dev, t)) < 1e-9
    pts = np.array([100, 200, 300]) + t[:, None] * d + dev[:, None] * u
    s = straightness(pts)
    # The normal's sign is a convention (towards the larger excursion): the pair is what counts.
    assert sorted([s.peak_mm, s.valley_mm]) == pytest.approx([0.05, 0.08], abs=1e-9)
    assert s.peak_mm >= s.valley_mm
    assert s.peak_to_valley_mm == pytest.approx(0.13, abs=1e-9)
    assert s.cylinder_diameter_mm == pytest.approx(0.16, abs=1e-9)
    assert abs(np.dot(s.direction, d)) == pytest.approx(1.0, abs=1e-6)
    assert np.dot(s.direction, pts[-1] - pts[0]) > 0
    assert s.along_mm.max() - s.along_mm.min() == pytest.approx(500, abs=1e-3)


def test_straightness_of_a_perfect_line_is_zero():
    pts = np.outer(np.arange(10.0), [3.0, -4.0, 12.0])
    assert straightness(pts).peak_to_valley_mm == pytest.approx(0.0, abs=1e-9)


def test_straightness_refuses_degenerate_input():
    with pytest.raises(ScrewcalError, match="at least 3 points"):
        straightness(np.zeros((2, 3)))
    with pytest.raises(ScrewcalError, match="coincide"):
        straightness(np.ones((5, 3)))


def test_orientation_in_the_other_zyx_representation():
    """Flange-down commanded as (180, 0, 180), attained written as (0, 180, 0) + small errors:
    the same rotations, so APa/b/c are the small errors, not 180 deg."""
    from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, rotation_from_euler_zyx_deg

    cmd = np.array([180.0, 0.0, 180.0])
    R = rotation_from_euler_zyx_deg([[180.02, 0.01, 179.97], [179.98, -0.01, 180.01]])
    other = euler_zyx_deg_from_rotation(R) + np.array([180.0, 0.0, 180.0])
    other[:, 1] = 180.0 - euler_zyx_deg_from_rotation(R)[:, 1]  # the (0, 180, 0)-like triple
    np.testing.assert_allclose(rotation_from_euler_zyx_deg(other), R, atol=1e-12)
    m = pose_metrics(np.zeros(3), np.zeros((2, 3)), cmd, other)
    np.testing.assert_allclose(m.ap_abc_deg, [0.0, 0.0, -0.01], atol=1e-9)
