"""Parameter identification (thesis 2.2.3, Eq. 2.4): Levenberg-Marquardt and Differential
Evolution on an error model, with an honest account of what the data can tell.

Residuals per pose, model minus measured: position (mm), then for full-pose data the rotation
vector of R_model R_meas^T; or, for "distance" data (thesis Appendix D), the differences of all
pairwise distances between measured points, which need no base alignment.

Weighting:
- "statistical" (default): each pose's residual is whitened by its covariance, the measuring
  noise plus the random joint error carried through the joint Jacobian,
  S_i = s_m^2 I + J_q,i S_q J_q,i^T (uniform +-a joint error: s_q = a / sqrt 3). Standard errors
  then come from (J^T J)^-1 of the whitened Jacobian: the Cramer-Rao bound of this noise model.
- "eq2.4": the thesis's objective, (1/W^2) sum |e_pos|^2 + sum |e_rot|^2, with the rotation
  errors in degrees (the thesis gives no unit; in degrees W = 1 mm/deg balances the two, which is
  what its Figs. 20-21 found best). Standard errors are scaled by the residual variance.

Noise levels (variance components): unless a level is fixed, the measuring noise (position, and
orientation when measured) and the joint noise are estimated with the parameters by Förstner's
iteration: with S_i = sum_k theta_k V_k,i, the whitened fit gives residuals e; each component's
share of the redundancy r_k = tr(W theta_k V_k) - tr(N^-1 A^T W theta_k V_k W A) and of the
squared residual Omega_k = e^T W theta_k V_k W e update theta_k <- theta_k Omega_k / r_k until
they agree (Förstner 1979; Koch, Parameter Estimation and Hypothesis Testing, 1999, 3.6). The
result reports the levels with their standard deviations (theta_k sqrt(2 / r_k)); the final fit's
chi2/dof is then 1 by construction and the standard errors are honest. With every level fixed,
the standard errors are scaled by chi2/dof when it exceeds 1 (the noise was understated).

Identifiability: the weighted Jacobian of every candidate parameter at the start is factorised
by QR with column pivoting (frames and the model's preferred parameters first); the parameters
outside the numerical rank are held at their starting value and reported with the kept
parameters they cannot be told from. Nothing is "solved" that the data cannot determine.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import scipy.linalg
from scipy.optimize import differential_evolution, least_squares
from scipy.special import fdtrc

from screwcal.calibration.blas_threads import one_blas_thread
from screwcal.calibration.degenerate import (
    NEAR_AXIS_MM,
    data_warnings,
    point_axis_distance_mm,
)
from screwcal.calibration.diagnostics import (
    MAX_OUTLIER_FRACTION,
    acquisition_order,
    data_quality,
    loo_position_error,
    pose_tests,
)
from screwcal.calibration.error_parameters import (
    ErrorModel,
    ModelKind,
    Param,
    candidate_params,
    forward_batch,
)
from screwcal.calibration.identifiability import (
    Residual,
    explain_removed,
    pairs,
    select_identifiable,
    structural_rank,
    svd,
)
from screwcal.calibration.initial_frames import align_frames
from screwcal.calibration.lag import correct_lag, lag_increment
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.plausible import (
    PlausibleRanges,
    held_directions,
    outside_ranges,
    prior_sigma,
)
from screwcal.errors import IdentificationError
from screwcal.instrument import JOINT_ERROR_DEG, ORIENTATION_NOISE_DEG, POSITION_NOISE_MM
from screwcal.kinematics.forward import forward_kinematics, point_jacobian, spatial_jacobian
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, rotvec_from_rotation

Frames = Literal["unknown", "known", "base"]  # base: only the measuring frame is unknown
LAG_ROUNDS = 4  # estimate-correct-refit rounds of lag="auto", while the residual falls
COMPLIANCE_T = 5.0  # |value| / std error above which "auto" keeps a joint compliance
FREE_MIN_POSES = 200  # enough poses to let auto try a compliance per joint and arm mass
FREE_P = 0.001  # ...and keep it when the residual's drop is this unlikely by chance
DEFAULT_RANGES = PlausibleRanges()
PRIOR_NOISE = (POSITION_NOISE_MM, ORIENTATION_NOISE_DEG, JOINT_ERROR_DEG)  # screwcal/instrument.py


@dataclass(frozen=True)
class NoiseModel:
    """Noise levels: measuring system (mm, 1 sigma), flange-derived orientation (deg, 1 sigma),
    random joint error (deg, uniform +-). A level left None is estimated from the data,
    starting from PRIOR_NOISE (the FARO arm's 0.013 mm, holes 50 mm apart, the thesis's
    +-0.05 deg)."""

    position_mm: float | None = None
    orientation_deg: float | None = None
    joint_deg: float | None = None

    @property
    def free(self) -> tuple[bool, bool, bool]:
        return (self.position_mm is None, self.orientation_deg is None, self.joint_deg is None)

    def filled(self) -> tuple[float, float, float]:
        """The levels, the priors where free."""
        return tuple(PRIOR_NOISE[k] if v is None else float(v)  # type: ignore[return-value]
                     for k, v in enumerate((self.position_mm, self.orientation_deg,
                                            self.joint_deg)))


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

    def to_dict(self) -> dict:
        out = {}
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

    def to_dict(self) -> dict:
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
    residual_kind: str
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
    diagnostics: dict = field(default_factory=dict)  # data_quality(): lag, drift, leverage, fit
    compliance: str = "none"  # the joint compliance identified: none, j23, j23-free, wrist
    compliance_note: str = ""  # why (compliance="auto")
    unabsorbed: dict[str, float] = field(default_factory=dict)  # compliance: see _unabsorbed
    reading_lag: Array | None = None  # (n,) per joint, when lag="auto" corrected the readings
    lag_note: str = ""
    data_warnings: tuple[str, ...] = ()  # degenerate data, named before the fit
    held_by_prior: tuple[str, ...] = ()  # directions the data left to the prior (nominal)
    implausible: tuple[str, ...] = ()  # parameters beyond their plausible range
    orientation_unknown: str = ""  # why the model predicts positions, not the orientation

    @property
    def warnings(self) -> list[str]:
        """What the user must read: data-quality findings and the poses left out."""
        out = list(self.data_warnings)
        out += [d["warning"] for d in self.diagnostics.values() if d.get("warning")]
        if self.implausible:
            out.append("implausible parameters (check the data, the set-up and the nominal "
                       "model before using this one): " + "; ".join(self.implausible))
        if self.orientation_unknown:
            out.append(f"position-only model: {self.orientation_unknown}; compensate refuses "
                       "targets with an orientation")
        rejected = [o for o in self.outliers if o.rejected]
        if rejected:
            out.append(f"{len(rejected)} poses rejected as outliers: " + ", ".join(
                o.describe() for o in rejected[:10]))
        kept = [o for o in self.outliers if not o.rejected]
        if kept:
            out.append(f"{len(kept)} poses look like outliers but were kept: " + ", ".join(
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


# ----------------------------------------------------------------------------------------------
# Residuals

def _theta(levels: tuple[float, float, float]) -> Array:
    """Variance components (mm^2, rad^2, rad^2) of the levels (mm, deg, uniform +- deg)."""
    p, o, j = levels
    return np.array([p**2, np.radians(o) ** 2, (np.radians(j) / np.sqrt(3.0)) ** 2])


def _levels(theta: Array) -> Array:
    """The inverse of _theta: (mm, deg, uniform +- deg)."""
    p, o, j = np.sqrt(np.maximum(theta, 0.0))
    return np.array([p, np.degrees(o), np.degrees(j) * np.sqrt(3.0)])


def _whitening(cov: Array) -> Array:
    """W_i with W_i^T W_i = cov_i^-1, per pose (N, k, k)."""
    return np.linalg.inv(np.linalg.cholesky(cov))


def _prior_weights(errors: ErrorModel, ranges: PlausibleRanges | None) -> Array:
    """1 / sigma of the prior per parameter (numeric units); zeros without one."""
    if ranges is None:
        return np.zeros(len(errors.params))
    return 1.0 / prior_sigma(errors.params, ranges)


class _Problem:
    """Residuals and Jacobian of one identification, pure functions of x."""

    def __init__(self, errors: ErrorModel, data: MeasurementSet, residual: Residual,
                 weighting: str, weight_mm: float, noise: NoiseModel,
                 weights_at: Array | None = None, ranges: PlausibleRanges | None = None):
        self.errors = errors
        self.data = data
        self.residual = residual
        self.rows = 6 if residual == "pose" else 3
        at = np.zeros(len(errors.params)) if weights_at is None else weights_at
        self._whiten = self._weights(weighting, weight_mm, noise, at)
        self._last: tuple[bytes, tuple[Array, Array]] | None = None
        self.ranges = ranges
        self.prior = _prior_weights(errors, ranges)

    def posterior(self, x: Array) -> tuple[Array, Array]:
        """The weighted residuals and Jacobian with the prior's rows (plausible.py) below:
        what the solvers minimise."""
        r, J = self.weighted(x)
        return np.concatenate([r, self.prior * x]), np.vstack([J, np.diag(self.prior)])

    def posterior_residuals(self, x: Array) -> Array:
        return np.concatenate([self.residuals(x), self.prior * x])

    def restricted(self, errors: ErrorModel) -> _Problem:
        """The same data and weights (taken at the same starting model) for a subset of the
        parameters: the weights depend on the model at the start, not on which are free."""
        out = object.__new__(_Problem)
        out.errors, out.data, out.residual, out.rows = errors, self.data, self.residual, self.rows
        out._whiten, out._last = self._whiten, None
        out.ranges, out.prior = self.ranges, _prior_weights(errors, self.ranges)
        return out

    def with_whitening(self, whiten: Array) -> _Problem:
        """The same problem with other whitening matrices (N, k, k)."""
        out = self.restricted(self.errors)
        out._whiten = whiten
        return out

    def joint_jacobian(self, at: Array) -> Array:
        """The residuals' Jacobian w.r.t. the joints (N, k, n) at x = `at`."""
        model = self.errors.apply(at)
        T = forward_kinematics(model, self.data.q)
        return point_jacobian(spatial_jacobian(model, self.data.q), T)[:, :self.rows, :]

    def components(self, at: Array) -> Array:
        """The unit covariance components V_k (3, N, k, k) at x = `at`: position rows (mm^2),
        orientation rows (rad^2), and the joints' through the joint Jacobian (per rad^2)."""
        k = self.rows
        Jq = self.joint_jacobian(at)
        V = np.zeros((3, len(self.data), k, k))
        V[0, :, range(3), range(3)] = 1.0
        if k == 6:
            V[1, :, range(3, 6), range(3, 6)] = 1.0
        V[2] = np.einsum("nij,nkj->nik", Jq, Jq)
        return V

    def _weights(self, weighting: str, weight_mm: float, noise: NoiseModel, at: Array) -> Array:
        """Per-pose whitening matrices (N, k, k), or per-pair weights (P,) for distances; the
        joint-noise part is carried through the joint Jacobian of the model at x = `at`."""
        data, k = self.data, self.rows
        N = len(data)
        if weighting == "eq2.4":
            w = np.r_[np.full(3, 1.0 / weight_mm), np.full(3, 180.0 / np.pi)][:k]
            W = np.broadcast_to(np.diag(w), (N, k, k)).copy()
            return W if self.residual != "distance" else np.full(len(pairs(N)[0]), w[0])
        cov = np.einsum("k,knij->nij", _theta(noise.filled()), self.components(at))
        if self.residual == "distance":
            i, j = pairs(N)
            u = data.positions_mm[i] - data.positions_mm[j]
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            var = np.einsum("pi,pij,pj->p", u, cov[i] + cov[j], u)
            return 1.0 / np.sqrt(var)
        return _whitening(cov)

    def raw(self, x: Array, jacobian: bool = True) -> tuple[Array, Array | None]:
        """Unweighted residuals (N, k) or (P,) and, if asked, their Jacobian (N, k, p) or
        (P, p)."""
        if jacobian:
            T, Js = self.errors.jacobian(x, self.data.q)
            J = point_jacobian(Js, T)
        else:
            T, J = forward_kinematics(self.errors.apply(x), self.data.q), None
        dp = T[:, :3, 3] - self.data.positions_mm
        if self.residual == "distance":
            i, j = pairs(len(self.data))
            d_model = T[i, :3, 3] - T[j, :3, 3]
            d_meas = self.data.positions_mm[i] - self.data.positions_mm[j]
            n_model = np.linalg.norm(d_model, axis=1)
            r = n_model - np.linalg.norm(d_meas, axis=1)
            if J is None:
                return r, None
            u = d_model / n_model[:, None]
            return r, np.einsum("pi,pij->pj", u, J[i, :3] - J[j, :3])
        if self.residual == "position":
            return dp, None if J is None else J[:, :3]
        dR = T[:, :3, :3] @ np.swapaxes(self.data.rotations, 1, 2)
        return np.concatenate([dp, rotvec_from_rotation(dR)], axis=1), J
        # (d rotvec / d omega is the identity to first order: the residual rotations are small)

    def residuals(self, x: Array) -> Array:
        """Weighted residuals alone (no Jacobian: most LM evaluations only need these)."""
        if self._last is not None and self._last[0] == x.tobytes():
            return self._last[1][0]
        r, _ = self.raw(x, jacobian=False)
        return self._apply_weights(r)

    def weighted(self, x: Array) -> tuple[Array, Array]:
        """Weighted residuals and Jacobian; the last evaluation is kept, since least_squares
        asks for the residuals and the Jacobian at the same x one after the other."""
        key = x.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        r, J = self.raw(x)
        assert J is not None
        if self.residual == "distance":
            out = (r * self._whiten, J * self._whiten[:, None])
        else:
            out = (self._apply_weights(r),
                   np.einsum("nij,njp->nip", self._whiten, J).reshape(-1, J.shape[-1]))
        self._last = (key, out)
        return out

    def _apply_weights(self, r: Array) -> Array:
        if self.residual == "distance":
            return r * self._whiten
        return np.einsum("nij,nj->ni", self._whiten, r).reshape(-1)

    def cost(self, x: Array) -> float:
        r = self.residuals(x)
        return float(r @ r)

    def cost_batch(self, X: Array) -> Array:
        """Weighted sum of squares for a population X (p, S) (scipy's vectorized layout)."""
        T = forward_batch(self.errors, X.T, self.data.q)  # (S, N, 4, 4)
        if self.residual == "distance":
            i, j = pairs(len(self.data))
            P = T[:, :, :3, 3]  # (S, N, 3); indexing T[:, i, :3, 3] would put the pairs first
            d_model = np.linalg.norm(P[:, i] - P[:, j], axis=2)
            d_meas = np.linalg.norm(self.data.positions_mm[i] - self.data.positions_mm[j], axis=1)
            r = (d_model - d_meas) * self._whiten
            return np.sum(r**2, axis=1) + np.sum((self.prior[:, None] * X) ** 2, axis=0)
        r = T[:, :, :3, 3] - self.data.positions_mm
        if self.residual == "pose":
            dR = T[:, :, :3, :3] @ np.swapaxes(self.data.rotations, 1, 2)
            rot = rotvec_from_rotation(dR)
            r = np.concatenate([r, rot], axis=2)
        rw = np.einsum("nij,snj->sni", self._whiten, r)
        return np.sum(rw**2, axis=(1, 2)) + np.sum((self.prior[:, None] * X) ** 2, axis=0)


