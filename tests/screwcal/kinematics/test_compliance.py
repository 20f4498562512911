"""Joint compliance under gravity (issue 11): torques, the bent chain, the model file, the
identification of the compliance with the geometry, and compensation that uses it."""

from dataclasses import replace

import numpy as np
import pytest

from screwcal.calibration.correction import compensate
from screwcal.calibration.error_parameters import ErrorModel, candidate_params
from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.errors import ModelError
from screwcal.kinematics.compliance import GRAVITY_M_S2, Payload
from screwcal.kinematics.forward import flange_kinematics, forward_kinematics, joint_torques
from screwcal.kinematics.modelfile import model_document, parse_model
from screwcal.kinematics.robots import irb120, irb1600
from screwcal.studies.simulated_measurements import simulate_measurements
from tests.conftest import point_rates

C_DEG_PER_KNM = np.array([0.0, 3.0, 15.0, 0.0, 0.0, 0.0])  # the tracker IRB 120's order


def bent(model, c_deg_per_knm=C_DEG_PER_KNM):
    return replace(model, compliance=np.radians(c_deg_per_knm) / 1000.0)


def test_gravity_torque_at_home_is_mass_times_lever():
    m = irb1600()
    tau = joint_torques(m, np.zeros((1, 6)))[0]
    # joint 2 (axis through x = 150 mm) carries the forearm (35 kg at x = 350) and the wrist
    # (6 kg at x = 750); the upper arm's centre is above it
    expected = GRAVITY_M_S2 * (35 * 0.200 + 6 * 0.600)
    assert tau[1] == pytest.approx(expected, rel=1e-9)
    assert tau[0] == 0.0 and tau[5] == 0.0
    heavier = joint_torques(replace(m, payload=Payload(5.0, (0, 0, 100))), np.zeros((1, 6)))[0]
    # the flange is at x = 815, the payload 100 mm further along tool0's z (+x at home)
    assert heavier[1] - tau[1] == pytest.approx(GRAVITY_M_S2 * 5 * (0.915 - 0.150), rel=1e-9)


def test_a_compliant_arm_sags_and_its_chain_is_the_bent_joints():
    m = irb120()
    q = random_configurations(40, np.random.default_rng(0))  # both paths: 1-16 and more
    soft = bent(m)
    dq = soft.compliance * joint_torques(m, q)
    np.testing.assert_allclose(forward_kinematics(soft, q), forward_kinematics(m, q + dq),
                               atol=1e-9)
    np.testing.assert_allclose(forward_kinematics(soft, q[:5]), forward_kinematics(m, q + dq)[:5],
                               atol=1e-9)
    reach = np.zeros((1, 6))
    reach[0, 1] = np.radians(60)  # the arm stretched forward: it droops
    assert (forward_kinematics(soft, reach)[0, 2, 3] < forward_kinematics(m, reach)[0, 2, 3])


def test_compliance_jacobian_matches_finite_differences():
    m = irb120()
    cands = candidate_params(m, "full", base=True, tool_rotation=True, tool_position=True,
                             compliance="j23")
    errors = ErrorModel(m, tuple(cands))
    rng = np.random.default_rng(1)
    x = rng.normal(0, 1e-3, len(cands))
    cols = [k for k, p in enumerate(cands) if p.kind == "compliance"]
    x[cols] = np.radians([3.0, 15.0])  # rad per kN m
    q = random_configurations(6, rng)
    T, J, _ = errors.linearisation(x, q)
    h = 1e-6
    for k in cols:
        step = np.zeros_like(x)
        step[k] = h
        fd = point_rates(forward_kinematics(errors.apply(x + step), q), T, h)
        np.testing.assert_allclose(fd, J[:, :, k], atol=2e-3 * np.abs(J[:, :, k]).max())


def test_the_model_file_keeps_compliance_and_payload():
    soft = replace(bent(irb120()), payload=Payload(0.4, (0.0, 0.0, 30.0)))
    back = parse_model(model_document(soft))
    np.testing.assert_allclose(back.compliance, soft.compliance)
    assert back.payload == soft.payload and back.masses == soft.masses
    q = random_configurations(3, np.random.default_rng(2))
    np.testing.assert_allclose(forward_kinematics(back, q), forward_kinematics(soft, q),
                               atol=1e-9)
    doc = model_document(soft)
    doc["gravity"]["compliance_deg_per_knm"] = [-1.0] * 6
    with pytest.raises(ModelError, match="compliance"):
        parse_model(doc)
    with pytest.raises(ModelError, match="masses"):
        replace(irb120(), masses=(), compliance=np.full(6, 1e-5))


