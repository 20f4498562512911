"""The residual stage after identification: the residual model (`residual_model`) learned from
the poses an identification kept, and the decision whether to use it (`learn_residual`)."""

from __future__ import annotations

import numpy as np

from screwcal.calibration.identify_result import CalibrationResult
from screwcal.calibration.lag import correct_lag
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.residual_model import (
    BAND_CHI2,
    MAX_POSES,
    MIN_POSES,
    RESIDUAL_MODES,
    ResidualMode,
    ResidualOutcome,
    fit_residual_model,
)
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.se3 import Array


def training_set(result: CalibrationResult, data: MeasurementSet, rejected: bool = False
                 ) -> tuple[Array, Array]:
    """The joints (N, n) and position residuals (N, 3) of the calibrated model on the poses the
    identification kept (`rejected`: on those it set aside as outliers), its lag correction
    applied."""
    out = {o.id for o in result.outliers if o.rejected}
    chosen = data.take(np.array([k for k, i in enumerate(data.ids) if (i in out) == rejected],
                                int))
    if result.reading_lag is not None:
        chosen = correct_lag(chosen, result.reading_lag, result.reading_lost_motion)
    predicted = forward_kinematics(result.model, chosen.q)[:, :3, 3]
    return chosen.q, chosen.positions_mm - predicted


def learn_residual(result: CalibrationResult, data: MeasurementSet,
                   mode: ResidualMode = "auto") -> ResidualOutcome:
    """The residual stage after identification (`mode`: see `residual_model`); `data`: the
    measurements the identification was given."""
    if mode not in RESIDUAL_MODES:
        raise ValueError(f"residual mode is one of {RESIDUAL_MODES}, not {mode!r}")
    if mode == "none":
        return ResidualOutcome(mode, None, False, "not asked (--residual-model none)")
    why = _not_applicable(result)
    if not why:
        q, residuals = training_set(result, data)
        if len(q) < MIN_POSES:
            why = f"{len(q)} calibration poses kept, fewer than the {MIN_POSES} it needs"
    if why:
        note = f"no residual model: {why}"
        return ResidualOutcome(mode, None, False, note, (note,) if mode == "gp" else ())
    subset = ""
    if len(q) > MAX_POSES:  # the exact process costs N^3: a seeded random subset
        subset = f" (trained on {MAX_POSES} of the {len(q)} poses kept, a seeded random subset)"
        pick = np.sort(np.random.default_rng(0).choice(len(q), MAX_POSES, replace=False))
        q, residuals = q[pick], residuals[pick]
    model = fit_residual_model(q, residuals, *training_set(result, data, rejected=True))
    cv = model.cv
    if cv.beats_physical():
        return ResidualOutcome(mode, model, True, f"kept ({mode}): {cv.describe()}{subset}")
    if mode == "auto":
        return ResidualOutcome(mode, model, False, f"declined (auto): {cv.describe()}; no "
                               f"gain beyond its spread{subset}")
    return ResidualOutcome(mode, model, True, f"kept (gp, as asked): {cv.describe()}{subset}", (
        f"the residual model does not beat the physical model beyond its spread "
        f"({cv.describe()}): kept because --residual-model gp asked for it",))


def _not_applicable(result: CalibrationResult) -> str:
    """Why no residual model can be learned from this identification, or ""."""
    if result.residual_kind == "distance":
        return "distance data do not place the measured point in a frame"
    if not np.all(result.model.is_revolute):
        return "a prismatic joint (the features are the angles of revolute joints)"
    return ""


def held_out_figures(result: CalibrationResult, outcome: ResidualOutcome,
                     held_out: MeasurementSet) -> dict[str, float | int | bool]:
    """The physical model's and the residual model's position errors on measurements the
    identification never saw (their readings corrected for the fit's lag), and the check that
    the predictive uncertainty is honest: the share of held-out errors within their 95 % band
    (chi-square, three components). The corrected figures are what the user gets: the
    physical ones where `outcome` did not keep a residual model."""
    seen = held_out if result.reading_lag is None else correct_lag(held_out, result.reading_lag,
                                                                         result.reading_lost_motion)
    error = seen.positions_mm - forward_kinematics(result.model, seen.q)[:, :3, 3]
    physical = np.linalg.norm(error, axis=1)
    out: dict[str, float | int | bool] = {
        "poses": len(seen), "used": outcome.used, "physical_mean_mm": float(physical.mean()),
        "physical_rms_mm": float(np.sqrt(np.mean(physical ** 2))),
        "physical_max_mm": float(physical.max())}
    if outcome.model is None or not outcome.used:
        return out | {"corrected_mean_mm": out["physical_mean_mm"],
                      "corrected_rms_mm": out["physical_rms_mm"],
                      "corrected_max_mm": out["physical_max_mm"]}
    p = outcome.model.predict(seen.q)
    corrected = np.linalg.norm(error - p.correction_mm, axis=1)
    return out | {"corrected_mean_mm": float(corrected.mean()),
                  "corrected_rms_mm": float(np.sqrt(np.mean(corrected ** 2))),
                  "corrected_max_mm": float(corrected.max()),
                  "coverage_95": float(np.mean(corrected ** 2 <= BAND_CHI2 * p.std_mm ** 2)),
                  "mean_std_mm": float(p.std_mm.mean()),
                  "beyond_reach": int((~p.within_reach).sum())}
