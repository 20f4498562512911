"""What the data can tell: the numerical rank of the identification Jacobian, which parameters
are kept (QR with column pivoting, by priority), why the others are removed, and how many
parameters well-spread data could identify at all (the structural rank).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from screwcal.calibration.error_parameters import ErrorModel
from screwcal.kinematics.se3 import Array

Index = NDArray[np.intp]
Residual = Literal["pose", "position", "distance"]

RANK_TOL = 1e-7  # relative to the largest singular value of the column-scaled Jacobian
GRAM_COND = 1e4  # up to this condition number, the Gram matrix's eigenvalues give the
# singular values (relative error eps * cond^2 = 2e-8 at most)


def svd(a: Array) -> tuple[Array, Array, Array]:
    """Thin SVD (U, s, Vt) by LAPACK's gesvd: numpy's default (gesdd) took 100+ ms, instead of
    1, on the exactly rank-deficient identification Jacobians."""
    U, s, Vt = scipy.linalg.svd(a, full_matrices=False, lapack_driver="gesvd")
    return U, s, Vt


def singular_values(a: Array) -> Array:
    """The singular values of `a`, largest first (gesvd, as `svd`)."""
    s: Array = scipy.linalg.svd(a, full_matrices=False, compute_uv=False, lapack_driver="gesvd")
    return s


def scaled_singular_values(J: Array, gram: Array) -> Array:
    """The singular values (largest first) of J (m, p) with its columns scaled to unit length,
    from its Gram matrix J^T J: the square roots of the scaled Gram matrix's eigenvalues (a
    (p, p) eigen-decomposition instead of the SVD of the tall J), whose relative error is
    about eps * cond^2: while the condition number is under `GRAM_COND`; above, by the SVD."""
    col = np.sqrt(np.diag(gram))
    col = np.where(col > 0, col, 1.0)
    ev = np.linalg.eigvalsh(gram / np.outer(col, col))[::-1]
    if ev[-1] > 0 and ev[0] < GRAM_COND ** 2 * ev[-1]:
        s: Array = np.sqrt(ev)
        return s
    return singular_values(J / col)


def pairs(n: int) -> tuple[Index, Index]:
    """The index pairs (i < j) of n points, i and j (n (n - 1) / 2,)."""
    i, j = np.triu_indices(n, k=1)
    return i, j


def select_identifiable(J: Array, priority: Array, names: list[str],
                        triangle: Array | None = None
                        ) -> tuple[Array, int, Array, list[str], Array]:
    """Kept column indices (in candidate order), the rank, the column norms, the null-space
    combinations, and the triangle of the scaled columns (`explain_removed` reads it).
    Columns of higher `priority` (0, 1, 2) are taken first wherever they are independent.

    Every question here is about the columns' independence, which the QR factor R of the
    column-scaled J answers as J does (J = Q R, Q keeps lengths): one factorisation of the
    tall J, then the SVD and the pivoted QR of R (p, p). `triangle`: R already at hand (the
    columns of a richer selection's R: Q R[:, S] are the columns S)."""
    norms = np.linalg.norm(J, axis=0)
    live = norms > 1e-12 * max(norms.max(), 1e-300)
    Rs = _scaled_triangle(J, norms, live) if triangle is None else triangle
    _, s, Vt = svd(Rs)
    rank = int(np.sum(s > RANK_TOL * s[0]))
    combos = []
    for v in Vt[rank:]:
        top = np.argsort(-np.abs(v))[:4]
        combos.append(" ".join(f"{v[t]:+.2f} {names[t]}" for t in top if abs(v[t]) > 0.05))
    order_weight = np.where(live, 1e4 ** np.asarray(priority, float), 0.0)
    _, _, piv = scipy.linalg.qr(Rs * order_weight, mode="economic", pivoting=True)
    keep = np.sort(piv[:rank])
    return keep, rank, norms, combos, Rs


def _scaled_triangle(J: Array, norms: Array, live: NDArray[np.bool_]) -> Array:
    """R (p, p) of the QR factorisation of J (m, p) with its live columns scaled to unit
    length (the others zero), written once in the column order LAPACK factorises in place
    (no second copy of the tall matrix)."""
    Js = np.empty(J.shape, order="F")
    np.divide(J, np.where(live, norms, 1.0), out=Js)
    Js[:, ~live] = 0.0
    geqrf, = scipy.linalg.get_lapack_funcs(("geqrf",), (Js,))
    work = geqrf(Js, lwork=-1)[2]  # the workspace LAPACK asks for (as scipy's qr)
    qr, _, _, info = geqrf(Js, lwork=int(work[0].real), overwrite_a=True)
    if info != 0:
        raise np.linalg.LinAlgError(f"QR of the scaled Jacobian: LAPACK geqrf info {info}")
    # the triangle from the top rows only (qr's mode "r" zeroes below the diagonal of the
    # whole tall matrix, a copy of it, and keeps p rows)
    R: Array = np.triu(qr[:J.shape[1]])
    return R


_STRUCTURAL_RANKS: dict[bytes, int] = {}


def structural_rank(errors: ErrorModel, residual: Residual, samples: int = 60) -> int:
    """How many of the error model's parameters well-spread data could identify: the rank of
    the column-scaled Jacobian over random configurations inside the limits. It depends on the
    model's structure only, so it is cached: the base frame moves the whole world rigidly and
    cannot change it, and the tool (the measured point) only through its rough place."""
    ref = errors.reference
    key = b"|".join([residual.encode(), str(samples).encode(), *(p.name.encode()
                                                                  for p in errors.params),
                     *(a.tobytes() for a in (ref.axis_dirs, ref.axis_points_mm,
                                             ref.home_flange, ref.limits)),
                     np.round(ref.tool, 1).tobytes()])
    if key not in _STRUCTURAL_RANKS:
        if len(_STRUCTURAL_RANKS) > 256:
            _STRUCTURAL_RANKS.clear()
        _STRUCTURAL_RANKS[key] = _structural_rank(errors, residual, samples)
    return _STRUCTURAL_RANKS[key]


def _structural_rank(errors: ErrorModel, residual: Residual, samples: int) -> int:
    ref = errors.reference
    q = np.random.default_rng(0).uniform(ref.limits[:, 0], ref.limits[:, 1],
                                         (samples, ref.n_joints))
    T, J, _ = errors.linearisation(np.zeros(len(errors.params)), q)
    if residual == "distance":
        i, j = pairs(samples)
        u = T[i, :3, 3] - T[j, :3, 3]
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        rows = np.einsum("pi,pij->pj", u, J[i, :3] - J[j, :3])
    else:
        rows = J[:, : (6 if residual == "pose" else 3)].reshape(-1, J.shape[-1])
    norms = np.linalg.norm(rows, axis=0)
    s = singular_values(rows / np.where(norms > 0, norms, 1.0))
    return int(np.sum(s > RANK_TOL * s[0]))


def explain_removed(Rs: Array, keep: Array, removed: Array, names: list[str], norms: Array
                    ) -> list[tuple[str, str]]:
    """Why each removed column is out: it has no effect, or the kept columns it cannot be told
    from (least squares of its scaled column on theirs, on the triangle `Rs` of the scaled
    columns that `select_identifiable` returns: the same fit as on the columns themselves)."""
    out = []
    coefs = np.linalg.lstsq(Rs[:, keep], Rs[:, removed], rcond=None)[0] if len(removed) else \
        np.zeros((len(keep), 0))
    for k, r in enumerate(removed):
        if norms[r] <= 1e-12 * max(norms.max(), 1e-300):
            out.append((names[r], "has no effect on these measurements"))
            continue
        coef = coefs[:, k]
        top = np.argsort(-np.abs(coef))[:3]
        terms = " ".join(f"{coef[t]:+.3g} {names[keep[t]]}" for t in top if abs(coef[t]) > 1e-3)
        out.append((names[r], f"not separable from {terms} (scaled columns)"))
    return out


# ----------------------------------------------------------------------------------------------
# The identification