def test_identification_recovers_the_compliance_and_auto_keeps_it_only_when_supported():
    rng = np.random.default_rng(3)
    q = random_configurations(200, rng)
    truth = bent(irb120())
    data = simulate_measurements(truth, q, rng, joint_noise_deg=0.0)
    r = identify(irb120(), data, kind="full", frames="known", compliance="auto")
    assert r.compliance == "j23" and "chosen" in r.compliance_note
    got = {p.name: (v, s) for p, v, s in zip(r.params, r.values, r.std_errors, strict=True)
           if p.kind == "compliance"}
    for name, true in (("J2c", 3.0), ("J3c", 15.0)):
        v, s = got[name]
        assert abs(v - true) < max(4 * s, 0.05 * true), (name, v, s)
    stiff = simulate_measurements(irb120(), q, rng, joint_noise_deg=0.0)
    plain = identify(irb120(), stiff, kind="full", frames="known", compliance="auto")
    assert plain.compliance == "none" and "left out" in plain.compliance_note


def test_auto_diagnoses_only_the_fit_it_returns(monkeypatch):
    """The joint-2/3 fit that "auto" sets aside is not diagnosed (its data-quality figures were
    computed and thrown away); the fit returned carries them, as the one kept fit always did."""
    import screwcal.calibration.identify_stages as stages_module

    calls = []
    real = stages_module.data_quality
    monkeypatch.setattr(stages_module, "data_quality",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    rng = np.random.default_rng(3)
    stiff = simulate_measurements(irb120(), random_configurations(80, rng), rng)
    plain = identify(irb120(), stiff, kind="full", frames="known", compliance="auto")
    assert plain.compliance == "none" and "left out" in plain.compliance_note
    assert len(calls) == 1 and plain.diagnostics is not None
    calls.clear()
    kept = identify(irb120(), simulate_measurements(bent(irb120()), random_configurations(
        80, rng), rng), kind="full", frames="known", compliance="auto")
    assert kept.compliance == "j23" and len(calls) == 1 and kept.diagnostics is not None


def test_compensation_with_a_compliant_model_puts_the_bent_robot_on_target():
    truth = bent(irb120())
    q_ref = random_configurations(20, np.random.default_rng(4))
    targets = flange_kinematics(irb120(), q_ref)
    comp = compensate(truth, irb120(), targets, q_ref, frame="base")
    reached = flange_kinematics(truth, comp.q_rad)
    assert np.abs(reached[:, :3, 3] - targets[:, :3, 3]).max() < 1e-3
    sagged = flange_kinematics(truth, q_ref)  # without the compensation it misses
    assert np.abs(sagged[:, :3, 3] - targets[:, :3, 3]).max() > 0.05


def test_per_mass_compliance_jacobian_file_and_auto_choice():

    m = replace(irb120(), payload=Payload(0.5, (0.0, 0.0, 40.0)))
    cands = candidate_params(m, "full", base=False, tool_rotation=False, tool_position=False,
                             compliance="j23-free")
    names = [p.name for p in cands if p.kind == "compliance_mass"]
    assert names == ["J2c.m1", "J2c.m2", "J2c.m3", "J3c.m2", "J3c.m3"]  # masses that load them
    errors = ErrorModel(m, tuple(cands))
    rng = np.random.default_rng(5)
    x = rng.normal(0, 1e-3, len(cands))
    cols = [k for k, p in enumerate(cands) if p.kind == "compliance_mass"]
    x[cols] = np.radians([3.0, 2.0, 6.0, 15.0, 12.0])
    q = random_configurations(5, rng)
    T, J, _ = errors.linearisation(x, q)
    for k in cols:  # the payload rides on the last arm mass's coefficient
        step = np.zeros_like(x)
        step[k] = 1e-6
        fd = point_rates(forward_kinematics(errors.apply(x + step), q), T, 1e-6)
        np.testing.assert_allclose(fd, J[:, :, k], atol=2e-3 * np.abs(J[:, :, k]).max())
    fitted = errors.apply(x)
    back = parse_model(model_document(fitted))
    np.testing.assert_allclose(forward_kinematics(back, q), forward_kinematics(fitted, q),
                               atol=1e-9)
    # a robot whose masses are not in the table's proportions: rich data pick the per-mass form
    truth = replace(irb120(), compliance_by_mass=np.radians(
        [[0, 0, 0], [2.0, 8.0, 30.0], [0, 15.0, 2.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]]) / 1000)
    q = random_configurations(300, rng)
    data = simulate_measurements(truth, q, rng, joint_noise_deg=0.0)
    r = identify(irb120(), data, kind="full", frames="known", compliance="auto")
    assert r.compliance == "j23-free" and "F-test" in r.compliance_note
    few = identify(irb120(), data.take(np.arange(60)), kind="full", frames="known",
                   compliance="auto")
    assert few.compliance == "j23"  # too few poses to try it
