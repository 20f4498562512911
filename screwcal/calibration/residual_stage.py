"""The residual stage after identification: the residual model (`residual_model`) learned from
the poses an identification kept, and the decision whether to use it (`learn_residual`)."""

from __future__ import annotations

import numpy as np

from screwcal.calibration.identify_result import CalibrationResult
from screwcal.calibration.lag import correct_lag
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.residual_model import (
    MIN_POSES,
    RESIDUAL_MODES,
    ResidualMode,
    ResidualOutcome,
    fit_residual_model,
)
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.se3 import Array


def training_set(result: CalibrationResult, data: MeasurementSet) -> tuple[Array, Array]:
    """The joints (N, n) and position residuals (N, 3) of the poses the identification kept
    (its rejected outliers out, its lag correction applied), of its calibrated model."""
    rejected = {o.id for o in result.outliers if o.rejected}
    kept = data.take(np.array([k for k, i in enumerate(data.ids) if i not in rejected], int))
    if result.reading_lag is not None:
        kept = correct_lag(kept, result.reading_lag)
    predicted = forward_kinematics(result.model, kept.q)[:, :3, 3]
    return kept.q, kept.positions_mm - predicted


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
    model = fit_residual_model(q, residuals)
    cv = model.cv
    if cv.beats_physical():
        return ResidualOutcome(mode, model, True, f"kept ({mode}): {cv.describe()}")
    if mode == "auto":
        return ResidualOutcome(mode, model, False, f"declined (auto): {cv.describe()}; no "
                               "gain beyond its spread")
    return ResidualOutcome(mode, model, True, f"kept (gp, as asked): {cv.describe()}", (
        f"the residual model does not beat the physical model beyond its spread "
        f"({cv.describe()}): kept because --residual-model gp asked for it",))


def _not_applicable(result: CalibrationResult) -> str:
    """Why no residual model can be learned from this identification, or ""."""
    if result.residual_kind == "distance":
        return "distance data do not place the measured point in a frame"
    if not np.all(result.model.is_revolute):
        return "a prismatic joint (the features are the angles of revolute joints)"
    return ""
