"""Rigid-body maths over batches: skew matrices, twists, adjoints, exponentials.

Twists are 6-vectors ordered (omega, v) (angular first, as in Modern Robotics). A *spatial*
twist `xi` of a moving frame T satisfies dT T^-1 = hat(xi). Every function takes a leading batch
axis (`...`) and returns float64 arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]  # a boolean mask, e.g. which targets are reachable


def skew(w: ArrayLike) -> Array:
    """Skew-symmetric matrix [w]x of vectors w, shape (..., 3) -> (..., 3, 3)."""
    w = np.asarray(w, dtype=float)
    out = np.zeros((*w.shape[:-1], 3, 3))
    out[..., 0, 1] = -w[..., 2]
    out[..., 0, 2] = w[..., 1]
    out[..., 1, 0] = w[..., 2]
    out[..., 1, 2] = -w[..., 0]
    out[..., 2, 0] = -w[..., 1]
    out[..., 2, 1] = w[..., 0]
    return out


def cross(a: ArrayLike, b: ArrayLike) -> Array:
    """Cross product over the last axis, (..., 3) x (..., 3) -> (..., 3). np.cross does the
    same with axis bookkeeping that costs more than the arithmetic for small batches."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def rotation_from_rotvec(phi: ArrayLike) -> Array:
    """Rodrigues' formula, (..., 3) -> (..., 3, 3) (Annex B); for the solver's hot path, where
    scipy's Rotation costs more than the arithmetic."""
    phi = np.asarray(phi, dtype=float)
    theta = np.linalg.norm(phi, axis=-1)
    small = theta < 1e-9
    th = np.where(small, 1.0, theta)
    A = np.where(small, 1.0 - theta**2 / 6.0, np.sin(th) / th)
    B = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(th)) / th**2)
    K = skew(phi)
    R: Array = np.eye(3) + A[..., None, None] * K + B[..., None, None] * (K @ K)
    return R


def rotvec_from_rotation(R: ArrayLike) -> Array:
    """The rotation vector of rotations (..., 3, 3), the inverse of `rotation_from_rotvec`.
    Angles within 0.1 rad of 180 deg, where this formula loses precision, are read off the
    unit quaternion (`_rotvec_near_half_turn`)."""
    R = np.asarray(R, dtype=float)
    cos = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(cos)
    v = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                  R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    sin = np.sin(theta)
    small = theta < 1e-6
    scale = np.where(small, 0.5 + theta**2 / 12.0, theta / (2.0 * np.where(small, 1.0, sin)))
    out: Array = v * scale[..., None]
    near_pi = theta > np.pi - 0.1
    if np.any(near_pi):
        out[near_pi] = _rotvec_near_half_turn(R[near_pi])
    return out


def _rotvec_near_half_turn(R: Array) -> Array:
    """Rotation vectors (M, 3) of rotations (M, 3, 3) near a half turn, from their unit
    quaternions (Shepperd's method, well conditioned there): angle 2 atan2(|v|, w) along v.
    (Once scipy's Rotation: importing scipy.spatial cost a third of a second of every
    `compensate` whose program had one such target.)"""
    q = quaternion_wxyz_from_rotation(R)
    norm = np.linalg.norm(q[:, 1:], axis=1)
    angle = 2.0 * np.arctan2(norm, q[:, 0])
    rotvec: Array = q[:, 1:] * (angle / norm)[:, None]
    return rotvec


def quaternion_wxyz_from_rotation(R: ArrayLike) -> Array:
    """Unit quaternions (w, x, y, z), w >= 0 as RAPID's orient, from rotations (..., 3, 3)
    (Shepperd's method: from the largest of w, x, y, z; w = 0 leaves the first non-zero of
    x, y, z positive, as scipy's canonical form)."""
    R = np.asarray(R, dtype=float)
    if R.shape == (3, 3):  # one rotation: the same formulas on floats (1/30 of the time)
        return np.array(_quaternion_of_one(R.tolist()))
    flat = R.reshape(-1, 3, 3)
    r = {(i, j): flat[:, i, j] for i in range(3) for j in range(3)}
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    case = np.argmax(np.stack([trace, r[0, 0], r[1, 1], r[2, 2]], axis=1), axis=1)
    q = np.empty((len(flat), 4))
    for c, (big, a, b, d) in enumerate((
            (1 + trace, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]),
            (1 + r[0, 0] - r[1, 1] - r[2, 2], r[2, 1] - r[1, 2], r[0, 1] + r[1, 0],
             r[0, 2] + r[2, 0]),
            (1 - r[0, 0] + r[1, 1] - r[2, 2], r[0, 2] - r[2, 0], r[0, 1] + r[1, 0],
             r[1, 2] + r[2, 1]),
            (1 - r[0, 0] - r[1, 1] + r[2, 2], r[1, 0] - r[0, 1], r[0, 2] + r[2, 0],
             r[1, 2] + r[2, 1]))):
        m = case == c
        if not m.any():
            continue
        s = np.sqrt(np.maximum(big[m], 0.0)) * 2.0  # 4 |component|
        order = ((0, 1, 2, 3), (1, 0, 2, 3), (2, 0, 1, 3), (3, 0, 1, 2))[c]
        values = (s / 4.0, a[m] / s, b[m] / s, d[m] / s)
        for slot, v in zip(order, values, strict=True):
            q[m, slot] = v
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    first = np.argmax(np.abs(q[:, 1:]) > 1e-15, axis=1) + 1
    sign = np.where(q[:, 0] != 0.0, np.sign(q[:, 0]),
                    np.sign(q[np.arange(len(q)), first]))
    q *= np.where(sign == 0, 1.0, sign)[:, None]
    return q.reshape((*R.shape[:-2], 4))


