"""The residual model: what the physical model leaves of the measured point's position, learned
over joint space after identification, kept only when cross-validation says it pays.

    outcome = learn_residual(result, data, "auto")   # residual_stage, after identify()
    prediction = outcome.model.predict(q_rad)         # correction (M, 3) mm, std (M,) mm

This module holds the model and what crosses the result file; `residual_stage` learns it from
an identification, `residual_gp` does the numerics (predictions need numpy alone: compensating a
program loads no optimiser).

The physical model (geometry, compliance, lag) leaves a residual that, on a real robot, is no
longer noise but a smooth function of the joints (unmodelled gear and bearing errors, the
arm's bending beyond the compliance terms). A Gaussian process over sin/cos of the joints
(`residual_gp`; every joint, or all but joint 1 when the marginal likelihood prefers it:
`fit_residual_model`) learns it from the calibration poses the identification kept (outliers
out, lag corrected): training inputs are those joints, targets the measured minus the
predicted position in the measuring system's frame. Positions only: the orientation stays the
physical model's (a compensated target's orientation is not corrected).

Choice (`mode`): "none" skips it; "gp" keeps it; "auto" keeps it only when 5-fold
cross-validation on the calibration poses shows that the corrected positions beat the physical
model's by more than the spread of that gain over the folds (and by more than 1 % of the
physical residual): on data with nothing left to learn it declines. The folds use the
hyperparameters of all the poses (chosen by marginal likelihood, not by the folds' errors).

Uncertainty: the predictive standard deviation per Cartesian component, the latent variance
plus the noise level, scaled so that 95 % of the cross-validated errors, and of the errors of
the poses the identification set aside as outliers, fall in their 95 % band (chi-square with
three degrees of freedom): new poses include such poses too (measured on the tracker set's
read-back joints, 8 % outliers: 84.7 % held-out coverage without them, 92.3 % with). The scale
and the band's coverage before it are in the cross-validation figures. Reach: a configuration
farther from every calibration pose (in feature space) than `REACH_LENGTHS` length scales, or
than `REACH_GAPS` times the widest gap between a calibration pose and its nearest neighbour (a
long length scale must not carry a correction into joint space the calibration never visited),
gets no correction and a note, never an extrapolation.

The document (`to_dict`, `from_dict`): the training joints and residuals, the hyperparameters,
the cross-validation figures and `RESIDUAL_MODEL_VERSION`; the result file carries it as its
`residual_model` member (`residual_from_document` reads it; older results have none).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Literal

import numpy as np

from screwcal.calibration.residual_gp import (
    Hyperparameters,
    Posterior,
    fit_with_evidence,
    fold_predictions,
    joint_features,
    squared_distances,
)
from screwcal.errors import ModelError
from screwcal.kinematics.se3 import Array, Mask

ResidualMode = Literal["auto", "none", "gp"]
RESIDUAL_MODES: tuple[ResidualMode, ...] = ("auto", "none", "gp")
RESIDUAL_MODEL_FORMAT = "screwcal-residual-model"
RESIDUAL_MODEL_VERSION = 1
KERNEL = "squared exponential over sin and cos of the joint angles, one per Cartesian component"
FOLDS = 5
MIN_POSES = 30  # fewer calibration poses: no residual model (6 per fold at least)
MAX_POSES = 800  # more: trained on a seeded random subset of this many (cost grows as N^3)
MIN_GAIN_SHARE = 0.01  # auto: the gain must also pass 1 % of the physical residual
REACH_LENGTHS = 2.5  # farther from every calibration pose (in length scales): no correction
REACH_GAPS = 3.0  # ...or farther than this many times the calibration poses' widest gap
BAND = 0.95
BAND_CHI2 = 7.814727903251178  # chi2.ppf(0.95, 3): |error|^2 / std^2 within it, in the band
STD_SCALE_BOUNDS = (0.5, 4.0)


@dataclass(frozen=True)
class CrossValidation:
    """What k-fold cross-validation on the calibration poses showed."""

    folds: int
    poses: int
    physical_mean_mm: float  # mean position residual of the physical model on these poses
    corrected_mean_mm: float  # ... after the residual model's out-of-fold correction
    fold_gain_mm: tuple[float, ...]  # physical minus corrected mean, per fold
    coverage: float  # share of out-of-fold errors within their 95 % band, before std_scale
    std_scale: float  # the factor on the predictive std that makes that share 95 %

    @property
    def gain_mm(self) -> float:
        return float(np.mean(self.fold_gain_mm))

    @property
    def spread_mm(self) -> float:
        return float(np.std(self.fold_gain_mm, ddof=1))

    def beats_physical(self) -> bool:
        """The gain exceeds its spread over the folds and 1 % of the physical residual."""
        return self.gain_mm > max(self.spread_mm, MIN_GAIN_SHARE * self.physical_mean_mm)

    def describe(self) -> str:
        return (f"{self.folds}-fold cross-validation on {self.poses} poses: mean "
                f"{self.physical_mean_mm:.4f} -> {self.corrected_mean_mm:.4f} mm (gain "
                f"{self.gain_mm:.4f} +- {self.spread_mm:.4f} mm over the folds)")

    def to_dict(self) -> dict[str, Any]:
        return {"folds": self.folds, "poses": self.poses,
                "physical_mean_mm": self.physical_mean_mm,
                "corrected_mean_mm": self.corrected_mean_mm,
                "fold_gain_mm": list(self.fold_gain_mm), "gain_mm": self.gain_mm,
                "spread_mm": self.spread_mm, "coverage_95_before_scale": self.coverage,
                "std_scale": self.std_scale}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> CrossValidation:
        return cls(int(d["folds"]), int(d["poses"]), float(d["physical_mean_mm"]),
                   float(d["corrected_mean_mm"]), tuple(float(v) for v in d["fold_gain_mm"]),
                   float(d["coverage_95_before_scale"]), float(d["std_scale"]))


@dataclass(frozen=True)
class ResidualPrediction:
    """The residual model at some configurations."""

    correction_mm: Array  # (M, 3) to add to the physical model's position (zeros beyond reach)
    std_mm: Array  # (M,) predictive standard deviation per Cartesian component, 1 sigma
    nearest_lengths: Array  # (M,) distance to the nearest calibration pose, in length scales
    reach_lengths: float = REACH_LENGTHS

    @property
    def within_reach(self) -> Mask:
        return self.nearest_lengths <= self.reach_lengths

    def note(self, k: int) -> str:
        """Why configuration k got no correction, or ""."""
        if self.within_reach[k]:
            return ""
        return (f"beyond the residual model's reach ({self.nearest_lengths[k]:.1f} length "
                f"scales from every calibration pose, limit {self.reach_lengths:g}): no "
                "residual correction")

    def summary(self) -> str:
        """One line: the corrections' size, the uncertainty, the configurations beyond reach."""
        inside = self.within_reach
        size = np.linalg.norm(self.correction_mm, axis=1)
        text = (f"residual model: correction mean {size.mean():.4f} mm, max {size.max():.4f} "
                f"mm; predictive std (per component) mean {self.std_mm.mean():.4f} mm")
        if not inside.all():
            text += f"; {int((~inside).sum())} beyond its reach, not corrected"
        return text


