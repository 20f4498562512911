"""What the residuals of a fit say about the data: poses that do not belong (outliers), joint
readings that lag the motion, drift over the acquisition, poses that add nothing, and a fit
poorer than the instrument allows.

Per pose i, with C_i its covariance, A_i its Jacobian and N = sum A^T C^-1 A, the residual's own
covariance is Q_i = C_i - A_i N^-1 A_i^T; the pose's test statistic T_i = e_i^T Q_i^-1 e_i is
chi-square with k degrees of freedom when the pose belongs (Baarda's data snooping, one pose at a
time); its leverage h_i = tr(A_i N^-1 A_i^T C_i^-1) (0..k, mean p/N) says how much the fit leans on
it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.special import chdtri, stdtr  # chi-square quantile, Student's t (not scipy.stats:

# a tenth of its import time, and this runs with every calibration)
from screwcal.kinematics.se3 import Array
from screwcal.tables import counted

OUTLIER_ALPHA = 0.01  # family-wise: each pose tested at alpha / N
MAX_OUTLIER_FRACTION = 0.1  # never reject more than this share of the poses
LAG_MIN_CORRELATION = 0.2
DRIFT_MIN_CORRELATION = 0.2
SIGNIFICANCE = 1e-3
LOW_LEVERAGE = 0.1  # a pose with less than this share of the mean leverage adds nothing
WELL_CONDITIONED = 1e8  # a (k, k) matrix inverted directly (1-norm condition number under it)


@dataclass(frozen=True)
class PoseTest:
    """The fit's residual statistics per pose (N,)."""

    statistic: Array  # T_i, chi-square with `dof` when the pose belongs
    leverage: Array  # h_i
    dof: int

    def threshold(self, alpha: float = OUTLIER_ALPHA) -> float:
        n = len(self.statistic)
        return float(chdtri(self.dof, alpha / max(n, 1)))


def pose_tests(e: Array, A: Array, W: Array) -> PoseTest:
    """Per-pose statistics from the raw residuals e (N, k), their Jacobian A (N, k, p) and the
    whitening W (N, k, k) (W^T W = C^-1).

    Worked in whitened units, where C is the identity: with N^-1 = L L^T and B_i = W_i A_i L,
    the hat block is H_i = B_i B_i^T, Q_i = I - H_i, T_i = e_i^T W_i^T Q_i^-1 W_i e_i and
    h_i = tr(H_i) (one (Nk, p) product and (k, k) solves; no per-pose inverse of C)."""
    return whitened_pose_tests(W @ e[..., None], W @ A)


def whitened_pose_tests(ew: Array, Aw: Array) -> PoseTest:
    """`pose_tests` of the whitened residuals ew (N, k, 1) and Jacobian Aw (N, k, p): W e and
    W A, when at hand."""
    N, k, p = Aw.shape
    flat = Aw.reshape(-1, p)
    Ninv = scipy.linalg.pinvh(flat.T @ flat)
    eigval, eigvec = np.linalg.eigh(Ninv)
    B = (flat @ (eigvec * np.sqrt(np.clip(eigval, 0.0, None)))).reshape(N, k, p)
    H = B @ np.swapaxes(B, 1, 2)
    Q = np.eye(k) - H
    try:
        Qe = np.linalg.solve(Q, ew)
    except np.linalg.LinAlgError:  # a pose the fit passes through exactly (leverage 1)
        Qe = np.linalg.pinv(Q, hermitian=True) @ ew
    T = np.einsum("nij,nij->n", ew, Qe)
    leverage = np.einsum("nij,nij->n", B, B)
    return PoseTest(T, leverage, k)


def _significant(x: Array, y: Array, min_r: float) -> tuple[float, bool]:
    """Pearson's r, and whether it is at least `min_r` and significant (two-sided t-test)."""
    ok = np.isfinite(x) & np.isfinite(y)
    n = int(ok.sum())
    if n < 10 or np.std(x[ok]) == 0 or np.std(y[ok]) == 0:
        return 0.0, False
    r = float(np.corrcoef(x[ok], y[ok])[0, 1])
    if abs(r) < min_r:
        return r, False
    t = abs(r) * np.sqrt((n - 2) / max(1.0 - r * r, 1e-300))
    return r, bool(2.0 * stdtr(n - 2, -t) < SIGNIFICANCE)


def _ranks(x: Array) -> Array:
    out = np.empty(len(x))
    out[np.argsort(x, kind="stable")] = np.arange(len(x))
    return out