def identify(nominal: SerialModel, data: MeasurementSet, *, kind: ModelKind = "full",
             residual: Residual | None = None, frames: Frames = "unknown",
             solver: Literal["lm", "de"] = "lm", weighting: str = "statistical",
             weight_mm: float = 1.0, noise: NoiseModel | None = None,
             de_link_bounds_mm: tuple[float, float] = (0.0, 1.0), seed: int = 0,
             base_guess: Array | None = None,
             link_offsets: Sequence[str] | None = None,
             outliers: Literal["reject", "keep"] = "reject",
             de_polish: bool = True, compliance: str = "none",
             lag: Literal["none", "auto"] = "none",
             plausible: PlausibleRanges | None = DEFAULT_RANGES) -> CalibrationResult:
    """Identify the error model `kind` of `nominal` from measured data. With unknown frames,
    `base_guess` (e.g. from `base_alignment.base_from_sweeps`) starts the base there. With
    `solver="de"`, `de_polish=False` returns differential evolution's own best (the thesis's
    DE, for comparison); by default a bounded least-squares polish refines it. `compliance`
    ("none", "j23", "wrist") identifies the joints' compliance under gravity with the geometry
    (`error_parameters.compliance_params`); "auto" fits the joint-2/3 compliance and keeps it when
    the data support it (a coefficient beyond `COMPLIANCE_T` standard errors), else fits
    without; with at least `FREE_MIN_POSES` poses it then tries a coefficient per joint and
    arm mass ("j23-free": the data correct the mass table's proportions) and keeps it when an
    F-test on the residual says so (p < `FREE_P`); the result says which and why
    (`compliance_note`). `lag="auto"`: when the diagnostics find joint readings that lag the
    motion and the data know each pose's previous readings, the lag per joint is estimated
    from the residuals and the readings corrected, in a few rounds while the residual falls
    (`reading_lag`, `lag_note`; `screwcal.calibration.lag`).

    Poses whose residual says they do not belong (data snooping, `diagnostics.pose_tests`) are
    rejected, the worst first, and the fit repeated (`outliers="keep"`: listed, kept); at most
    a tenth of the poses. The result lists them and the data-quality
    diagnostics.

    `plausible`: every parameter carries a weak zero-mean prior scaled by its plausible range
    (`screwcal.calibration.plausible`): among models that fit equally, the one nearest nominal;
    the result names the directions the prior decided (`held_by_prior`) and warns of any
    parameter beyond its range. None: plain least squares."""
    common = dict(kind=kind, residual=residual, frames=frames, solver=solver,
                  weighting=weighting, weight_mm=weight_mm, noise=noise,
                  de_link_bounds_mm=de_link_bounds_mm, seed=seed, base_guess=base_guess,
                  link_offsets=link_offsets, outliers=outliers, de_polish=de_polish,
                  ranges=plausible)
    with one_blas_thread():  # small dense problems: threads only compete (blas_threads)
        return _with_lag(nominal, data, compliance=compliance, lag=lag, common=common)


