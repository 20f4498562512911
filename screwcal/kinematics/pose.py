"""Pose conversions at the interfaces: (x, y, z, rx, ry, rz) in mm and degrees, 4x4 transforms,
RAPID-style quaternions (w first).

Orientation triples are (rx, ry, rz) with R = Rz(rz) Ry(ry) Rx(rx) (RAPID's EulerZYX), scipy's
intrinsic "ZYX" sequence taken in the order (rz, ry, rx). The conversions are written out (a few
lines each, tested against scipy's Rotation): importing scipy.spatial costs a third of a second
at every start of the command line (it brings the k-d tree and scipy.sparse), more than a whole
`screwcal compensate` of a program needs otherwise.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from screwcal.kinematics.se3 import Array, rotvec_from_rotation, transform_from_rotation_translation

_GIMBAL_TOL = 1e-9  # cos(ry) under this: ry = +-90 deg, rx and rz not separable


def rotation_from_euler_zyx_deg(rxyz_deg: ArrayLike) -> Array:
    """Rotation matrices from (..., 3) triples (rx, ry, rz) in degrees, R = Rz Ry Rx."""
    a = np.radians(np.asarray(rxyz_deg, dtype=float))
    cx, cy, cz = np.cos(a[..., 0]), np.cos(a[..., 1]), np.cos(a[..., 2])
    sx, sy, sz = np.sin(a[..., 0]), np.sin(a[..., 1]), np.sin(a[..., 2])
    R = np.empty((*a.shape[:-1], 3, 3))
    R[..., 0, 0], R[..., 0, 1] = cz * cy, cz * sy * sx - sz * cx
    R[..., 0, 2], R[..., 1, 0] = cz * sy * cx + sz * sx, sz * cy
    R[..., 1, 1], R[..., 1, 2] = sz * sy * sx + cz * cx, sz * sy * cx - cz * sx
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = -sy, cy * sx, cy * cx
    return R


def euler_zyx_deg_from_rotation(R: ArrayLike) -> Array:
    """(rx, ry, rz) in degrees, shape (..., 3), from rotation matrices (..., 3, 3).

    ry lies in [-90, 90]; at ry = +-90 (gimbal lock) rx is set to 0 and rz carries the rest.
    """
    R = np.asarray(R, dtype=float)
    cy = np.hypot(R[..., 0, 0], R[..., 1, 0])
    ry = np.arctan2(-R[..., 2, 0], cy)
    lock = cy < _GIMBAL_TOL
    rx = np.where(lock, 0.0, np.arctan2(R[..., 2, 1], R[..., 2, 2]))
    rz = np.where(lock, np.arctan2(-R[..., 0, 1], R[..., 1, 1]),
                  np.arctan2(R[..., 1, 0], R[..., 0, 0]))
    angles_deg: Array = np.degrees(np.stack([rx, ry, rz], axis=-1))
    return angles_deg


def euler_zyx_deg_near(R: ArrayLike, reference_deg: ArrayLike) -> Array:
    """(rx, ry, rz) of rotations (..., 3, 3) on the ZYX triple nearest `reference_deg`.

    Every rotation has two triples, (rx, ry, rz) and (rx + 180, 180 - ry, rz + 180): e.g.
    flange-down is both (180, 0, 180) and (0, 180, 0). Angle by angle comparisons (ISO 9283's
    APa/b/c) need the one nearest the commanded triple, each angle unwrapped to within 180 deg.
    """
    ref = np.asarray(reference_deg, dtype=float)
    a = euler_zyx_deg_from_rotation(R)
    b = a + np.array([180.0, 0.0, 180.0])
    b[..., 1] = 180.0 - a[..., 1]

    def near(t: Array) -> Array:
        wrapped: Array = ref + (t - ref + 180.0) % 360.0 - 180.0
        return wrapped

    a, b = near(a), near(b)
    pick_b = np.sum(np.abs(b - ref), axis=-1) < np.sum(np.abs(a - ref), axis=-1)
    return np.where(pick_b[..., None], b, a)


def transform_from_pose(pose: ArrayLike) -> Array:
    """4x4 transforms from poses (..., 6) = (x, y, z [mm], rx, ry, rz [deg])."""
    pose = np.asarray(pose, dtype=float)
    if pose.shape[-1] != 6:
        raise ValueError(f"a pose has 6 values (x, y, z, rx, ry, rz); got shape {pose.shape}")
    return transform_from_rotation_translation(rotation_from_euler_zyx_deg(pose[..., 3:]),
                                               pose[..., :3])


def pose_from_transform(T: ArrayLike) -> Array:
    """Poses (..., 6) = (x, y, z [mm], rx, ry, rz [deg]) from 4x4 transforms (..., 4, 4)."""
    T = np.asarray(T, dtype=float)
    return np.concatenate([T[..., :3, 3], euler_zyx_deg_from_rotation(T[..., :3, :3])], axis=-1)


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


def rotation_from_quaternion_wxyz(q_wxyz: ArrayLike) -> Array:
    """Rotation matrices from quaternions (..., 4) ordered (w, x, y, z); normalised first."""
    q = np.asarray(q_wxyz, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty((*q.shape[:-1], 3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), \
        2 * (x * z + y * w)
    R[..., 1, 0], R[..., 1, 1], R[..., 1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), \
        2 * (y * z - x * w)
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), \
        1 - 2 * (x * x + y * y)
    return R


def rotation_angle_deg(R_a: ArrayLike, R_b: ArrayLike) -> Array:
    """Angle in degrees of the relative rotation R_a^T R_b, shape (...)."""
    R_rel = np.swapaxes(np.asarray(R_a, float), -1, -2) @ np.asarray(R_b, float)
    angle_deg: Array = np.degrees(np.linalg.norm(rotvec_from_rotation(R_rel), axis=-1))
    return angle_deg
