from dataclasses import replace

import numpy as np
import pytest

from screwcal.calibration.correction import joint_correction
from screwcal.calibration.error_parameters import Param
from screwcal.calibration.identify import NoiseModel, identify
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.errors import CorrectionRefusedError, IdentificationError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist
from screwcal.studies.simulated_measurements import simulate_measurements

BASE = exp_twist([0.2, -0.1, 2.5, 1400, -600, -300])  # the measuring system's frame
TOOL = exp_twist([0.0, 0.0, 0.0, 25, -40, 90])  # the measured point on the flange


def full_truth(rng):
    """An independent truth: every axis tilted and shifted, zeros and the flange off."""
    m = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    dirs = m.axis_dirs + rng.normal(0, np.radians(0.1), m.axis_dirs.shape)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    return replace(m, axis_dirs=dirs,
                   axis_points_mm=m.axis_points_mm + rng.normal(0, 0.5, (6, 3)),
                   home_flange=exp_twist(np.r_[rng.normal(0, 2e-3, 3), rng.normal(0, 0.5, 3)])
                   @ m.home_flange)


def validation_rms(truth, model, rng, n=300):
    q = random_configurations(n, rng)
    d = forward_kinematics(truth, q)[:, :3, 3] - forward_kinematics(model, q)[:, :3, 3]
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


@pytest.mark.parametrize("frames", ["known", "unknown"])
@pytest.mark.parametrize("full_pose", [True, False])
def test_full_model_predicts_unseen_poses_to_the_noise_level(rng, frames, full_pose):
    """The measured point sits off the flange axis (as the thesis's holes do): known frames
    means the base and this tool offset are given."""
    truth = full_truth(rng).with_frames(BASE if frames == "unknown" else np.eye(4), TOOL)
    nominal = irb1600() if frames == "unknown" else irb1600().with_frames(np.eye(4), TOOL)
    q = random_configurations(60, rng)
    data = simulate_measurements(truth, q, rng, joint_noise_deg=0.0, full_pose=full_pose)
    result = identify(nominal, data, kind="full", frames=frames, noise=NoiseModel(joint_deg=0))
    assert result.converged and not result.degenerate
    assert validation_rms(truth, result.start_model, rng) > 1.0  # the errors are real
    # The noise level of a 3-D point is sqrt(3) x 0.013 mm; allow three times that.
    assert validation_rms(truth, result.model, rng) < 3 * np.sqrt(3) * 0.013
    assert result.chi2_reduced == pytest.approx(1.0, abs=0.35)


def test_thesis_model_recovers_table_11(rng):
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    r = identify(irb1600(), data, kind="thesis", frames="known")
    assert not r.degenerate and not r.removed
    assert set(r.names) == set(THESIS_TABLE11)  # named as the thesis names them
    for name, value in THESIS_TABLE11.items():
        k = r.names.index(name)
        assert abs(r.values[k] - value) < 4 * r.std_errors[k], name
    assert r.std_errors[r.names.index("J1rz")] < 0.05


def test_unknown_frames_make_the_thesis_model_degenerate_and_say_why(rng):
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11).with_frames(BASE, TOOL)
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    r = identify(irb1600(), data, kind="thesis")
    assert r.degenerate
    removed = dict(r.removed)
    assert "J1rz" in removed and "base.rz" in removed["J1rz"]
    assert "J6rx" in removed and "tool.rz" in removed["J6rx"]
    assert "J1pz" in removed and "base.z" in removed["J1pz"]
    assert "J1rz" not in r.names  # held, not solved with garbage


def test_distance_data_need_no_base_alignment(rng):
    truth = full_truth(rng).with_frames(BASE, TOOL)
    data = simulate_measurements(truth, random_configurations(40, rng), rng,
                                 joint_noise_deg=0.0, full_pose=False)
    r = identify(irb1600(), data, kind="full", residual="distance", noise=NoiseModel(joint_deg=0))
    assert r.converged and not any(p.group == "base" for p in r.params)
    assert r.residuals_after.mean() < 0.05 < r.residuals_before.mean()


def test_too_few_poses_are_refused(rng):
    data = simulate_measurements(irb1600(), random_configurations(5, rng), rng)
    with pytest.raises(IdentificationError, match=r"5 poses give 30 equations for the 30 .*"
                                                  r"at least 6 poses"):
        identify(irb1600(), data, kind="full", frames="known")


def test_poorly_spread_poses_are_reported_degenerate(rng):
    """Joint 6 never moves: its axis cannot be told from the flange, beyond the model's own
    redundancy."""
    q = random_configurations(40, rng)
    q[:, 5] = 0.3
    data = simulate_measurements(irb1600(), q, rng)
    r = identify(irb1600(), data, kind="full", frames="known")
    assert r.degenerate and r.rank < 30