def _with_lag(nominal: SerialModel, data: MeasurementSet, *, compliance: str,
              lag: Literal["none", "auto"], common: dict) -> CalibrationResult:
    """One identification, then (`lag="auto"`) the readings' lag estimated and corrected."""
    result = _with_compliance(nominal, data, compliance=compliance, **common)
    if lag == "none":
        return result
    flagged = [d["joint"] for d in result.diagnostics.get("lag", {}).get("per_joint", [])
               if d["flagged"]]
    if data.q_previous is None or not flagged:
        return replace(result, lag_note="not corrected: " + (
            "the data do not say which pose came before which" if data.q_previous is None
            else "the readings do not lag the motion"))
    chosen = result.compliance if compliance == "auto" else compliance
    best, lam = result, np.zeros(nominal.n_joints)
    for _ in range(LAG_ROUNDS):
        trial_lag = lam + lag_increment(best.model, correct_lag(data, lam))
        trial = _with_compliance(nominal, correct_lag(data, trial_lag), compliance=chosen,
                                 **common)
        if trial.residuals_after.mean() >= best.residuals_after.mean():
            break
        best, lam = trial, trial_lag
    shown = ", ".join(f"J{j + 1} {v:.2e}" for j, v in enumerate(lam))
    return replace(best, reading_lag=lam, lag_note=(
        f"corrected: the readings lagged the motion (flagged joints {flagged}); lag per joint "
        f"(share of the previous move still in the reading): {shown}; residual mean "
        f"{result.residuals_after.mean():.3f} -> {best.residuals_after.mean():.3f} mm. Better: "
        "wait for the arm to settle, or calibrate with the commanded joints"))


