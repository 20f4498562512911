"""A joint compliance the data push below zero is held at zero in the calibrated model.

A joint cannot be stiffer than rigid: a negative compliance is the noise of a fit whose joint
barely bends (J3c = -0.0007 +- 0.2 deg/kNm), or a sign the model has wrong (a mass table, the
gravity direction) when it lies many standard errors below zero. Either way the model file
refuses it (every command that reads the result would stop), so the model the result carries
holds it at 0 and the result says so; the parameter table keeps the estimate with its
standard error, as the data gave it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from screwcal.calibration.identify_result import CalibrationResult

SIGNIFICANT_SIGMA = 3.0  # below zero by more standard errors: a warning that something is wrong


def held_at_zero(result: CalibrationResult) -> CalibrationResult:
    """The result with every negative per-joint compliance of its model set to 0, and a
    warning naming each estimate held. Coefficients per joint and arm mass
    (`compliance_by_mass`, "j23-free") are left as they are: one below zero corrects the mass
    table's proportions, the file takes it, and only their sum is a joint's compliance."""
    model = result.model
    if not (model.compliance < 0).any():
        return result
    held = []
    for p, v, s in zip(result.params, result.values, result.std_errors, strict=True):
        if p.kind == "compliance" and v < 0:
            sigmas = -v / s if s > 0 else np.inf
            held.append(f"{p.name} {v:.3g} +- {s:.2g} deg/kNm ("
                        + (f"{sigmas:.1f} standard errors below zero: check the masses, the "
                           "payload and the robot's gravity direction"
                           if sigmas > SIGNIFICANT_SIGMA else
                           f"{sigmas:.1f} standard errors: none within the noise") + ")")
    if not held:  # a compliance below zero the parameters do not show (the nominal's own)
        held.append("the model's own compliance below zero")
    warning = ("joint compliance below zero held at 0 in the model (a joint cannot be stiffer "
               "than rigid; the parameter table keeps the estimate): " + "; ".join(held))
    fixed = replace(model, compliance=np.maximum(model.compliance, 0.0))
    return replace(result, model=fixed, data_warnings=(*result.data_warnings, warning))
