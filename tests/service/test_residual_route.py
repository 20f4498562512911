"""The service's compensate route and verify jobs send targets compensated for the calibration's
residual model too (service.analysis.compensate_plan)."""

import numpy as np

from screwcal.calibration.residual_model import ResidualOutcome, fit_residual_model
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.robots import irb120
from service.analysis import compensate_plan
from service.plans import PlannedPose
from service.report.residual import residual_body


def test_the_compensated_plan_takes_the_residual_into_account():
    rng = np.random.default_rng(3)
    nominal = irb120()
    q_cal = np.radians(rng.uniform([-90, -40, -40, -90, -60, -90], [90, 60, 40, 90, 60, 90],
                                   (200, 6)))
    smooth = 0.1 * np.c_[np.sin(q_cal[:, 1]), np.cos(q_cal[:, 2]), np.sin(q_cal[:, 0])]
    residual = fit_residual_model(q_cal, smooth + rng.normal(0, 0.005, smooth.shape))
    plan = [PlannedPose(k, tuple(np.degrees(q)), "target") for k, q in enumerate(q_cal[:10])]
    plain, _ = compensate_plan(plan, nominal, nominal)
    with_it, _ = compensate_plan(plan, nominal, nominal, residual)
    q_plain = np.radians([p.joints_deg for p in plain])
    q_with = np.radians([p.joints_deg for p in with_it])
    np.testing.assert_allclose(q_plain, q_cal[:10], atol=1e-6)  # nothing to compensate but it
    wanted = flange_kinematics(nominal, q_cal[:10])[:, :3, 3]
    reached = flange_kinematics(nominal, q_with)[:, :3, 3] + residual.predict(q_with).correction_mm
    assert np.abs(reached - wanted).max() < 0.01  # mm: joints rounded to 1e-4 deg
    assert np.abs(q_with - q_plain).max() > 1e-5


def test_the_report_sets_the_residual_model_beside_the_physical_one():
    rng = np.random.default_rng(4)
    q = np.radians(rng.uniform(-90, 90, (120, 6)))
    smooth = 0.1 * np.c_[np.sin(q[:, 1]), np.cos(q[:, 2]), np.sin(q[:, 0])]
    model = fit_residual_model(q, smooth + rng.normal(0, 0.005, smooth.shape))
    member = ResidualOutcome("auto", model, True, "kept (auto): it pays").to_dict()
    html = residual_body(member)
    assert "kept (auto): it pays" in html
    assert "physical model" in html and "physical + residual" in html
    assert f"{model.cv.corrected_mean_mm:.4f}" in html
    assert "Robot exports (URDF, DH) carry the physical model only" in html
    declined = residual_body(ResidualOutcome("auto", model, False, "declined").to_dict())
    assert "declined" in declined and "physical + residual" in declined
    assert "Each prediction" not in declined
