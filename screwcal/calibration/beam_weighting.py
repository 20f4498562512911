"""Weighting a laser tracker's points: the covariance each point was reported with, plus what the
data show beyond it, along the beam and across it.

A tracker reports each point's covariance from its own error model: a few um along the beam,
several times that across it. Weighting by it alone is right when that noise is all there is
(`studies.tracker_noise`: the Cramer-Rao bound is reached). On a real robot the model's misfit
(repeatability, what the model leaves out) adds tens of um in every direction, and the reported
covariance then trusts the beam's direction far more than the data allow: on the IRB 120 tracker
data set (positions of SMR 1, full model, compliance and lag auto, three random halves) the
held-out mean error grows from 0.093-0.096 mm to 0.101-0.102 mm.

So the data say what they carry beyond the reported covariance, per component: a first fit's
residuals give the noise along the beam and across it (`beam_levels`, RMS corrected for the
parameters fitted); what exceeds the reported covariance's own share is added to every point as an
excess along and across its beam (`covariance_with_excess`), and the fit is repeated. With
tracker noise alone the excess is nil and the points keep their reported weights; with a misfit
that dominates, the weights become nearly isotropic. Points are taken in the tracker's own frame
(its head at the origin), as a tracker reports them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from screwcal.calibration.identify import CalibrationResult, identify
from screwcal.calibration.lag import correct_lag
from screwcal.calibration.measurements import MeasurementSet
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array


@dataclass(frozen=True)
class BeamLevels:
    """Noise levels along the beam and across it (per direction), mm (1 sigma)."""

    radial_mm: float
    lateral_mm: float


def _beam_projectors(points_mm: Array) -> Array:
    p = np.asarray(points_mm, dtype=float)
    u = p / np.linalg.norm(p, axis=1, keepdims=True)
    return np.asarray(u[:, :, None] * u[:, None, :], dtype=float)


def beam_levels(residuals_mm: Array, points_mm: Array, n_params: int = 0) -> BeamLevels:
    """The noise per component from a fit's residuals (N, 3) at points (N, 3) seen from a
    tracker at the origin: the RMS along the beam and across it (per direction), each corrected
    for the `n_params` parameters the fit took out of the 3 N rows."""
    e = np.asarray(residuals_mm, dtype=float)
    P = _beam_projectors(points_mm)
    radial_sq = np.einsum("ni,nij,nj->n", e, P, e)
    lateral_sq = np.sum(e * e, axis=1) - radial_sq
    dof = max(0.1, 1.0 - n_params / (3.0 * len(e)))
    return BeamLevels(float(np.sqrt(np.mean(radial_sq) / dof)),
                      float(np.sqrt(np.mean(lateral_sq) / 2.0 / dof)))


def covariance_with_excess(points_mm: Array, reported_mm2: Array | None, levels: BeamLevels
                           ) -> tuple[Array, BeamLevels]:
    """Each point's covariance (N, 3, 3): the reported one (or none) plus the excess of
    `levels` over the reported covariance's mean share along and across the beam; and that
    excess."""
    P = _beam_projectors(points_mm)
    Q = np.eye(3) - P
    if reported_mm2 is None:
        reported_mm2 = np.zeros_like(P)
    share_radial = float(np.mean(np.einsum("nij,nji->n", P, reported_mm2)))
    share_lateral = float(np.mean(np.einsum("nij,nji->n", Q, reported_mm2))) / 2.0
    excess = BeamLevels(float(np.sqrt(max(0.0, levels.radial_mm**2 - share_radial))),
                        float(np.sqrt(max(0.0, levels.lateral_mm**2 - share_lateral))))
    cov = reported_mm2 + excess.radial_mm**2 * P + excess.lateral_mm**2 * Q
    return np.asarray(cov, dtype=float), excess


@dataclass(frozen=True)
class BeamFit:
    result: CalibrationResult  # the fit weighted by the reported covariance and the excess
    levels: BeamLevels  # the first fit's noise along and across the beam
    excess: BeamLevels  # what of it the reported covariance did not explain


def fit_residuals(result: CalibrationResult, data: MeasurementSet) -> Array:
    """The fit's position residuals (N, 3), model minus measured, the readings' lag undone as
    the fit undid it."""
    seen = data if result.reading_lag is None else correct_lag(data, result.reading_lag,
                                                                 result.reading_lost_motion)
    return np.asarray(forward_kinematics(result.model, seen.q)[:, :3, 3] - data.positions_mm,
                      dtype=float)


def identify_beam_weighted(nominal: SerialModel, data: MeasurementSet, **options: Any
                           ) -> BeamFit:
    """`identify` twice: on the data as given, then with each point's covariance the reported
    one plus the excess the first fit's residuals show along and across the beam."""
    first = identify(nominal, data, **options)
    kept = [k for k, pid in enumerate(data.ids)
            if pid not in {o.id for o in first.outliers if o.rejected}]
    part = data.take(kept)
    levels = beam_levels(fit_residuals(first, part), part.positions_mm, len(first.params))
    cov, excess = covariance_with_excess(data.positions_mm, data.position_cov_mm2, levels)
    second = identify(nominal, replace(data, position_cov_mm2=cov), **options)
    return BeamFit(second, levels, excess)