def stacked_predictions(rows: list[tuple[int, ResidualPrediction]], n: int
                        ) -> ResidualPrediction:
    """Predictions of single configurations (index, prediction of one) as one for n of them:
    zeros where none was made (e.g. refused targets)."""
    index = [k for k, _ in rows]
    correction, std, nearest = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
    correction[index] = [p.correction_mm[0] for _, p in rows]
    std[index] = [p.std_mm[0] for _, p in rows]
    nearest[index] = [p.nearest_lengths[0] for _, p in rows]
    return ResidualPrediction(correction, std, nearest, rows[0][1].reach_lengths)


@dataclass(frozen=True)
class ResidualModel:
    """A trained residual model: predicts the position the physical model misses."""

    q_rad: Array  # (N, n) the calibration joints it was trained on
    residuals_mm: Array  # (N, 3) measured minus physical, measuring frame
    h: Hyperparameters
    cv: CrossValidation
    reach_lengths: float = REACH_LENGTHS
    trained: Posterior | None = field(default=None, repr=False, compare=False)  # when known
    joints: tuple[int, ...] | None = None  # the joints (0-based) whose angles enter; None: all

    def features(self, q_rad: Array) -> Array:
        """The kernel's features of joints q_rad (M, n)."""
        return _features(q_rad, self.joints)

    @cached_property
    def posterior(self) -> Posterior:
        if self.trained is not None:
            return self.trained
        return Posterior.train(self.features(self.q_rad), self.residuals_mm, self.h)

    @property
    def std_scale(self) -> float:
        return self.cv.std_scale

    def predict(self, q_rad: Array) -> ResidualPrediction:
        """The correction and its standard deviation at joints q_rad (M, n) (numeric units)."""
        q = np.atleast_2d(np.asarray(q_rad, float))
        if q.shape[1] != self.q_rad.shape[1]:
            raise ModelError(f"the residual model takes {self.q_rad.shape[1]} joints; got "
                             f"{q.shape[1]}")
        mean, latent, nearest = self.posterior.predict(self.features(q))
        beyond = nearest > self.reach_lengths
        mean[beyond] = 0.0  # no extrapolation: the physical model alone there
        latent[beyond] = self.h.signal_mm ** 2
        std = self.std_scale * np.sqrt(latent + self.h.noise_mm ** 2)
        return ResidualPrediction(mean, std, nearest, self.reach_lengths)

    def size_mm(self) -> dict[str, float]:
        """The correction's size over the calibration poses (what an export without it drops)."""
        size = np.linalg.norm(self.posterior.mean(self.posterior.X), axis=1)
        return {"mean": float(size.mean()), "rms": float(np.sqrt(np.mean(size ** 2))),
                "max": float(size.max())}

    def std_at_calibration_mm(self) -> float:
        """The predictive standard deviation (per component) averaged over the calibration
        poses."""
        return float(self.predict(self.q_rad).std_mm.mean())

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "gp", "kernel": KERNEL,
                "predicts": "the measured point's position minus the physical model's, "
                            "measuring frame, mm",
                "hyperparameters": {"length_scale": self.h.length,
                                    "signal_mm": self.h.signal_mm,
                                    "noise_mm": self.h.noise_mm},
                "joints": [j + 1 for j in (range(self.q_rad.shape[1]) if self.joints is None
                                           else self.joints)],
                "std_scale": self.std_scale, "reach_length_scales": self.reach_lengths,
                "size_over_calibration_poses_mm": self.size_mm(),
                "predictive_std_mm": {"per": "Cartesian component, 1 sigma",
                                      "mean_over_calibration_poses":
                                          self.std_at_calibration_mm()},
                "training": {"joints_deg": np.degrees(self.q_rad).tolist(),
                             "residuals_mm": self.residuals_mm.tolist()}}


