"""The identification problem: weighted residuals and their Jacobian, pure functions of the
parameter vector x (thesis 2.2.3, Eq. 2.4).

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
  what its Figs. 20-21 found best).

Below the measurements' rows, each parameter's weak prior (`screwcal.calibration.plausible`):
what the solvers minimise is the posterior.
"""

from __future__ import annotations

import numpy as np

from screwcal.calibration.error_parameters import ErrorModel
from screwcal.calibration.identifiability import Residual, pairs
from screwcal.calibration.identify_settings import IdentifySettings, variance_from_levels
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.plausible import PlausibleRanges, prior_sigma
from screwcal.calibration.population import forward_batch
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, rotvec_from_rotation


def whitening(cov: Array) -> Array:
    """W_i with W_i^T W_i = cov_i^-1, per pose (N, k, k): the inverse of the Cholesky factor."""
    factor = np.asarray(np.linalg.cholesky(cov), dtype=np.float64)
    return lower_inverse(factor)


def lower_inverse(L: Array) -> Array:
    """The inverses of lower-triangular matrices L (N, k, k), by forward substitution a row at
    a time for all N together, X_i = (e_i - L_i,<i X_<i) / L_ii (a batched LU solve costs four
    times as much for 1000 of 6 x 6)."""
    k = L.shape[-1]
    X = np.zeros_like(L)
    for i in range(k):
        row = -np.einsum("nm,nmj->nj", L[:, i, :i], X[:, :i])
        row[:, i] += 1.0
        X[:, i] = row / L[:, i, i, None]
    return X


def whitening_of_levels(theta: Array, V: Array) -> Array:
    """The whitening of the covariance sum_k theta_k V_k: variance components (K,) and their
    per-pose matrices (K, N, k, k)."""
    return whitening(np.einsum("k,knij->nij", theta, V))


def prior_weights(errors: ErrorModel, ranges: PlausibleRanges | None) -> Array:
    """1 / sigma of the prior per parameter (numeric units); zeros without one."""
    if ranges is None:
        return np.zeros(len(errors.params))
    return 1.0 / prior_sigma(errors.params, ranges)


def residual_rows(residual: Residual) -> int:
    """Rows per pose: 6 for pose residuals, 3 for positions (and the points of distances)."""
    return 6 if residual == "pose" else 3


def covariance_components(Jq: Array, position_cov: Array | None = None) -> Array:
    """The unit covariance components V_k (3, N, k, k) of residuals whose joint Jacobian is Jq
    (N, k, n): position rows (mm^2), orientation rows (rad^2), and the joints' through the
    joint Jacobian (per rad^2). With each point's own covariance (N, 3, 3) (the data's
    `position_cov_mm2`) the position component is those, scaled to a mean variance of 1 per
    coordinate: the measuring level keeps its meaning (mm^2 per coordinate) and each point
    weighs by its own shape and size."""
    k = Jq.shape[1]
    V = np.zeros((3, len(Jq), k, k))
    if position_cov is None:
        V[0, :, range(3), range(3)] = 1.0
    else:
        V[0, :, :3, :3] = position_cov / (np.trace(position_cov, axis1=1, axis2=2).mean() / 3.0)
    if k == 6:
        V[1, :, range(3, 6), range(3, 6)] = 1.0
    V[2] = Jq @ np.swapaxes(Jq, 1, 2)
    return V


def _weights(problem: ResidualProblem, settings: IdentifySettings, at: Array) -> Array:
    """Per-pose whitening matrices (N, k, k), or per-pair weights (P,) for distances; the
    joint-noise part is carried through the joint Jacobian of the model at x = `at`."""
    data, residual = problem.data, problem.residual
    k = residual_rows(residual)
    N = len(data)
    if settings.weighting == "eq2.4":
        w = np.r_[np.full(3, 1.0 / settings.weight_mm), np.full(3, 180.0 / np.pi)][:k]
        W = np.broadcast_to(np.diag(w), (N, k, k)).copy()
        return W if residual != "distance" else np.full(len(pairs(N)[0]), w[0])
    Jq = problem.joint_jacobian(at)
    cov = np.einsum("k,knij->nij", variance_from_levels(settings.noise.filled()),
                    covariance_components(Jq, data.position_cov_mm2))
    if residual == "distance":
        i, j = pairs(N)
        u = data.positions_mm[i] - data.positions_mm[j]
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        var = np.einsum("pi,pij,pj->p", u, cov[i] + cov[j], u)
        return 1.0 / np.sqrt(var)
    return whitening(cov)


