"""What an identification returns: the calibrated model with its parameters, their standard
errors and correlations, how well the data determined them, the noise levels used, the poses
left out, and the warnings the user must read (`CalibrationResult.warnings`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from screwcal.calibration.diagnostics import DataQuality
from screwcal.calibration.error_parameters import Param
from screwcal.calibration.identifiability import Residual
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array
from screwcal.tables import counted


@dataclass(frozen=True)
class NoiseEstimate:
    """The noise levels the fit used: estimated from the data or fixed by the user."""

    position_mm: float
    orientation_deg: float
    joint_deg: float  # uniform +- half-width (sigma = joint_deg / sqrt 3)
    position_std_mm: float | None  # standard deviation of the estimate; None: fixed
    orientation_std_deg: float | None
    joint_std_deg: float | None
    iterations: int = 0
    converged: bool = True
    note: str = ""  # how a level was chosen, when not simply estimated or fixed

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, unit, value, std in (
                ("position", "mm", self.position_mm, self.position_std_mm),
                ("orientation", "deg", self.orientation_deg, self.orientation_std_deg),
                ("joint", "deg (uniform +-)", self.joint_deg, self.joint_std_deg)):
            measured = bool(np.isfinite(value))
            out[name] = {"value": value if measured else None, "unit": unit,
                         "estimated": std is not None, "std": std, "measured": measured}
        out["iterations"], out["converged"] = self.iterations, self.converged
        out["note"] = self.note
        return out


@dataclass(frozen=True)
class Outlier:
    """A pose whose residual says it does not belong."""

    id: str
    line: int | None  # in the measurement file, when known
    residual_mm: float  # its position residual in the fit that flagged it
    statistic: float  # T_i (chi-square)
    threshold: float
    rejected: bool

    def describe(self) -> str:
        where = f" (line {self.line})" if self.line else ""
        return f"pose {self.id}{where} {self.residual_mm:.3f} mm, T {self.statistic:.0f} > " \
               f"{self.threshold:.0f}"

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "line": self.line, "residual_mm": self.residual_mm,
                "statistic": self.statistic, "threshold": self.threshold,
                "rejected": self.rejected}


@dataclass(frozen=True)
class CalibrationResult:
    model: SerialModel  # the calibrated model (base and tool included)
    start_model: SerialModel  # the nominal model with the starting frames
    params: tuple[Param, ...]  # identified
    values: Array  # interface units (deg, mm), relative to the start
    std_errors: Array
    correlation: Array
    removed: tuple[tuple[str, str], ...]  # (name, why)
    unidentifiable_combinations: tuple[str, ...]
    residual_kind: Residual
    weighting: str
    solver: str
    rank: int
    n_candidates: int
    condition_number: float
    o1: float  # Borm-Menq O1 of the column-scaled weighted Jacobian
    min_singular_value: float
    chi2_reduced: float
    converged: bool
    message: str
    n_evaluations: int
    seconds: float
    residuals_before: Array  # (N,) position error norm per pose, mm (pairs for distances)
    residuals_after: Array
    rotation_before_deg: Array | None = None
    rotation_after_deg: Array | None = None
    degenerate: bool = False
    covariance: Array = field(default_factory=lambda: np.zeros((0, 0)))  # numeric units
    noise: NoiseEstimate | None = None  # the levels used (statistical weighting)
    outliers: tuple[Outlier, ...] = ()  # rejected (and, with outliers="keep", kept) poses
    diagnostics: DataQuality | None = None  # data_quality(): lag, drift, leverage, fit
    compliance: str = "none"  # the joint compliance identified: none, j23, j23-free, wrist
    compliance_note: str = ""  # why (compliance="auto")
    unabsorbed: dict[str, float] = field(default_factory=dict)  # single_fit.unabsorbed
    reading_lag: Array | None = None  # (n,) per joint, when lag="auto" corrected the readings
    # (n,) the lost motion (backlash, rad / mm) per joint the readings were corrected for with it
    reading_lost_motion: Array | None = None
    lag_note: str = ""
    data_warnings: tuple[str, ...] = ()  # degenerate data, named before the fit
    held_by_prior: tuple[str, ...] = ()  # directions the data left to the prior (nominal)
    prior_note: str = ""  # the prior's scales, when learned from a small set (empirical_prior)
    implausible: tuple[str, ...] = ()  # parameters beyond their plausible range
    orientation_unknown: str = ""  # why the model predicts positions, not the orientation
    pose_ids: tuple[str, ...] = ()  # the ids of the poses fitted (the outliers' left out), in order

    @property
    def warnings(self) -> list[str]:
        """What the user must read: data-quality findings and the poses left out."""
        out = list(self.data_warnings)
        out += self.diagnostics.warnings if self.diagnostics is not None else []
        if self.implausible:
            out.append("implausible parameters (check the data, the set-up and the nominal "
                       "model before using this one): " + "; ".join(self.implausible))
        if self.orientation_unknown:
            out.append(f"position-only model: {self.orientation_unknown}; compensate refuses "
                       "targets with an orientation")
        rejected = [o for o in self.outliers if o.rejected]
        if rejected:
            out.append(f"{counted(len(rejected), 'pose')} rejected as "
                       f"{'an outlier' if len(rejected) == 1 else 'outliers'}: " + ", ".join(
                o.describe() for o in rejected[:10]))
        kept = [o for o in self.outliers if not o.rejected]
        if kept:
            look = "looks" if len(kept) == 1 else "look"
            out.append(f"{counted(len(kept), 'pose')} {look} like outliers but "
                       f"{'was' if len(kept) == 1 else 'were'} kept: " + ", ".join(
                o.describe() for o in kept[:10]))
        return out

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    def joint_offset_index(self, joint: int) -> int | None:
        """Index of joint `joint`'s (0-based) identified offset, whatever the model names it."""
        for k, p in enumerate(self.params):
            if p.kind == "zero" and p.joint == joint:
                return k
        return None

    def value(self, name: str) -> float:
        return float(self.values[self.names.index(name)])