def _with_compliance(nominal: SerialModel, data: MeasurementSet, *, compliance: str,
                     **common: object) -> CalibrationResult:
    """One identification with `compliance` ("auto": chosen by the data)."""
    kind = common["kind"]
    solver = common["solver"]
    if compliance != "auto":
        result = _identify_rejecting(nominal, data, compliance=compliance,
                                     **common)  # type: ignore[arg-type]
        return replace(result, compliance=compliance)
    why = ""
    if kind in ("frames",) or solver != "lm" or not nominal.all_masses:
        why = ("not tried: " + ("no masses load the joints (a built-in robot's table or a "
                                "payload)" if not nominal.all_masses else
                                "the frames-only model" if kind == "frames" else
                                "the population solver"))
    else:
        bent = _with_compliance(nominal, data, compliance="j23", **common)
        t = {p.name: abs(v) / s for p, v, s in zip(bent.params, bent.values, bent.std_errors,
                                                    strict=True)
             if p.kind.startswith("compliance") and s > 0}
        shown = ", ".join(f"{n} {v:.1f}" for n, v in t.items()) or "none identifiable"
        if t and max(t.values()) > COMPLIANCE_T:
            note = (f"chosen (auto): the data support it, |value| / std error: {shown} (> "
                    f"{COMPLIANCE_T:g})")
            if len(data) < FREE_MIN_POSES:
                return replace(bent, compliance="j23", compliance_note=note)
            free = _with_compliance(nominal, data, compliance="j23-free", **common)
            p_value = _nested_f_test(bent, free)
            if p_value < FREE_P:
                return replace(free, compliance="j23-free", compliance_note=(
                    f"{note}; with a coefficient per joint and arm mass (the data correct the "
                    f"mass table's proportions: F-test p = {p_value:.2g} < {FREE_P:g}, "
                    f"{len(data)} poses)"))
            return replace(bent, compliance="j23", compliance_note=(
                f"{note}; per-mass coefficients add nothing significant (F-test p = "
                f"{p_value:.2g})"))
        why = f"left out (auto): the data do not support it, |value| / std error: {shown}"
    plain = _with_compliance(nominal, data, compliance="none", **common)
    return replace(plain, compliance="none", compliance_note=why)


def _nested_f_test(simple: CalibrationResult, rich: CalibrationResult) -> float:
    """p-value of the richer model's drop in the position residual sum of squares (F-test of
    nested least-squares models, on the poses both kept)."""
    m = 3 * min(len(simple.residuals_after), len(rich.residuals_after))
    rss_a = float(np.sum(simple.residuals_after ** 2))
    rss_b = float(np.sum(rich.residuals_after ** 2))
    extra = max(rich.rank - simple.rank, 1)
    dof = max(m - rich.rank, 1)
    if rss_b <= 0 or rss_a <= rss_b:
        return 1.0
    return float(fdtrc(extra, dof, (rss_a - rss_b) / extra / (rss_b / dof)))


