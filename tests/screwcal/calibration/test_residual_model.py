"""The residual model over joint space (residual_gp, residual_model): it learns a smooth
residual, declines pure noise, says how sure it is, refuses to extrapolate, and round-trips
through the result file."""

import json

import numpy as np
import pytest

from screwcal.calibration.residual_gp import (
    Hyperparameters,
    Posterior,
    fit_hyperparameters,
    fold_predictions,
    joint_features,
    kernel,
)
from screwcal.calibration.residual_model import (
    BAND_CHI2,
    RESIDUAL_MODEL_VERSION,
    ResidualOutcome,
    fit_residual_model,
    residual_from_document,
)
from screwcal.errors import ModelError

LIMITS = np.radians([[-160, 160], [-80, 80], [-80, 60], [-150, 150], [-110, 110], [-170, 170]])


def _joints(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(LIMITS[:, 0], LIMITS[:, 1], (n, 6))


def _smooth(q: np.ndarray) -> np.ndarray:
    """A residual (N, 3) mm that is a smooth function of the joints, 0.1 mm in size."""
    return 0.06 * np.c_[np.sin(q[:, 1] + q[:, 2]), np.cos(q[:, 0]) * np.sin(q[:, 4]),
                        np.sin(2 * q[:, 3]) * 0.5 + np.cos(q[:, 1])]


def test_a_smooth_residual_is_learned_and_its_band_holds(rng):
    q, q_new = _joints(rng, 400), _joints(rng, 2000)
    noise = 0.02
    model = fit_residual_model(q, _smooth(q) + rng.normal(0, noise, (400, 3)))
    assert model.cv.beats_physical()
    assert model.cv.corrected_mean_mm < 0.7 * model.cv.physical_mean_mm
    assert 0.5 * noise < model.h.noise_mm < 1.5 * noise
    observed = _smooth(q_new) + rng.normal(0, noise, (2000, 3))
    p = model.predict(q_new)
    before = np.linalg.norm(observed, axis=1).mean()
    after = np.linalg.norm(observed - p.correction_mm, axis=1)
    assert after.mean() < 0.6 * before
    coverage = np.mean(after ** 2 / p.std_mm ** 2 <= BAND_CHI2)
    assert 0.90 <= coverage <= 0.98, coverage


def test_pure_noise_is_declined(rng):
    q = _joints(rng, 300)
    model = fit_residual_model(q, rng.normal(0, 0.03, (300, 3)))
    assert not model.cv.beats_physical(), model.cv.describe()


def test_fold_predictions_are_those_of_a_process_trained_on_the_other_folds(rng):
    q = _joints(rng, 60)
    X, Y = joint_features(q), _smooth(q) + rng.normal(0, 0.01, (60, 3))
    h = Hyperparameters(1.3, 0.05, 0.01)
    folds = np.arange(60) % 4
    mean, var = fold_predictions(Posterior.train(X, Y, h), Y, folds)
    for f in range(4):
        out = folds == f
        alone = Posterior.train(X[~out], Y[~out], h)
        m, latent, _ = alone.predict(X[out])
        np.testing.assert_allclose(mean[out], m, atol=1e-10)
        np.testing.assert_allclose(var[out], latent + h.noise_mm ** 2, rtol=1e-8)


def _nll(X: np.ndarray, Y: np.ndarray, h: Hyperparameters) -> float:
    """The negative log marginal likelihood, written the plain way (Cholesky)."""
    Ky = kernel(X, X, h) + h.noise_mm ** 2 * np.eye(len(X))
    L = np.linalg.cholesky(Ky)
    A = np.linalg.solve(L, Y)
    return 0.5 * float(np.sum(A * A)) + Y.shape[1] * float(np.sum(np.log(np.diag(L))))


def test_hyperparameters_maximise_the_marginal_likelihood(rng):
    q = _joints(rng, 150)
    X, Y = joint_features(q), _smooth(q) + rng.normal(0, 0.015, (150, 3))
    h = fit_hyperparameters(X, Y)
    best = _nll(X, Y, h)
    for factor in (0.8, 1.25):
        for changed in (Hyperparameters(h.length * factor, h.signal_mm, h.noise_mm),
                        Hyperparameters(h.length, h.signal_mm * factor, h.noise_mm),
                        Hyperparameters(h.length, h.signal_mm, h.noise_mm * factor)):
            assert _nll(X, Y, changed) > best - 1e-3


def test_far_from_the_calibration_poses_no_correction_and_a_note(rng):
    q = _joints(rng, 200) * 0.3  # the calibration covers a third of each range around zero
    model = fit_residual_model(q, _smooth(q) + rng.normal(0, 0.01, (200, 3)))
    far = np.radians([[150, 75, 55, 140, 100, 160]])
    p = model.predict(np.r_[q[:1], far])
    assert p.within_reach.tolist() == [True, False]
    np.testing.assert_array_equal(p.correction_mm[1], 0.0)
    assert "beyond the residual model's reach" in p.note(1) and p.note(0) == ""
    assert p.std_mm[1] > p.std_mm[0]
    assert "1 beyond its reach" in p.summary()


def _document(rng: np.random.Generator) -> dict:
    q = _joints(rng, 80)
    model = fit_residual_model(q, _smooth(q) + rng.normal(0, 0.01, (80, 3)))
    outcome = ResidualOutcome("gp", model, True, "kept")
    return json.loads(json.dumps({"residual_model": outcome.to_dict()}))


def test_the_result_file_carries_it_and_older_results_have_none(rng):
    doc = _document(rng)
    member = doc["residual_model"]
    assert member["version"] == RESIDUAL_MODEL_VERSION and member["used"]
    assert len(member["training"]["joints_deg"]) == 80
    assert {"length_scale", "signal_mm", "noise_mm"} == set(member["hyperparameters"])
    assert member["cross_validation"]["folds"] == 5
    loaded = residual_from_document(doc, "result.json")
    assert loaded is not None
    q = _joints(rng, 5)
    np.testing.assert_allclose(loaded.predict(q).correction_mm,
                               loaded.predict(q).correction_mm)
    assert residual_from_document({"format": "screwcal-calibration", "version": 1}) is None
    declined = ResidualOutcome("auto", None, False, "declined").to_dict()
    assert residual_from_document({"residual_model": declined}) is None


def test_a_newer_or_broken_residual_model_is_refused_by_name(rng):
    doc = _document(rng)
    doc["residual_model"]["version"] = RESIDUAL_MODEL_VERSION + 1
    with pytest.raises(ModelError, match=r"r\.json: residual_model .* newer screwcal"):
        residual_from_document(doc, "r.json")
    doc = _document(rng)
    del doc["residual_model"]["training"]
    with pytest.raises(ModelError, match=r"r\.json: residual_model is incomplete"):
        residual_from_document(doc, "r.json")
    doc = _document(rng)
    doc["residual_model"]["training"]["residuals_mm"][0] = [1.0, 2.0]
    with pytest.raises(ModelError, match=r"r\.json: residual_model"):
        residual_from_document(doc, "r.json")


def test_predictions_in_blocks_equal_one_block(rng, monkeypatch):
    from screwcal.calibration import residual_gp

    q = _joints(rng, 50)
    model = fit_residual_model(q, _smooth(q) + rng.normal(0, 0.01, (50, 3)))
    q_new = _joints(rng, 23)
    whole = model.predict(q_new)
    monkeypatch.setattr(residual_gp, "CHUNK_ROWS", 5)
    blocks = model.predict(q_new)
    np.testing.assert_allclose(blocks.correction_mm, whole.correction_mm, atol=1e-12)
    np.testing.assert_allclose(blocks.std_mm, whole.std_mm, atol=1e-12)
    np.testing.assert_allclose(blocks.nearest_lengths, whole.nearest_lengths, atol=1e-12)


def test_a_large_set_trains_on_a_seeded_subset_and_says_so(rng, monkeypatch):
    from screwcal.calibration import residual_stage
    from screwcal.calibration.identify import identify
    from screwcal.calibration.posesets import random_configurations
    from screwcal.kinematics.robots import irb1600
    from screwcal.studies.simulated_measurements import simulate_measurements

    q = random_configurations(60, rng)
    data = simulate_measurements(irb1600(), q, rng, joint_noise_deg=0.0)
    data = data.__class__(data.q, data.positions_mm + _smooth(data.q), data.rotations)
    result = identify(irb1600(), data, kind="joints")
    monkeypatch.setattr(residual_stage, "MAX_POSES", 40)
    outcome = residual_stage.learn_residual(result, data, "gp")
    kept = len(data) - sum(o.rejected for o in result.outliers)
    assert f"(trained on 40 of the {kept} poses kept, a seeded random subset)" in outcome.note
    assert outcome.model is not None and outcome.model.q_rad.shape == (40, 6)
    again = residual_stage.learn_residual(result, data, "gp")
    np.testing.assert_array_equal(again.model.q_rad, outcome.model.q_rad)


def test_a_residual_that_ignores_joint_1_is_told_by_the_marginal_likelihood(rng):
    """Gravity's pull does not change with joint 1 on a floor-mounted arm: a residual of the
    other joints alone leaves joint 1 out of the features, and the file says which joints."""
    q = _joints(rng, 200)
    alone = 0.06 * np.c_[np.sin(q[:, 1] + q[:, 2]), np.cos(q[:, 4]), np.sin(2 * q[:, 3])]
    model = fit_residual_model(q, alone + rng.normal(0, 0.01, (200, 3)))
    assert model.joints == (1, 2, 3, 4, 5)
    member = ResidualOutcome("gp", model, True, "kept").to_dict()
    assert member["joints"] == [2, 3, 4, 5, 6]
    loaded = residual_from_document(json.loads(json.dumps({"residual_model": member})))
    assert loaded is not None and loaded.joints == (1, 2, 3, 4, 5)
    q_new = _joints(rng, 5)
    np.testing.assert_allclose(loaded.predict(q_new).correction_mm,
                               model.predict(q_new).correction_mm, atol=1e-12)
    turned = q_new.copy()
    turned[:, 0] += 1.0  # joint 1 turned: the same correction
    np.testing.assert_allclose(model.predict(turned).correction_mm,
                               model.predict(q_new).correction_mm, atol=1e-12)
    with_1 = fit_residual_model(q, _smooth(q) + rng.normal(0, 0.01, (200, 3)))
    assert with_1.joints is None  # _smooth depends on joint 1