@dataclass(frozen=True)
class ResidualOutcome:
    """What the residual stage decided: the model (when used), why, and the evidence."""

    mode: ResidualMode
    model: ResidualModel | None  # trained (None: not tried)
    used: bool
    note: str
    warnings: tuple[str, ...] = field(default_factory=tuple)

    @property
    def cv(self) -> CrossValidation | None:
        return None if self.model is None else self.model.cv

    def to_dict(self) -> dict[str, Any]:
        """The result file's `residual_model` member (the model itself only when used)."""
        out: dict[str, Any] = {"format": RESIDUAL_MODEL_FORMAT,
                               "version": RESIDUAL_MODEL_VERSION, "mode": self.mode,
                               "used": self.used, "note": self.note,
                               "cross_validation": None if self.cv is None else
                               self.cv.to_dict()}
        if self.used and self.model is not None:
            out |= self.model.to_dict()
        return out


def cross_validate(posterior: Posterior, Y: Array, folds: int = FOLDS, seed: int = 0,
                   X_out: Array | None = None, Y_out: Array | None = None) -> CrossValidation:
    """k-fold figures of a process trained on residuals Y (`posterior`, hyperparameters and
    all). The
    band's scale is set on the out-of-fold errors and on those of the poses the
    identification set aside as outliers (X_out, Y_out, predicted from all of X): a new pose
    may be one of those too, and the band is to hold for it."""
    X, h = posterior.X, posterior.h
    fold = np.random.default_rng(seed).permutation(len(X)) % folds
    mean, var = fold_predictions(posterior, Y, fold)
    physical = np.linalg.norm(Y, axis=1)
    corrected = np.linalg.norm(Y - mean, axis=1)
    gains = tuple(float(physical[fold == f].mean() - corrected[fold == f].mean())
                  for f in range(folds))
    z = corrected ** 2 / var
    coverage = float(np.mean(z <= BAND_CHI2))
    if X_out is not None and Y_out is not None and len(X_out):
        mean_out, latent, _ = posterior.predict(X_out)
        z = np.r_[z, np.sum((Y_out - mean_out) ** 2, axis=1) / (latent + h.noise_mm ** 2)]
    scale = float(np.clip(np.sqrt(np.quantile(z, BAND) / BAND_CHI2), *STD_SCALE_BOUNDS))
    return CrossValidation(folds, len(X), float(physical.mean()), float(corrected.mean()), gains,
                           coverage, scale)


