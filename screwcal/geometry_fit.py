"""A geometric fit of the screw model to full-pose measurements (relinearised Gauss-Newton).

The parameters are the raw ones of `kinematics.ParameterLayout`; the identifiable subset is chosen
by a QR factorisation with column pivoting of the scaled identification Jacobian at the starting
model, and the rest are reported as removed. Residuals are weighted by the stated standard
deviations (position in mm, orientation in rad).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from screwcal.kinematics import (
    ParameterLayout,
    forward_kinematics,
    parameter_jacobian,
    perturb_model,
    point_jacobian,
)
from screwcal.model import SerialModel
from screwcal.se3 import Array


@dataclass(frozen=True)
class GeometryFit:
    model: SerialModel
    free: tuple[str, ...]
    removed: tuple[str, ...]
    rank: int
    condition_number: float
    iterations: int
    converged: bool
    rms_before: float  # weighted residual RMS (unitless) at the start and at the end
    rms_after: float


def pose_residuals(T_measured: Array, T_model: Array) -> Array:
    """(dp [mm], dphi [rad]) per pose, shape (N, 6): what takes the model pose to the measured."""
    dR = T_measured[:, :3, :3] @ np.swapaxes(T_model[:, :3, :3], 1, 2)
    return np.concatenate([T_measured[:, :3, 3] - T_model[:, :3, 3],
                           Rotation.from_matrix(dR).as_rotvec()], axis=1)


def select_identifiable(J: Array, preferred: Array | None = None, rel_tol: float = 1e-8
                        ) -> tuple[Array, int, float]:
    """Indices of an independent column subset (QR with pivoting on unit-norm columns), the rank
    and the condition number of the kept columns. Columns in the boolean mask `preferred` are
    taken first where they are independent (pivoting picks the largest column, so they are
    scaled up for the pivot order only)."""
    norms = np.linalg.norm(J, axis=0)
    nonzero = norms > 1e-12 * max(norms.max(), 1e-300)
    Js = J[:, nonzero] / norms[nonzero]
    rank = np.linalg.matrix_rank(Js, tol=rel_tol * np.linalg.norm(Js, 2))
    if preferred is not None:
        Js = Js * np.where(preferred[nonzero], 1e3, 1.0)
    _, _, piv = scipy.linalg.qr(Js, mode="economic", pivoting=True)
    keep = np.flatnonzero(nonzero)[np.sort(piv[:rank])]
    s = np.linalg.svd(J[:, keep] / norms[keep], compute_uv=False)
    return keep, rank, float(s[0] / s[-1])


def fit_geometry(model: SerialModel, q: ArrayLike, T_measured: ArrayLike, *,
                 sigma_mm: float, sigma_rad: float, frames: Sequence[str] = ("home",),
                 max_iter: int = 25, step_tol: float = 1e-10) -> GeometryFit:
    """Fit joint axes, joint zeros and the given frames ("home", "base", "tool") to measured tool
    poses (N, 4, 4) at joint values q (N, n) rad."""
    q = np.asarray(q, dtype=float)
    T_measured = np.asarray(T_measured, dtype=float)
    layout = ParameterLayout(model.n_joints)
    candidates = list(range(7 * model.n_joints))
    for frame in frames:
        s = layout.frame_slice(frame)
        candidates += list(range(s.start, s.stop))
    weights = np.array([1 / sigma_mm] * 3 + [1 / sigma_rad] * 3)

    def weighted(m: SerialModel) -> tuple[Array, Array]:
        T = forward_kinematics(m, q)
        r = (pose_residuals(T_measured, T) * weights).reshape(-1)
        J = point_jacobian(parameter_jacobian(m, q), T)[:, :, candidates]
        return r, (J * weights[None, :, None]).reshape(-1, len(candidates))

    r, J = weighted(model)
    zeros = np.array([layout.names[c].endswith(".zero") for c in candidates])
    keep, rank, cond = select_identifiable(J, preferred=zeros)
    rms_before = float(np.sqrt(np.mean(r**2)))
    current, converged, iterations = model, False, 0
    for iterations in range(1, max_iter + 1):  # noqa: B007 (reported after the loop)
        dx_free = np.linalg.lstsq(J[:, keep], r, rcond=None)[0]
        dx = np.zeros(layout.size)
        dx[np.asarray(candidates)[keep]] = dx_free
        current = perturb_model(current, dx)
        r, J = weighted(current)
        if np.linalg.norm(dx_free) < step_tol:
            converged = True
            break
    names = [layout.names[c] for c in candidates]
    free = tuple(names[k] for k in keep)
    return GeometryFit(model=current, free=free,
                       removed=tuple(n for n in names if n not in free), rank=rank,
                       condition_number=cond, iterations=iterations, converged=converged,
                       rms_before=rms_before, rms_after=float(np.sqrt(np.mean(r**2))))
