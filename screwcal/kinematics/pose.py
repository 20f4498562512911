"""Pose conversions at the interfaces: (x, y, z, rx, ry, rz) in mm and degrees, 4x4 transforms,
RAPID-style quaternions (w first).

Orientation triples are (rx, ry, rz) with R = Rz(rz) Ry(ry) Rx(rx) (RAPID's EulerZYX), scipy's
intrinsic "ZYX" sequence taken in the order (rz, ry, rx). The conversions are written out (a few
lines each, tested against scipy's Rotation): importing scipy.spatial costs a third of a second
at every start of the command line (it brings the k-d tree and scipy.sparse), more than a whole
`screwcal compensate` of a program needs otherwise.
"""

from __future__ import annotations

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
