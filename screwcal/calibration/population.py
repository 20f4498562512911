"""Tool poses for many parameter vectors of an error model at once: the population solver's
cost (Differential Evolution evaluates a whole population per generation, thesis 2.2.3).

`forward_batch(errors, X, q)` is `forward_kinematics(errors.apply(X[k]), q)` for every k, without
building P model objects: the parameters are scattered into per-vector zeros, axes and frames,
and the chain of screws runs over the population and the poses together.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from screwcal.calibration.error_parameters import ErrorModel
from screwcal.errors import ModelError
from screwcal.kinematics.forward import checked_joints
from screwcal.kinematics.se3 import Array, rotation_from_rotvec, skew


def _batched_frames(T0: Array, rotvec: Array, pos: Array) -> Array:
    """(P, 4, 4) frames [exp(rotvec) R0 | t0 + pos] for P parameter vectors."""
    P = len(rotvec)
    out = np.zeros((P, 4, 4))
    out[:, :3, :3] = rotation_from_rotvec(rotvec) @ T0[:3, :3]
    out[:, :3, 3] = T0[:3, 3] + pos
    out[:, 3, 3] = 1.0
    return out


def forward_batch(errors: ErrorModel, X: ArrayLike, q: ArrayLike) -> Array:
    """Tool poses for many parameter vectors at once: X (P, p), q (N, n) -> (P, N, 4, 4).

    The same model as `errors.apply(X[k])` for every k, without building P model objects (for
    population-based solvers such as Differential Evolution).
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    ref = errors.reference
    if ref.has_compliance or any(p.kind.startswith("compliance") for p in errors.params):
        raise ModelError("joint compliance is identified by least squares, not by the "
                         "population solver: use solver='lm'")
    q = checked_joints(ref, q)
    P, n = len(X), ref.n_joints
    zero = np.broadcast_to(ref.joint_zero, (P, n)).copy()
    dirs = np.broadcast_to(ref.axis_dirs, (P, n, 3)).copy()
    points = np.broadcast_to(ref.axis_points_mm, (P, n, 3)).copy()
    frame = {k: np.zeros((P, 3)) for k in ("home_rot", "home_pos", "base_rot", "base_pos",
                                            "tool_rot", "tool_pos")}
    for col, p in enumerate(errors.params):
        v = X[:, col]
        if p.kind == "zero":
            zero[:, p.joint] += v
        elif p.kind == "link":
            points[:, p.joint + 1:, p.axis] += v[:, None]
            frame["home_pos"][:, p.axis] += v
        elif p.kind in ("dir", "point"):
            e = errors._normals_table[p.joint, p.axis]
            target = dirs if p.kind == "dir" else points
            target[:, p.joint] += v[:, None] * e
        else:
            frame[p.kind][:, p.axis] += v
    dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
    home = _batched_frames(ref.home_flange, frame["home_rot"], frame["home_pos"])
    base = _batched_frames(ref.base, frame["base_rot"], frame["base_pos"])
    tool = _batched_frames(ref.tool, frame["tool_rot"], frame["tool_pos"])
    theta = q[None, :, :] + zero[:, None, :]  # (P, N, n)
    A = np.broadcast_to(base[:, None, :3, :], (P, len(q), 3, 4)).copy()
    for i in range(n):
        G1 = np.zeros((P, 4, 4))
        if ref.joint_types[i] == "R":
            K = skew(dirs[:, i])
            G1[:, :3, :3] = K
            G1[:, :3, 3] = -np.einsum("pij,pj->pi", K, points[:, i])
            G2 = G1 @ G1
            t = theta[:, :, i, None, None]
            A = A + np.sin(t) * (A @ G1[:, None]) + (1.0 - np.cos(t)) * (A @ G2[:, None])
        else:
            G1[:, :3, 3] = dirs[:, i]
            A = A + theta[:, :, i, None, None] * (A @ G1[:, None])
    A = A @ (home @ tool)[:, None]
    T = np.zeros((*A.shape[:-2], 4, 4))
    T[..., :3, :] = A
    T[..., 3, 3] = 1.0
    return T