def acquisition_order(ids: tuple[str, ...], lines: tuple[int, ...]) -> NDArray[np.bool_]:
    """(N,) True where a pose directly follows the one before it in the acquisition (its file
    line, or a numeric id, one more): a subset of the poses (a calibration half) keeps only
    those pairs, so that "the previous move" is the move the robot made."""
    keys: list[int | None] = list(lines) if lines else [int(i) if str(i).isdigit() else None
                                                         for i in ids]
    follows = np.zeros(len(keys), bool)
    for k in range(1, len(keys)):
        now, before = keys[k], keys[k - 1]
        follows[k] = now is not None and before is not None and now - before == 1
    return follows


def explaining_joint_errors(e: Array, Jq: Array) -> Array:
    """(N, n) per pose, the smallest joint change that would remove its residual e (N, k)
    through the joint Jacobian Jq (N, k, n): what the readings would have to be off by (the
    pseudo-inverse's answer). By batched (k, k) or (n, n) inverses (a batched SVD costs
    eight times as much): Jq^-1 e for k = n, the minimum-norm Jq^T (Jq Jq^T)^-1 e for k < n,
    (Jq^T Jq)^-1 Jq^T e for k > n; the poses whose matrix is ill-conditioned (condition
    number over `WELL_CONDITIONED`, e.g. a pose at the wrist singularity, where the SVD cuts
    the direction no joint change moves) by the SVD."""
    k, n = Jq.shape[1:]
    JT = np.swapaxes(Jq, 1, 2)
    G = Jq if k == n else Jq @ JT if k < n else JT @ Jq
    try:
        Ginv = np.linalg.inv(G)
    except np.linalg.LinAlgError:
        return (np.linalg.pinv(Jq) @ e[..., None])[..., 0]
    ev = e[..., None]
    dq = (Ginv @ ev if k == n else JT @ (Ginv @ ev) if k < n else Ginv @ (JT @ ev))[..., 0]
    cond = np.abs(G).sum(axis=1).max(axis=1) * np.abs(Ginv).sum(axis=1).max(axis=1)
    bad = ~(cond < WELL_CONDITIONED)  # (NaN too)
    if bad.any():
        dq[bad] = (np.linalg.pinv(Jq[bad]) @ ev[bad])[..., 0]
    return dq


@dataclass(frozen=True)
class JointLag:
    """One joint's readings against its previous move: the correlation of the joint error that
    would explain each residual with the joint's previous move, and whether it is flagged."""

    joint: int  # 1-based
    correlation: float
    flagged: bool


@dataclass(frozen=True)
class LagFinding:
    """Joint readings that lag the motion (taken before the arm settled), or backlash."""

    per_joint: tuple[JointLag, ...]
    warning: str | None

    @property
    def flagged(self) -> list[int]:
        """The joints (1-based) whose readings lag the motion."""
        return [j.joint for j in self.per_joint if j.flagged]


@dataclass(frozen=True)
class DriftFinding:
    """The residuals' size against the acquisition order (Spearman's rank correlation)."""

    spearman: float
    warning: str | None


@dataclass(frozen=True)
class LeverageFinding:
    """Poses that add almost nothing to the fit: their ids, and the mean leverage."""

    mean: float
    low: tuple[str, ...]
    warning: str | None


@dataclass(frozen=True)
class FitFinding:
    """The measuring noise the residuals need against the instrument's stated noise (None:
    the noise was fixed, not estimated)."""

    position_noise_over_stated: float | None
    warning: str | None


@dataclass(frozen=True)
class DataQuality:
    """The diagnostics a user sees: each finding with a `warning` (a sentence, or None) and
    its figures; `to_dict()` is the result file's `diagnostics` member."""

    lag: LagFinding
    drift: DriftFinding
    leverage: LeverageFinding
    fit: FitFinding

    @property
    def warnings(self) -> list[str]:
        return [f.warning for f in (self.lag, self.drift, self.leverage, self.fit) if f.warning]

    def to_dict(self) -> dict[str, Any]:
        return {
            "lag": {"per_joint": [{"joint": j.joint, "correlation": j.correlation,
                                   "flagged": j.flagged} for j in self.lag.per_joint],
                    "warning": self.lag.warning},
            "drift": {"spearman": self.drift.spearman, "warning": self.drift.warning},
            "leverage": {"mean": self.leverage.mean, "low": list(self.leverage.low),
                         "warning": self.leverage.warning},
            "fit": {"position_noise_over_stated": self.fit.position_noise_over_stated,
                    "warning": self.fit.warning}}