def _quaternion_of_one(r: list[list[float]]) -> tuple[float, float, float, float]:
    """`quaternion_wxyz_from_rotation` of one rotation (rows as lists): Shepperd's four cases
    and the sign rule written on floats (a test holds the two equal)."""
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = r
    trace = r00 + r11 + r22
    big = max(trace, r00, r11, r22)  # the first largest, as argmax
    if big == trace:
        s = math.sqrt(max(1 + trace, 0.0)) * 2.0
        q = (s / 4.0, (r21 - r12) / s, (r02 - r20) / s, (r10 - r01) / s)
    elif big == r00:
        s = math.sqrt(max(1 + r00 - r11 - r22, 0.0)) * 2.0
        q = ((r21 - r12) / s, s / 4.0, (r01 + r10) / s, (r02 + r20) / s)
    elif big == r11:
        s = math.sqrt(max(1 - r00 + r11 - r22, 0.0)) * 2.0
        q = ((r02 - r20) / s, (r01 + r10) / s, s / 4.0, (r12 + r21) / s)
    else:
        s = math.sqrt(max(1 - r00 - r11 + r22, 0.0)) * 2.0
        q = ((r10 - r01) / s, (r02 + r20) / s, (r12 + r21) / s, s / 4.0)
    n = math.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    w, x, y, z = (v / n for v in q)
    first = next((v for v in (x, y, z) if abs(v) > 1e-15), x)
    sign = math.copysign(1.0, w) if w != 0.0 else (math.copysign(1.0, first) if first else 1.0)
    return (w * sign, x * sign, y * sign, z * sign)


def transform_from_rotation_translation(R: ArrayLike, t: ArrayLike) -> Array:
    """Homogeneous transforms from rotations (..., 3, 3) and translations (..., 3)."""
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    shape = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    T = np.zeros((*shape, 4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def transform_points(T: ArrayLike, points: ArrayLike) -> Array:
    """Points (..., 3) expressed in the frame T (4, 4) maps them into: R p + t."""
    T = np.asarray(T, dtype=float)
    mapped: Array = np.asarray(points, dtype=float) @ T[:3, :3].T + T[:3, 3]
    return mapped


def invert_transform(T: ArrayLike) -> Array:
    """Inverse of homogeneous transforms, shape (..., 4, 4)."""
    T = np.asarray(T, dtype=float)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    t = -np.einsum("...ij,...j->...i", Rt, T[..., :3, 3])
    return transform_from_rotation_translation(Rt, t)


def adjoint(T: ArrayLike) -> Array:
    """Adjoint matrices Ad_T, shape (..., 4, 4) -> (..., 6, 6), for twists ordered (omega, v).

    Ad_T = [[R, 0], [[p]x R, R]], so that hat(Ad_T xi) = T hat(xi) T^-1.
    """
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    out = np.zeros((*T.shape[:-2], 6, 6))
    out[..., :3, :3] = R
    out[..., 3:, 3:] = R
    out[..., 3:, :3] = skew(T[..., :3, 3]) @ R
    return out


def exp_twist(xi: ArrayLike) -> Array:
    """Matrix exponential of twists (omega, v) of any magnitude, shape (..., 6) -> (..., 4, 4)."""
    xi = np.asarray(xi, dtype=float)
    w = xi[..., :3]
    v = xi[..., 3:]
    theta = np.linalg.norm(w, axis=-1)
    small = theta < 1e-9
    th = np.where(small, 1.0, theta)
    # Series-safe coefficients: A = sin/th, B = (1-cos)/th^2, C = (th - sin)/th^3.
    A = np.where(small, 1.0 - theta**2 / 6.0, np.sin(th) / th)
    B = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(th)) / th**2)
    C = np.where(small, 1.0 / 6.0 - theta**2 / 120.0, (th - np.sin(th)) / th**3)
    K = skew(w)
    K2 = K @ K
    eye = np.eye(3)
    R = eye + A[..., None, None] * K + B[..., None, None] * K2
    V = eye + B[..., None, None] * K + C[..., None, None] * K2
    return transform_from_rotation_translation(R, np.einsum("...ij,...j->...i", V, v))


def twist_from_transform_difference(T_plus: ArrayLike, T_minus: ArrayLike, T: ArrayLike,
                                    step: float) -> Array:
    """Central-difference spatial twist: ((T+ - T-) / 2 step) T^-1, read as (omega, v).

    Used to check analytic Jacobians against finite differences.
    """
    dT = (np.asarray(T_plus) - np.asarray(T_minus)) / (2.0 * step)
    M = dT @ invert_transform(T)
    Wsk = 0.5 * (M[..., :3, :3] - np.swapaxes(M[..., :3, :3], -1, -2))
    w = np.stack([Wsk[..., 2, 1], Wsk[..., 0, 2], Wsk[..., 1, 0]], axis=-1)
    return np.concatenate([w, M[..., :3, 3]], axis=-1)