def _identify_rejecting(nominal: SerialModel, data: MeasurementSet, *, kind: ModelKind,
                        residual: Residual | None, frames: Frames,
                        solver: Literal["lm", "de"], weighting: str, weight_mm: float,
                        noise: NoiseModel | None, de_link_bounds_mm: tuple[float, float],
                        seed: int, base_guess: Array | None,
                        link_offsets: Sequence[str] | None,
                        outliers: Literal["reject", "keep"], de_polish: bool,
                        compliance: str, ranges: PlausibleRanges | None) -> CalibrationResult:
    """One identification (see `identify`), rejecting outliers."""
    started = time.perf_counter()
    settings = dict(kind=kind, residual=residual, frames=frames, solver=solver,
                    weighting=weighting, weight_mm=weight_mm, noise=noise,
                    de_link_bounds_mm=de_link_bounds_mm, seed=seed, base_guess=base_guess,
                    link_offsets=link_offsets, de_polish=de_polish, compliance=compliance,
                    ranges=ranges)
    found: list[Outlier] = []
    current = data
    limit = max(1, int(MAX_OUTLIER_FRACTION * len(data)))
    while True:
        result, problem, x = _identify_once(nominal, current, **settings)  # type: ignore[arg-type]
        if result.residual_kind == "distance" or weighting != "statistical":
            return replace(result, outliers=tuple(found), seconds=time.perf_counter() - started)
        e, A = problem.raw(x)
        assert A is not None
        test = pose_tests(e, A, problem._whiten)
        limit_T = test.threshold()
        worst = float(test.statistic.max())
        if worst <= limit_T or outliers == "keep" or len(found) >= limit:
            break
        # The clearly worst first (within half of the worst statistic, above the limit): one
        # at a time would be a refit per outlier, and a gross one masks the others anyway.
        drop = np.flatnonzero((test.statistic > limit_T) & (test.statistic >= 0.5 * worst))
        drop = drop[np.argsort(-test.statistic[drop])][:limit - len(found)]
        found += [Outlier(current.ids[k], current.line_of(k), float(np.linalg.norm(e[k, :3])),
                          float(test.statistic[k]), limit_T, rejected=True) for k in drop]
        current = current.take(np.setdiff1d(np.arange(len(current)), drop))
    kept = [Outlier(current.ids[k], current.line_of(k), float(np.linalg.norm(e[k, :3])),
                    float(test.statistic[k]), limit_T, rejected=False)
            for k in np.flatnonzero(test.statistic > limit_T)]
    stated = PRIOR_NOISE[0] if noise is None or noise.position_mm is None else noise.position_mm
    quality = data_quality(e, problem.joint_jacobian(x), np.degrees(current.q), test,
                           current.ids, None if result.noise is None or
                           result.noise.position_std_mm is None else result.noise.position_mm,
                           stated, acquisition_order(current.ids, current.lines))
    return replace(result, outliers=tuple(found + kept), diagnostics=quality,
                   seconds=time.perf_counter() - started)