def data_quality(e: Array, Jq: Array, q_deg: Array, test: PoseTest, ids: tuple[str, ...],
                 position_noise_mm: float | None, stated_noise_mm: float,
                 follows: NDArray[np.bool_] | None = None) -> DataQuality:
    """The diagnostics a user sees (`DataQuality`).

    e (N, k) residuals in acquisition order, Jq (N, k, n) their joint Jacobian, q_deg (N, n) the
    joint readings, the pose tests, the estimated position noise (None when fixed), the
    instrument's stated noise, and which poses directly follow the previous one (default: all).
    """
    # Joint readings that lag the motion: the joint error that would explain each residual,
    # against the previous move of that joint.
    dq = np.degrees(explaining_joint_errors(e, Jq))
    step = np.vstack([np.full((1, q_deg.shape[1]), np.nan), np.diff(q_deg, axis=0)])
    if follows is not None:
        step[~follows] = np.nan
    lag = []
    for j in range(q_deg.shape[1]):
        r, flagged = _significant(step[:, j], dq[:, j], LAG_MIN_CORRELATION)
        lag.append(JointLag(j + 1, r, flagged))
    lagging = [d.joint for d in lag if d.flagged]
    lag_found = LagFinding(tuple(lag), None if not lagging else (
        f"the residual follows the previous move (joints {lagging}): joint readings taken "
        "before the arm settled (they lag the motion), or backlash; wait for the robot to "
        "settle, approach each pose from the same direction, or use the commanded joints"))
    # Drift: residual size against acquisition order.
    size = np.linalg.norm(e[:, :3], axis=1)
    rho, drift = _significant(np.arange(len(size), dtype=float), _ranks(size),
                              DRIFT_MIN_CORRELATION)  # Spearman: Pearson on the ranks
    drift_found = DriftFinding(float(rho), None if not drift else (
        f"the residuals {'grow' if rho > 0 else 'shrink'} with the acquisition order "
        f"(Spearman {rho:+.2f}): the set-up drifted; check the base and the measuring system"))
    # Poses that add nothing.
    mean = float(test.leverage.mean())
    idle = tuple(ids[k] for k in np.flatnonzero(test.leverage < LOW_LEVERAGE * mean))
    leverage = LeverageFinding(mean, idle, None if not idle else (
        f"{counted(len(idle), 'pose')} {'adds' if len(idle) == 1 else 'add'} almost nothing "
        f"to the fit (leverage under "
        f"{LOW_LEVERAGE:g} of the mean): {', '.join(idle[:10])}"))
    # A fit poorer than the instrument: the noise the data need against what is stated.
    ratio = None if position_noise_mm is None else position_noise_mm / stated_noise_mm
    fit = FitFinding(ratio, None if ratio is None or ratio < 3.0 else (
        f"the residuals need {position_noise_mm:.3g} mm of measuring noise, {ratio:.1f} times "
        f"the instrument's {stated_noise_mm:g} mm: the model misses something (joint "
        "compliance, a loose flange, drift) or the instrument is worse than stated"))
    return DataQuality(lag_found, drift_found, leverage, fit)


def loo_position_error(e: Array, A: Array, W: Array) -> float:
    """Mean leave-one-pose-out position error (mm) of the weighted linear fit of residuals e
    (N, k) with Jacobian A (N, k, p) and whitening W (N, k, k), from one solve: each pose's
    residual had it been left out, (I - H_ii)^-1 r_i in whitened units (PRESS, by blocks)."""
    p = A.shape[-1]
    d = W[0].diagonal()
    same_diagonal = bool(np.array_equal(W, np.broadcast_to(np.diag(d), W.shape)))
    # (the measuring noise alone weights every pose by the same diagonal: rows scaled)
    WA = A * d[:, None] if same_diagonal else W @ A
    r = e * d if same_diagonal else (W @ e[..., None])[..., 0]
    flat = WA.reshape(-1, p)
    Ninv = scipy.linalg.pinvh(flat.T @ flat)
    # residuals after this weighting's step; the hat blocks (products of the stacked rows)
    r = r - (flat @ (Ninv @ (flat.T @ r.reshape(-1)))).reshape(r.shape)
    H = (flat @ Ninv).reshape(WA.shape) @ np.swapaxes(WA, 1, 2)
    k = e.shape[1]
    r_loo = np.linalg.solve(np.eye(k) - H, r[..., None])[..., 0]
    e_loo = r_loo / d if same_diagonal else np.linalg.solve(W, r_loo[..., None])[..., 0]
    return float(np.linalg.norm(e_loo[:, :3], axis=1).mean())
