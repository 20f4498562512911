"""One Fisher-scoring step of the variance components (REML; `noise_levels`), in whitened
units with each component factored.

With the covariance C_i = sum_k theta_k V_k,i of pose i, its whitening W_i (W^T W = C^-1), the
whitened residuals e~ = W e, Jacobian A~ = W A, H_i = A~_i N^-1 A~_i^T and V~_k = W V_k W^T,
the score and the expected information of the restricted likelihood are (Koch 1999, 3.6)

    s_k    = 1/2 [ e~^T V~_k e~ - tr(V~_k) + tr(V~_k H) ]                  (sums over poses)
    I_kl   = 1/2 [ tr(V~_k V~_l) - 2 tr(V~_k V~_l H) + tr(G_k N^-1 G_l N^-1) ],
    G_k    = sum_i A~_i^T V~_k,i A~_i.

Each component is factored, V_k = B_k B_k^T (the measuring noise's a fixed selection of rows,
the joint noise's a Cholesky factor per pose), so V~_k = U_k U_k^T with U_k = W B_k (k, r_k):
every trace is a sum over the columns u of U, tr(V~_k) = sum |u|^2, tr(V~_k H) = sum u^T H u,
tr(V~_k V~_l) = sum (u^T u')^2, tr(V~_k V~_l H) = sum (u^T u')(u^T H u'), all of (k, k) and
(k, r) blocks once H (k, k) is formed from one product of the stacked rows; and G_k is the Gram
matrix of the stacked P_k = U_k^T A~ (r_k, p): the (p, p)-sized work is one pass over the rows
(the per-pose products C^-1 V_k C^-1 A of every component, 1000 of (k, k) x (k, p) each, are not
formed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from screwcal.calibration.identifiability import Index
from screwcal.kinematics.se3 import Array

BLOCK = 200  # poses summed at a time: a block's arrays (~0.1-0.2 MB each) stay in cache


@dataclass(frozen=True)
class Factor:
    """A variance component V = B B^T per pose: for one that is the same diagonal at every
    pose (the measuring noise's), the rows it weights and their scale (B: those unit columns,
    scaled); else B (N, k, r) itself."""

    rows: Index
    scale: Array
    B: Array | None = None

    def whitened(self, W: Array, poses: slice) -> Array:
        """U = W B (n, k, r) of the poses `poses`, whose whitening is W (n, k, k)."""
        if self.B is None:
            U: Array = W[:, :, self.rows] * self.scale
            return U
        return W @ self.B[poses]


def component_factors(V: Array) -> list[Factor]:
    """The factors of the components V (K, N, k, k): a component that is the same
    non-negative diagonal at every pose, the rows it weights, scaled; else the Cholesky factor
    per pose, or (a pose where it is singular) the eigen-decomposition's."""
    out = []
    for Vc in V:
        d = Vc[0].diagonal()
        if np.all(d >= 0) and np.array_equal(Vc, np.broadcast_to(np.diag(d), Vc.shape)):
            rows = np.flatnonzero(d)
            out.append(Factor(rows, np.sqrt(d[rows])))
            continue
        try:
            B = np.linalg.cholesky(Vc)
        except np.linalg.LinAlgError:
            lam, Q = np.linalg.eigh(Vc)
            B = Q * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]
        out.append(Factor(np.arange(B.shape[2]), np.ones(B.shape[2]), B))
    return out


def scoring_step(e: Array, Aw: Array, factors: list[Factor], W: Array, Ninv: Array
                 ) -> tuple[Array, Array]:
    """REML score (K,) and expected information (K, K) of the free variance components,
    factored (`component_factors`), at the residuals e (N, k) of the problem linearised as
    A (N, k, p), whitened by W (N, k, k) (Aw = W A), whose normal matrix (the prior's
    included) has the inverse Ninv (p, p) (the module docstring's formulas). Every term is a
    sum over the poses: they are summed `BLOCK` poses at a time (each block's arrays stay in
    cache)."""
    K = len(factors)
    owner = np.concatenate([np.full(len(f.rows), c) for c, f in enumerate(factors)])
    E = np.zeros((len(owner), K))
    E[np.arange(len(owner)), owner] = 1.0  # columns -> components
    sums = [_block_sums(e[s:s + BLOCK], Aw[s:s + BLOCK], factors, W[s:s + BLOCK],
                        slice(s, s + BLOCK), Ninv) for s in range(0, len(e), BLOCK)]
    traces, UU2, UUZ, G = (sum(part[j] for part in sums) for j in range(4))
    score = 0.5 * traces @ E
    GN = G @ Ninv
    information = 0.5 * (E.T @ (UU2 - 2.0 * UUZ) @ E + np.einsum("kpq,lqp->kl", GN, GN))
    return score, information


def _block_sums(e: Array, Aw: Array, factors: list[Factor], W: Array, poses: slice,
                Ninv: Array) -> tuple[Array, Array, Array, Array]:
    """Of the poses `poses`: per factor column u, |u^T e~|^2 - |u|^2 + u^T H u (R,); the sums
    of (u^T u')^2 and of (u^T u')(u^T H u') (R, R); and G_k (K, p, p)."""
    p = Aw.shape[-1]
    H = (Aw.reshape(-1, p) @ Ninv).reshape(Aw.shape) @ np.swapaxes(Aw, 1, 2)  # hat blocks
    Us = [f.whitened(W, poses) for f in factors]  # V~_k = U_k U_k^T
    # G_k: the Gram matrix of the stacked P_k = U_k^T A~
    G = np.stack([_stacked_gram(np.swapaxes(U, 1, 2) @ Aw) for U in Us])
    U = np.concatenate(Us, axis=2)  # (n, k, R)
    UT = np.swapaxes(U, 1, 2)
    HU = H @ U
    ue = (UT @ (W @ e[..., None]))[..., 0]  # (n, R)
    traces = np.sum(ue ** 2, axis=0) - np.sum(U ** 2, axis=(0, 1)) + np.sum(U * HU,
                                                                          axis=(0, 1))
    UU = UT @ U  # (n, R, R)
    return traces, np.sum(UU ** 2, axis=0), np.sum(UU * (UT @ HU), axis=0), G


def _stacked_gram(P: Array) -> Array:
    """sum_i P_i^T P_i (p, p) of P (N, r, p): one product of the stacked rows."""
    X = P.reshape(-1, P.shape[-1])
    out: Array = X.T @ X
    return out