def _identify_once(nominal: SerialModel, data: MeasurementSet, *, kind: ModelKind,
                   residual: Residual | None, frames: Frames, solver: Literal["lm", "de"],
                   weighting: str, weight_mm: float, noise: NoiseModel | None,
                   de_link_bounds_mm: tuple[float, float], seed: int,
                   base_guess: Array | None, link_offsets: Sequence[str] | None,
                   de_polish: bool = True, compliance: str = "none",
                   ranges: PlausibleRanges | None = None
                   ) -> tuple[CalibrationResult, _Problem, Array]:
    """One fit of all the poses given: the result, the final problem and its estimate."""
    started = time.perf_counter()
    noise = noise or NoiseModel()
    residual = residual or ("pose" if data.full_pose else "position")
    if residual == "pose" and not data.full_pose:
        raise IdentificationError("pose residuals need orientations: the data are positions only")
    if weighting not in ("statistical", "eq2.4"):
        raise IdentificationError(f"weighting is 'statistical' or 'eq2.4', not '{weighting}'")
    start = nominal
    if frames != "known":
        base, tool = align_frames(nominal, data.q, data.positions_mm,
                                  data.rotations if residual == "pose" else None,
                                  base=base_guess, fit_tool=frames == "unknown")
        start = nominal.with_frames(base, tool)
    unknown = frames == "unknown"
    cands = candidate_params(start, kind, base=frames != "known" and residual != "distance",
                             tool_rotation=unknown and residual == "pose",
                             tool_position=unknown, link_offsets=link_offsets,
                             compliance=compliance)
    errors_all = ErrorModel(start, tuple(cands))
    problem_all = _Problem(errors_all, data, residual, weighting, weight_mm, noise,
                           ranges=ranges)
    r0, J0 = problem_all.weighted(np.zeros(len(cands)))
    # The frames are unknown whatever the robot: take them first, then the model's own
    # parameters (joint and link offsets: what a controller can correct), then axis terms.
    priority = np.array([2 if p.group != "robot" else 1 if p.kind in ("zero", "link") else 0
                         for p in cands])
    needed = structural_rank(errors_all, residual)
    m = len(r0)
    if m <= needed:
        per_pose = {"pose": 6, "position": 3}.get(residual)
        more = f" (at least {needed // per_pose + 1} poses)" if per_pose else ""
        raise IdentificationError(f"{len(data)} poses give {m} equations for the {needed} "
                                  f"parameters this model can identify: measure more poses{more}")
    names = [p.name for p in cands]
    keep, rank, norms, combos = select_identifiable(J0, priority, names)
    removed_idx = np.setdiff1d(np.arange(len(cands)), keep)
    removed = explain_removed(J0, keep, removed_idx, names, norms)
    # Degenerate: the poses separate fewer parameters than well-spread data would, or (for
    # the thesis and joint models) a requested offset cannot be identified at all.
    requested_robot = [k for k, p in enumerate(cands) if p.group == "robot"]
    degenerate = rank < needed or (kind != "full" and any(k in removed_idx
                                                          for k in requested_robot))

    notes = data_warnings(start, data, residual, m, rank, [n for n, _ in removed])
    errors = errors_all.subset(keep)
    problem = problem_all.restricted(errors)
    p = len(keep)
    x0 = np.zeros(p)

    def lm(problem: _Problem, x_start: Array, tol: float = 1e-12
           ) -> tuple[Array, bool, str, int]:
        sol = least_squares(problem.posterior_residuals, x_start,
                            jac=lambda x: problem.posterior(x)[1], method="lm", x_scale="jac",
                            xtol=tol, ftol=tol, gtol=tol, max_nfev=200 * (p + 1))
        return sol.x, bool(sol.status > 0), str(sol.message), int(sol.nfev)

    statistical = weighting == "statistical"
    # a level to estimate that these data measure (positions carry no orientation noise)
    estimate_noise = statistical and residual != "distance" and any(
        free for k, free in enumerate(noise.free) if residual == "pose" or k != 1)
    reweighted = False
    if solver == "lm":
        # The candidate Jacobian at the start gives one Gauss-Newton step for free; with
        # statistical weights, take the weights there (the joint noise is very directional:
        # weights at the starting model mis-shape it by the size of the errors being
        # identified) and solve once. If that step does not lower the cost, solve from the
        # start and re-weight afterwards.
        prior0 = problem.prior
        x_gn = -np.linalg.lstsq(np.vstack([J0[:, keep], np.diag(prior0)]),
                                np.r_[r0, np.zeros(p)], rcond=None)[0]
        if estimate_noise:  # the noise levels' own loop re-weights and solves from there
            x, converged, message, nfev = x_gn, True, "", 0
            reweighted = True
        elif statistical and problem.cost(x_gn) < float(r0 @ r0):
            problem = _Problem(errors, data, residual, weighting, weight_mm, noise,
                               weights_at=x_gn, ranges=ranges)
            x, converged, message, nfev = lm(problem, x_gn)
            reweighted = True
        else:
            x, converged, message, nfev = lm(problem, x0, 1e-6 if statistical else 1e-12)
    else:
        # DE searches the robot's parameters within the thesis's bounds, the frames held at
        # their starting alignment (the thesis's DE had an aligned base); a bounded
        # trust-region polish then refines everything together.
        bounds = _de_bounds(errors, de_link_bounds_mm)
        robot = np.array([q.group == "robot" for q in errors.params])
        searched = robot if robot.any() else np.ones(p, bool)

        def cost_robot(X: Array) -> Array:
            full = np.zeros((p, X.shape[1]))
            full[searched] = X
            return problem.cost_batch(full)

        de = differential_evolution(cost_robot, [b for b, s in zip(bounds, searched,
                                                                   strict=True) if s],
                                    seed=seed, tol=1e-7, atol=0, maxiter=1000, popsize=15,
                                    polish=False, init="sobol", vectorized=True,
                                    updating="deferred")
        start_x = np.zeros(p)
        start_x[searched] = de.x
        if de_polish:
            polish = least_squares(problem.posterior_residuals, start_x,
                                   jac=lambda x: problem.posterior(x)[1], method="trf",
                                   x_scale="jac", bounds=tuple(zip(*bounds, strict=True)),
                                   xtol=1e-12, ftol=1e-12)
            x, converged = polish.x, bool(de.success or polish.status > 0)
            message = f"DE: {de.message}; polished: {polish.message}"
            nfev = int(de.nfev + polish.nfev)
        else:
            x, converged, message, nfev = start_x, bool(de.success), f"DE: {de.message}", \
                int(de.nfev)
    noise_used = None
    if estimate_noise:
        # Re-weighted at every estimate while the noise levels are found (variance components).
        def solve(pr: _Problem, x_start: Array) -> tuple[Array, bool, str, int]:
            return lm(pr, x_start, 1e-10)

        problem, x, noise_used, nfev_vce, (converged, message) = _estimate_noise(
            problem, noise, x, solve)
        nfev += nfev_vce
        if noise.joint_deg is None and noise_used.joint_deg > 0.0:
            # Is the joint component noise, or what the model misses (compliance, lag) soaked
            # up, down-weighting the far poses that show the geometry? Keep the weighting that
            # predicts left-out poses better (PRESS, from this one linearisation).
            e, A = problem.raw(x)
            assert A is not None
            V = problem.components(x)
            theta = _theta((noise_used.position_mm, noise_used.orientation_deg
                            if problem.rows == 6 else 0.0, 0.0))
            without = loo_position_error(e, A, _whitening(np.einsum("k,knij->nij", theta, V)))
            with_joint = loo_position_error(e, A, problem._whiten)
            if without < (1.0 - PRESS_MARGIN) * with_joint:
                problem, x, noise_used, nfev_vce, (converged, message) = _estimate_noise(
                    problem, replace(noise, joint_deg=0.0), x, solve)
                nfev += nfev_vce
                noise_used = replace(noise_used, note=(
                    f"joint noise left out: it predicted left-out poses worse "
                    f"({with_joint:.3f} vs {without:.3f} mm, leave-one-out): what it soaked up "
                    "is model error, not noise"))
        if not noise_used.converged:
            message += "; noise levels did not settle (see noise)"
    elif statistical and not reweighted:
        # Re-weight at the estimate and solve again (iteratively re-weighted GLS; one pass is
        # enough, the weights' own error is then second order).
        problem = _Problem(errors, data, residual, weighting, weight_mm, noise, weights_at=x,
                           ranges=ranges)
        x, converged_again, message_again, nfev_again = lm(problem, x)
        converged = converged and converged_again
        message, nfev = f"{message}; re-weighted: {message_again}", nfev + nfev_again
    if statistical and noise_used is None:
        levels = list(noise.filled())
        if residual != "pose":
            levels[1] = float("nan")  # positions carry no orientation: not measured
        noise_used = NoiseEstimate(*levels, None, None, None)
    if not converged and _stationary(problem, x):
        converged, message = True, f"{message}; at a stationary point of the cost (the " \
            "solver's own tolerances were not met, its steps no longer lower the cost)"
    elif not converged:
        message += ("; NOT converged: try a simpler model (--model thesis or joints), more "
                    "poses spread over the joint ranges, or a starting base frame "
                    "(--base-guess)")

    r, Jw = problem.weighted(x)
    dof = max(m - p, 1)
    chi2 = float(r @ r) / dof
    cov = scipy.linalg.pinvh(Jw.T @ Jw + np.diag(problem.prior ** 2))  # the posterior's
    if weighting == "eq2.4" or (statistical and not estimate_noise and chi2 > 1.0):
        cov = cov * chi2  # the noise was understated: the a-posteriori variance factor
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    corr = cov / np.outer(np.where(std > 0, std, 1), np.where(std > 0, std, 1))
    col = np.linalg.norm(Jw, axis=0)
    s = svd(Jw / np.where(col > 0, col, 1), compute_uv=False)
    to_if = errors.to_interface
    calibrated = errors.apply(x)
    unabsorbed = _unabsorbed(Jw, errors.params)
    names_kept = list(errors.names)
    held = held_directions(Jw, 1.0 / problem.prior, names_kept) if ranges is not None else []
    implausible = outside_ranges(errors.params, to_if(x), to_if(std), ranges) \
        if ranges is not None else []
    orientation_unknown = _orientation_unknown(residual, calibrated)
    before = _pose_errors(start, data, residual)
    after = _pose_errors(calibrated, data, residual)
    return CalibrationResult(
        model=calibrated, start_model=start, params=errors.params, values=to_if(x),
        std_errors=to_if(std), correlation=corr, removed=tuple(removed),
        unidentifiable_combinations=tuple(combos), residual_kind=residual, weighting=weighting,
        solver=solver, rank=rank, n_candidates=len(cands),
        condition_number=float(s[0] / s[-1]), o1=float(np.prod(s ** (1.0 / p)) / np.sqrt(m)),
        min_singular_value=float(s[-1]), chi2_reduced=chi2, converged=bool(converged),
        message=str(message), n_evaluations=nfev, seconds=time.perf_counter() - started,
        residuals_before=before[0], residuals_after=after[0], rotation_before_deg=before[1],
        rotation_after_deg=after[1], degenerate=degenerate, covariance=cov, noise=noise_used,
        unabsorbed=unabsorbed, data_warnings=tuple(notes), held_by_prior=tuple(held),
        implausible=tuple(implausible), orientation_unknown=orientation_unknown), problem, x


