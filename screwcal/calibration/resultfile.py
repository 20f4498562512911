"""The calibration result document (`result.json`): parameters with units and standard errors,
identifiability, convergence, residuals, frames, the joint-offset correction and the calibrated
model, and the nominal model it was calibrated against (`nominal_model`). `screwcal calibrate`
writes it, the job service serves it (`GET /jobs/{id}/model`), `predict`, `compensate`, the
RAPID filter and `robot export` read its `model` member, `compensate` its `nominal_model`."""

from __future__ import annotations

import numpy as np

from screwcal.calibration.correction import joint_correction
from screwcal.calibration.identify import CalibrationResult
from screwcal.errors import CorrectionRefusedError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import model_document, pose_document

RESULT_FORMAT = "screwcal-calibration"


def _summary(values: np.ndarray) -> dict:
    return {"mean": float(values.mean()), "rms": float(np.sqrt(np.mean(values**2))),
            "max": float(values.max())}


def result_document(result: CalibrationResult, robot: str, settings: dict,
                    model: SerialModel | None = None, model_note: str | None = None) -> dict:
    """The result.json document: parameters, identifiability, residuals, model, correction.
    `model` replaces the identified one (e.g. the robot's model once a ZERO correction made the
    identified offsets the new zero), `model_note` says so."""
    params = [{"name": p.name, "unit": p.unit, "group": p.group, "value": float(v),
               "std_error": float(s)}
              for p, v, s in zip(result.params, result.values, result.std_errors, strict=True)]
    residuals: dict = {"kind": result.residual_kind, "unit": "mm",
                       "before": result.residuals_before.tolist(),
                       "after": result.residuals_after.tolist(),
                       "summary_before": _summary(result.residuals_before),
                       "summary_after": _summary(result.residuals_after)}
    if len(result.pose_ids) == len(result.residuals_after):  # per pose (not per pair)
        residuals["poses"] = list(result.pose_ids)  # whose residuals, in order
    before_deg, after_deg = result.rotation_before_deg, result.rotation_after_deg
    if before_deg is not None and after_deg is not None:
        residuals |= {"rotation_before_deg": before_deg.tolist(),
                      "rotation_after_deg": after_deg.tolist()}
    try:
        correction = joint_correction(result.params, result.values, result.std_errors,
                                      result.model.n_joints).to_dict()
    except CorrectionRefusedError as err:
        correction = {"refused": str(err)}
    return {
        "format": RESULT_FORMAT, "version": 1, "robot": robot, "settings": settings,
        "parameters": params,
        "compliance": compliance_summary(result),
        "reading_lag": {"per_joint": None if result.reading_lag is None else
                        [float(v) for v in result.reading_lag], "note": result.lag_note,
                        "lost_motion_deg": lost_motion_deg(result)},
        "removed_parameters": [{"name": n, "reason": why} for n, why in result.removed],
        "correlation": {"names": list(result.names), "matrix": result.correlation.tolist()},
        "identifiability": {
            "rank": result.rank, "candidates": result.n_candidates,
            "condition_number": result.condition_number, "o1_borm_menq": result.o1,
            "min_singular_value": result.min_singular_value, "degenerate": result.degenerate,
            "unidentifiable_combinations": list(result.unidentifiable_combinations)},
        "convergence": {"converged": result.converged, "message": result.message,
                        "evaluations": result.n_evaluations, "seconds": result.seconds,
                        "chi2_reduced": result.chi2_reduced},
        "predicts": {"position": True, "orientation": not result.orientation_unknown,
                     "orientation_unknown": result.orientation_unknown or None},
        "nearest_nominal": {
            "rule": "a weak prior on every parameter, its plausible range as the standard "
                    "deviation: among models that fit equally, the one nearest nominal",
            "prior_scales": result.prior_note or "the plausible ranges",
            "held_by_prior": list(result.held_by_prior),
            "implausible": list(result.implausible)},
        "noise": result.noise.to_dict() if result.noise is not None else None,
        "outliers": [o.to_dict() for o in result.outliers],
        "diagnostics": {} if result.diagnostics is None else result.diagnostics.to_dict(),
        "warnings": result.warnings,
        "residuals": residuals,
        "frames": {"base": pose_document(result.model.base),
                   "tool": pose_document(result.model.tool)},
        "correction": correction,
        "model": model_document(model or result.model),
        # the robot calibrated against, frames aside: compensate, the RAPID filter and export
        # need no robot named again, whether it came from the library or a file
        "nominal_model": model_document(result.start_model.with_frames(np.eye(4), np.eye(4))),
        "model_note": model_note or "the identified model: the robot as the controller reads "
                                    "its joints during the calibration",
    }


def lost_motion_deg(result: CalibrationResult) -> list[float] | None:
    """The lost motion (backlash) per joint the readings were corrected for with their lag
    (deg; mm for a prismatic joint), or None."""
    lost = result.reading_lost_motion
    return None if lost is None else [float(v) for v in result.model.joints_to_deg(lost)]


def compliance_summary(result: CalibrationResult) -> dict:
    """The joint compliance identified (or why none): per joint the compliance (deg per kN m)
    with its standard error and the stiffness (kN m per deg), and the payload it was under."""
    joints = []
    for p, v, s in zip(result.params, result.values, result.std_errors, strict=True):
        if p.kind.startswith("compliance"):
            joints.append({"joint": p.joint + 1, "name": p.name,
                           "loaded_by": "all masses" if p.kind == "compliance" else
                           f"arm mass {p.axis + 1}", "compliance_deg_per_knm": float(v),
                           "std_error": float(s),
                           "stiffness_knm_per_deg": float(1.0 / v) if v > 0 else None,
                           "share_the_geometry_cannot_absorb": result.unabsorbed.get(p.name)})
    payload = result.model.payload
    return {"chosen": result.compliance, "note": result.compliance_note, "joints": joints,
            "not_identifiable": [n for n, _ in result.removed if n.endswith("c")],
            "payload": {"kg": payload.kg, "cog_mm": list(payload.cog_mm)}}