@pytest.mark.slow
def test_de_agrees_with_lm_on_the_thesis_model(rng):
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    lm = identify(irb1600(), data, kind="thesis", frames="known")
    de = identify(irb1600(), data, kind="thesis", frames="known", solver="de")
    np.testing.assert_allclose(de.values, lm.values, atol=1e-3)


def test_de_with_distance_residuals_the_thesis_appendix_d_method(rng):
    """DE over pairwise distances (no frame to align): its population cost used to index the
    pairs first and crash; now it recovers the offsets as LM does."""
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(30, rng), rng, full_pose=False)
    de = identify(irb1600(), data, kind="thesis", residual="distance", solver="de")
    lm = identify(irb1600(), data, kind="thesis", residual="distance")
    for name in ("J2ry", "J3rz", "J5ry"):
        assert de.value(name) == pytest.approx(THESIS_TABLE11[name], abs=0.1), name
        assert de.value(name) == pytest.approx(lm.value(name), abs=0.02), name


def test_noise_levels_are_estimated_from_the_data(rng):
    """Variance components: data without joint noise are not weighted as if they had it, and
    data with it have it found; chi2/dof is then 1 and the levels come with uncertainties."""
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    quiet = simulate_measurements(truth, random_configurations(200, rng), rng,
                                  joint_noise_deg=0.0)
    r = identify(irb1600(), quiet, kind="thesis", frames="known")
    assert r.noise.position_mm == pytest.approx(0.013, rel=0.15)
    assert r.noise.joint_deg < 0.01 and r.chi2_reduced == pytest.approx(1.0, abs=0.1)
    noisy = simulate_measurements(truth, random_configurations(200, rng), rng,
                                  joint_noise_deg=0.05)
    r = identify(irb1600(), noisy, kind="thesis", frames="known")
    assert r.noise.joint_deg == pytest.approx(0.05, rel=0.2)
    assert r.noise.joint_std_deg is not None and r.noise.joint_std_deg < 0.01
    fixed = identify(irb1600(), noisy, kind="thesis", frames="known",
                     noise=NoiseModel(0.013, None, 0.05))
    assert fixed.noise.joint_std_deg is None  # fixed: reported as such


def test_eq_2_4_weighting_runs_and_scales_errors(rng):
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    r = identify(irb1600(), data, kind="joints", frames="known", weighting="eq2.4", weight_mm=1.0)
    assert r.converged and r.weighting == "eq2.4"
    assert np.all(np.abs(r.values - [2.0, 1.1, 3.1, -2.0, 3.7, -4.6]) < 0.5)


def test_correction_is_minus_the_offsets_and_refuses_the_implausible():
    j1, j2 = (Param(n, "deg", "zero", joint=i) for i, n in enumerate(("J1rz", "J2ry")))
    c = joint_correction((j1, j2), [1.0, -2.0], [0.01, 0.01], 6)
    np.testing.assert_allclose(c.zero_command_deg, [-1, 2, 0, 0, 0, 0])
    assert c.identified.tolist() == [True, True, False, False, False, False]
    with pytest.raises(CorrectionRefusedError, match="exceeds the plausible bound"):
        joint_correction((j1,), [7.0], [0.01], 6)
    with pytest.raises(CorrectionRefusedError, match="uncertain"):
        joint_correction((j1,), [1.0], [0.5], 6)


@pytest.mark.slow
def test_lm_is_statistically_efficient():
    """Issue 3: >= 200 simulated calibrations, the RMS error of every joint offset within 1.2x
    of its Cramer-Rao bound from the same Jacobian and noise model."""
    from screwcal.studies.montecarlo import efficiency_study

    rows = efficiency_study(samples=200, seed=0)
    offsets = [r for r in rows if r.unit == "deg"]
    assert len(offsets) == 6
    for r in offsets:
        assert r.ratio <= 1.2, f"{r.name}: RMS {r.rms_error:.4f} vs bound {r.bound:.4f}"
        assert r.ratio >= 0.8, f"{r.name}: better than the bound means the bound is wrong"


def test_base_only_frames_identify_j6_with_a_known_tool(rng):
    """With the flange known (Eq. 4.6) and only the measuring frame unknown, J6's offset is
    identifiable; J1's stays inseparable from the base's rotation about z."""
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11).with_frames(base=BASE)
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    r = identify(irb1600(), data, kind="thesis", frames="base")
    assert "J6rx" in r.names and abs(r.value("J6rx") + 4.6) < 0.05
    assert "J1rz" in dict(r.removed) and not any(p.group == "tool" for p in r.params)