def _orientation_unknown(residual: str, model: SerialModel) -> str:
    """Why a model fitted to positions predicts no orientation, or "". Positions of a point
    on (or near) the last joint's axis see neither that axis' tilt nor its zero; a point off
    it sees the tilt, and only the zero stays with the measured point's unknown place on the
    flange (held at nominal: the orientation is then known but for the turn about the last
    axis, as the nominal robot's)."""
    if residual == "pose":
        return ""
    n = model.n_joints
    d = point_axis_distance_mm(model)
    if d >= NEAR_AXIS_MM:
        return ""
    return (f"the measured point is {d:.1f} mm from joint {n}'s axis (under "
            f"{NEAR_AXIS_MM:g} mm) and the data are positions only: they see neither the "
            f"tilt of that axis nor joint {n}'s zero, so the model does not know the "
            "orientation")


def _stationary(problem: _Problem, x: Array) -> bool:
    """Whether x is a stationary point of the (posterior) cost: a Gauss-Newton step from it
    would lower the cost by less than a millionth (the solver stopped on its evaluation count
    or step tolerances, not short of the minimum)."""
    r, J = problem.posterior(x)
    dx = np.linalg.lstsq(J, -r, rcond=None)[0]
    cost = float(r @ r)
    gain = cost - float(np.sum((r + J @ dx) ** 2))
    return bool(gain <= 1e-6 * max(cost, 1.0))


def _unabsorbed(Jw: Array, params: Sequence[Param]) -> dict[str, float]:
    """Per compliance parameter, the share of its effect on the measurements that the other
    parameters cannot reproduce: 1 - |projection of its column on theirs|^2 / |column|^2
    (1: nothing of the geometry can imitate it; near 0: the geometry would absorb it)."""
    out = {}
    for k, p in enumerate(params):
        if p.kind != "compliance":
            continue
        col = Jw[:, k]
        others = np.delete(Jw, k, axis=1)
        fit = others @ np.linalg.lstsq(others, col, rcond=None)[0]
        out[p.name] = float(1.0 - (fit @ fit) / max(col @ col, 1e-300))
    return out


PRESS_MARGIN = 0.02  # the joint component is dropped only when that predicts clearly better
VCE_MAX_ITER = 25
VCE_TOL = 0.05  # relative change of every free component at convergence
NEGLIGIBLE = 0.01  # a component under this share of the variance no longer shapes the weights
STEP_LIMIT = 20.0  # one scoring step changes a component by at most this factor