def fit_residual_model(q_rad: Array, residuals_mm: Array, q_outliers: Array | None = None,
                       residuals_outliers: Array | None = None) -> ResidualModel:
    """A residual model trained on joints q_rad (N, n) and residuals (N, 3), with its
    cross-validation figures; the outliers' joints and residuals (set aside by the
    identification) widen its band where they must (`cross_validate`). The features are
    those of every joint, or of all but joint 1, whichever the marginal likelihood prefers:
    on an arm standing on the floor (or hanging from the ceiling) joint 1 turns about gravity,
    whose pull, behind most of what the physical model leaves, does not change with it."""
    q_rad = np.asarray(q_rad, float)
    candidates = [None] if q_rad.shape[1] < 2 else [None, tuple(range(1, q_rad.shape[1]))]
    fits = [(fit_with_evidence(_features(q_rad, c), residuals_mm), c) for c in candidates]
    (h, _), joints = min(fits, key=lambda f: f[0][1])
    X = _features(q_rad, joints)
    D2 = squared_distances(X, X)
    np.fill_diagonal(D2, np.inf)
    widest_gap = float(np.sqrt(D2.min(axis=1).max()))
    reach = min(REACH_LENGTHS, REACH_GAPS * widest_gap / h.length)
    X_out = None if q_outliers is None else _features(q_outliers, joints)
    posterior = Posterior.train(X, residuals_mm, h)
    cv = cross_validate(posterior, residuals_mm, X_out=X_out, Y_out=residuals_outliers)
    return ResidualModel(q_rad, np.asarray(residuals_mm, float), h, cv, reach, posterior,
                         joints)


def _features(q_rad: Array, joints: tuple[int, ...] | None) -> Array:
    return joint_features(q_rad if joints is None else q_rad[:, list(joints)])


def dropped_by_export(doc: object, form: str) -> str:
    """What an export of a result's robot (URDF, DH, MDH, a screw table) leaves out: its
    residual model, with the size of its correction over the calibration poses; "" when the
    result uses none."""
    member = doc.get("residual_model") if isinstance(doc, dict) else None
    if not isinstance(member, dict) or not member.get("used"):
        return ""
    size = member.get("size_over_calibration_poses_mm") or {}
    shown = ", ".join(f"{k} {float(v):.4f}" for k, v in size.items()
                      if k in ("mean", "rms", "max"))
    return (f"the {form} export carries the physical model only: the result's residual model "
            f"(its correction over the calibration poses: {shown} mm) is left out; predict and "
            "compensate with the result itself apply it")


def residual_from_document(doc: object, source: str = "result") -> ResidualModel | None:
    """The residual model a result document carries and uses; None for a result without one
    (older results, `none`, or declined by `auto`)."""
    member = doc.get("residual_model") if isinstance(doc, dict) else None
    if not isinstance(member, dict) or not member.get("used"):
        return None
    version = member.get("version")
    if member.get("format") != RESIDUAL_MODEL_FORMAT or not isinstance(version, int) or \
            version > RESIDUAL_MODEL_VERSION:
        raise ModelError(f"{source}: residual_model is not a {RESIDUAL_MODEL_FORMAT} of version "
                         f"<= {RESIDUAL_MODEL_VERSION} (got {member.get('format')!r}, version "
                         f"{version!r}): a newer screwcal wrote it")
    try:
        hp, training = member["hyperparameters"], member["training"]
        q = np.radians(np.asarray(training["joints_deg"], float))
        residuals = np.asarray(training["residuals_mm"], float)
        h = Hyperparameters(float(hp["length_scale"]), float(hp["signal_mm"]),
                            float(hp["noise_mm"]))
        cv = CrossValidation.from_dict(member["cross_validation"])
        reach = float(member["reach_length_scales"])
        used = member.get("joints")  # every joint when absent
        joints = None if used is None else tuple(int(j) - 1 for j in used)
    except (KeyError, TypeError, ValueError) as err:
        raise ModelError(f"{source}: residual_model is incomplete or malformed ({err!r})"
                         ) from None
    if q.ndim != 2 or residuals.shape != (len(q), 3) or not np.isfinite(q).all() or \
            not np.isfinite(residuals).all() or min(h.length, h.signal_mm, h.noise_mm) <= 0 or \
            (joints is not None and not all(0 <= j < q.shape[1] for j in joints)):
        raise ModelError(f"{source}: residual_model's training data or hyperparameters are "
                         "not valid (joints (N, n), residuals (N, 3), positive "
                         "hyperparameters, joints numbered 1..n)")
    return ResidualModel(q, residuals, h, cv, reach, joints=joints)