class ResidualProblem:
    """Residuals and Jacobian of one identification, pure functions of x; `whiten` holds the
    per-pose whitening matrices (N, k, k), or the per-pair weights (P,) of distances."""

    def __init__(self, errors: ErrorModel, data: MeasurementSet, residual: Residual,
                 whiten: Array, ranges: PlausibleRanges | None):
        self.errors = errors
        self.data = data
        self.residual = residual
        self.rows = residual_rows(residual)
        self.whiten = whiten
        self.ranges = ranges
        self.prior = prior_weights(errors, ranges)
        self._last: tuple[bytes, tuple[Array, Array]] | None = None
        self._linear: tuple[bytes, tuple[Array, Array, Array]] | None = None
        self._raw: tuple[bytes, tuple[Array, Array]] | None = None

    @classmethod
    def weighted_at(cls, errors: ErrorModel, data: MeasurementSet, residual: Residual,
                    settings: IdentifySettings, at: Array | None = None) -> ResidualProblem:
        """The problem with the settings' weights taken at x = `at` (default: the start)."""
        at = np.zeros(len(errors.params)) if at is None else at
        problem = cls(errors, data, residual, np.zeros(0), settings.prior_ranges)
        problem.whiten = _weights(problem, settings, at)  # the linearisation at `at` is kept
        return problem

    def restricted(self, errors: ErrorModel) -> ResidualProblem:
        """The same data and weights (taken at the same starting model) for a subset of the
        parameters: the weights depend on the model at the start, not on which are free."""
        return ResidualProblem(errors, self.data, self.residual, self.whiten, self.ranges)

    def with_whitening(self, whiten: Array) -> ResidualProblem:
        """The same problem with other whitening matrices (N, k, k) (and the kinematics of
        the last x at hand)."""
        problem = ResidualProblem(self.errors, self.data, self.residual, whiten, self.ranges)
        problem._linear, problem._raw = self._linear, self._raw
        return problem

    def posterior(self, x: Array) -> tuple[Array, Array]:
        """The weighted residuals and Jacobian with the prior's rows (plausible.py) below:
        what the solvers minimise."""
        r, J = self.weighted(x)
        return np.concatenate([r, self.prior * x]), np.vstack([J, np.diag(self.prior)])

    def posterior_residuals(self, x: Array) -> Array:
        return np.concatenate([self.residuals(x), self.prior * x])

    def posterior_jacobian(self, x: Array) -> Array:
        return self.posterior(x)[1]

    def linearisation(self, x: Array) -> tuple[Array, Array, Array]:
        """`ErrorModel.linearisation` at x on these data: tool poses, the point rates w.r.t.
        the parameters and w.r.t. the joints; the last one is kept (the residuals' Jacobian,
        the joint Jacobian of the weights and the diagnostics are asked at the same x)."""
        key = x.tobytes()
        if self._linear is None or self._linear[0] != key:
            self._linear = (key, self.errors.linearisation(x, self.data.q))
        return self._linear[1]

    def joint_jacobian(self, at: Array) -> Array:
        """The residuals' Jacobian w.r.t. the joints (N, k, n) at x = `at`."""
        return self.linearisation(at)[2][:, :self.rows]

    def components(self, at: Array) -> Array:
        """The unit covariance components V_k (3, N, k, k) at x = `at`."""
        return covariance_components(self.joint_jacobian(at), self.data.position_cov_mm2)

    def raw(self, x: Array) -> tuple[Array, Array]:
        """Unweighted residuals (N, k) or (P,) and their Jacobian (N, k, p) or (P, p); the
        last are kept (the solver's, the noise check's and the pose tests' are at one x)."""
        key = x.tobytes()
        if self._raw is None or self._raw[0] != key:
            self._raw = (key, self._raw_at(x))
        return self._raw[1]

    def _raw_at(self, x: Array) -> tuple[Array, Array]:
        T, J, _ = self.linearisation(x)
        dp = T[:, :3, 3] - self.data.positions_mm
        if self.residual == "distance":
            i, j = pairs(len(self.data))
            d_model = T[i, :3, 3] - T[j, :3, 3]
            n_model = np.linalg.norm(d_model, axis=1)
            r = n_model - np.linalg.norm(self.data.positions_mm[i] - self.data.positions_mm[j],
                                         axis=1)
            u = d_model / n_model[:, None]
            return r, np.einsum("pi,pij->pj", u, J[i, :3] - J[j, :3])
        if self.residual == "position":
            return dp, J[:, :3]
        dR = T[:, :3, :3] @ np.swapaxes(self._rotations(), 1, 2)
        # (d rotvec / d omega is the identity to first order: the residual rotations are small)
        return np.concatenate([dp, rotvec_from_rotation(dR)], axis=1), J

    def raw_residuals(self, x: Array) -> Array:
        """Unweighted residuals alone (N, k) or (P,): no Jacobian (unless at hand)."""
        if self._linear is not None and self._linear[0] == x.tobytes():
            T = self._linear[1][0]
        else:
            T = forward_kinematics(self.errors.apply(x), self.data.q)
        if self.residual == "distance":
            i, j = pairs(len(self.data))
            return (np.linalg.norm(T[i, :3, 3] - T[j, :3, 3], axis=1)
                    - np.linalg.norm(self.data.positions_mm[i] - self.data.positions_mm[j],
                                     axis=1))
        dp = T[:, :3, 3] - self.data.positions_mm
        if self.residual == "position":
            return dp
        dR = T[:, :3, :3] @ np.swapaxes(self._rotations(), 1, 2)
        return np.concatenate([dp, rotvec_from_rotation(dR)], axis=1)

    def _rotations(self) -> Array:
        rotations = self.data.rotations
        assert rotations is not None  # pose residuals are refused for position-only data
        return rotations

    def residuals(self, x: Array) -> Array:
        """Weighted residuals alone (no Jacobian: most LM evaluations only need these)."""
        if self._last is not None and self._last[0] == x.tobytes():
            return self._last[1][0]
        return self._apply_weights(self.raw_residuals(x))

    def weighted(self, x: Array) -> tuple[Array, Array]:
        """Weighted residuals and Jacobian; the last evaluation is kept (the result's
        statistics ask at the solver's last estimate again)."""
        key = x.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        r, J = self.raw(x)
        if self.residual == "distance":
            out = (r * self.whiten, J * self.whiten[:, None])
        else:
            out = (self._apply_weights(r), (self.whiten @ J).reshape(-1, J.shape[-1]))
        self._last = (key, out)
        return out

    def _apply_weights(self, r: Array) -> Array:
        if self.residual == "distance":
            return r * self.whiten
        return (self.whiten @ r[..., None]).reshape(-1)

    def cost(self, x: Array) -> float:
        r = self.residuals(x)
        return float(r @ r)

    def cost_batch(self, X: Array) -> Array:
        """Weighted sum of squares for a population X (p, S) (scipy's vectorized layout)."""
        T = forward_batch(self.errors, X.T, self.data.q)  # (S, N, 4, 4)
        prior = np.sum((self.prior[:, None] * X) ** 2, axis=0)
        if self.residual == "distance":
            i, j = pairs(len(self.data))
            P = T[:, :, :3, 3]  # (S, N, 3); indexing T[:, i, :3, 3] would put the pairs first
            d_model = np.linalg.norm(P[:, i] - P[:, j], axis=2)
            d_meas = np.linalg.norm(self.data.positions_mm[i] - self.data.positions_mm[j], axis=1)
            return np.sum(((d_model - d_meas) * self.whiten) ** 2, axis=1) + prior
        r = T[:, :, :3, 3] - self.data.positions_mm
        if self.residual == "pose":
            dR = T[:, :, :3, :3] @ np.swapaxes(self._rotations(), 1, 2)
            r = np.concatenate([r, rotvec_from_rotation(dR)], axis=2)
        rw = np.einsum("nij,snj->sni", self.whiten, r)
        return np.sum(rw**2, axis=(1, 2)) + prior


def pose_errors(model: SerialModel, data: MeasurementSet, residual: Residual,
                T: Array | None = None) -> tuple[Array, Array | None]:
    """Position error norm per pose (mm) and rotation error (deg) when measured; for distance
    data, the absolute error of each pairwise distance. `T`: the model's tool poses at the
    data's joints, when at hand."""
    T = forward_kinematics(model, data.q) if T is None else T
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