def _estimate_noise(problem: _Problem, noise: NoiseModel, x: Array,
                    solve: Callable[[_Problem, Array], tuple[Array, bool, str, int]]
                    ) -> tuple[_Problem, Array, NoiseEstimate, int, tuple[bool, str]]:
    """The free noise levels and the parameters together, by restricted maximum likelihood
    (Fisher scoring on the variance components, a Gauss-Newton step of the parameters with the
    weights of each step, LM at the end); returns the final problem, estimate, levels,
    evaluations and the final solve's (converged, message)."""
    theta = _theta(noise.filled())
    floor = 1e-8 * _theta(PRIOR_NOISE)
    free = np.array(noise.free)
    if problem.rows == 3:
        free[1] = False  # no orientation measured
        theta[1] = 0.0
    idx = np.flatnonzero(free)
    information = np.eye(len(idx))
    nfev, converged, iteration = 0, False, 0
    # The levels are found on the problem linearised at the start (which the candidates'
    # Gauss-Newton step puts near the optimum), then LM solves the nonlinear problem once with
    # the final weights, taken at its own estimate.
    V = problem.components(x)
    e, A = problem.raw(x)
    assert A is not None
    while iteration < VCE_MAX_ITER:
        iteration += 1
        W = _whitening(np.einsum("k,knij->nij", theta, V))
        # The weighted linear least-squares step, and the residuals carried there.
        P = problem.prior
        dx = -np.linalg.lstsq(np.vstack([(W @ A).reshape(-1, A.shape[-1]), np.diag(P)]),
                              np.r_[(W @ e[..., None]).reshape(-1), P * x], rcond=None)[0]
        x, e = x + dx, e + A @ dx
        Cinv = np.swapaxes(W, 1, 2) @ W
        Ce = (Cinv @ e[..., None])[..., 0]
        CA = Cinv @ A
        p_ = A.shape[-1]
        Ninv = scipy.linalg.pinvh(A.reshape(-1, p_).T @ CA.reshape(-1, p_) + np.diag(P ** 2))
        Vk = V[idx]
        K = len(idx)
        M = Cinv @ Vk  # C^-1 V_k per pose
        S = CA @ Ninv @ np.swapaxes(CA, 1, 2)  # C^-1 A N^-1 A^T C^-1 per pose
        # A^T C^-1 V_k C^-1 A summed over the poses: one product of the stacked rows, never
        # the (K, N, p, p) per-pose terms (55 MB for 1000 poses and 48 parameters)
        G = CA.reshape(-1, p_).T @ (Vk @ CA).reshape(K, -1, p_)
        # REML score and expected information of the variance components (traces of products
        # of per-pose blocks: tr(X Y) = sum of X * Y^T)
        score = 0.5 * ((Ce[:, None, :] @ Vk @ Ce[:, :, None]).sum(axis=(1, 2, 3))
                       - np.trace(M, axis1=2, axis2=3).sum(axis=1)
                       + (Vk * np.swapaxes(S, 1, 2)).sum(axis=(1, 2, 3)))
        GN = G @ Ninv
        MS = M @ S
        information = 0.5 * (M.reshape(K, -1) @ np.swapaxes(M, 2, 3).reshape(K, -1).T
                             - 2.0 * Vk.reshape(K, -1) @ np.swapaxes(MS, 2, 3).reshape(K, -1).T
                             + np.einsum("kpq,lqp->kl", GN, GN))
        step = np.linalg.lstsq(information, score, rcond=None)[0]
        old = theta[idx].copy()
        new = np.clip(old + step, old / STEP_LIMIT, old * STEP_LIMIT)
        theta[idx] = np.maximum(new, floor[idx])
        share = np.einsum("knii->k", V) * theta
        share = share / share.sum()
        at_zero = (share[idx] < NEGLIGIBLE) & (step < 0)  # on the boundary: below detection
        if np.all((np.abs(theta[idx] / old - 1.0) < VCE_TOL) | at_zero):
            converged = True
            break
    V = problem.components(x)
    problem = problem.with_whitening(_whitening(np.einsum("k,knij->nij", theta, V)))
    x, solved, message, n = solve(problem, x)
    nfev += n
    levels = _levels(theta)
    cov_theta = scipy.linalg.pinvh(information)
    stds: list[float | None] = [None, None, None]
    for j, c in enumerate(idx):
        # d level / d theta = level / (2 theta) for each of the three levels' scalings
        stds[c] = float(levels[c] / (2.0 * theta[c]) * np.sqrt(max(cov_theta[j, j], 0.0)))
    if problem.rows == 3:
        levels[1] = float("nan")
    estimate = NoiseEstimate(*(float(v) for v in levels), *stds,  # type: ignore[arg-type]
                             iterations=iteration, converged=converged)
    return problem, x, estimate, nfev, (solved, message)


def _pose_errors(model: SerialModel, data: MeasurementSet, residual: str
                 ) -> tuple[Array, Array | None]:
    """Position error norm per pose (mm) and rotation error (deg) when measured; for distance
    data, the absolute error of each pairwise distance."""
    T = forward_kinematics(model, data.q)
    if residual == "distance":
        i, j = pairs(len(data))
        return (np.abs(np.linalg.norm(T[i, :3, 3] - T[j, :3, 3], axis=1)
                       - np.linalg.norm(data.positions_mm[i] - data.positions_mm[j], axis=1)),
                None)
    pos = np.linalg.norm(T[:, :3, 3] - data.positions_mm, axis=1)
    if data.rotations is None:
        return pos, None
    dR = T[:, :3, :3] @ np.swapaxes(data.rotations, 1, 2)
    return pos, np.degrees(np.linalg.norm(rotvec_from_rotation(dR), axis=-1))


def _de_bounds(errors: ErrorModel, link_bounds_mm: tuple[float, float]
               ) -> list[tuple[float, float]]:
    """The thesis's bounds: joint offsets [-5, 5] deg, link offsets (0, 1) mm by default;
    frames within +-2 deg and +-20 mm of the starting alignment; full-model axis terms within
    +-1 deg and +-5 mm."""
    out = []
    for p in errors.params:
        if p.kind == "zero":
            out.append((-np.radians(5), np.radians(5)) if p.is_angle else (-5.0, 5.0))
        elif p.kind == "link":
            out.append(link_bounds_mm)
        elif p.kind.endswith("rot"):
            out.append((-np.radians(2), np.radians(2)))
        elif p.kind.endswith("pos"):
            out.append((-20.0, 20.0))
        elif p.kind == "dir":
            out.append((-np.radians(1), np.radians(1)))
        else:
            out.append((-5.0, 5.0))
    return out
