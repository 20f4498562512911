"""Pose conversions at the interfaces: (x, y, z, rx, ry, rz) in mm and degrees, 4x4 transforms,
RAPID-style quaternions (w first).

Orientation triples are (rx, ry, rz) with R = Rz(rz) Ry(ry) Rx(rx) (RAPID's EulerZYX), which is
scipy's intrinsic "ZYX" sequence taken in the order (rz, ry, rx).
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from screwcal.kinematics.se3 import Array, transform_from_rotation_translation


def rotation_from_euler_zyx_deg(rxyz_deg: ArrayLike) -> Array:
    """Rotation matrices from (..., 3) triples (rx, ry, rz) in degrees, R = Rz Ry Rx."""
    rxyz = np.asarray(rxyz_deg, dtype=float)
    flat = rxyz.reshape(-1, 3)
    R = Rotation.from_euler("ZYX", flat[:, ::-1], degrees=True).as_matrix()
    return R.reshape((*rxyz.shape[:-1], 3, 3))


def euler_zyx_deg_from_rotation(R: ArrayLike) -> Array:
    """(rx, ry, rz) in degrees, shape (..., 3), from rotation matrices (..., 3, 3).

    ry lies in [-90, 90]; at ry = +-90 (gimbal lock) rx is set to 0 and rz carries the rest.
    """
    R = np.asarray(R, dtype=float)
    flat = R.reshape(-1, 3, 3)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected")
        zyx = Rotation.from_matrix(flat).as_euler("ZYX", degrees=True)
    return zyx[:, ::-1].reshape((*R.shape[:-2], 3))


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
        return ref + (t - ref + 180.0) % 360.0 - 180.0

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
    """Unit quaternions (w, x, y, z), w >= 0 as RAPID's orient, from rotations (..., 3, 3)."""
    R = np.asarray(R, dtype=float)
    q = Rotation.from_matrix(R.reshape(-1, 3, 3)).as_quat(canonical=True, scalar_first=True)
    return q.reshape((*R.shape[:-2], 4))


def rotation_from_quaternion_wxyz(q_wxyz: ArrayLike) -> Array:
    """Rotation matrices from quaternions (..., 4) ordered (w, x, y, z); normalised first."""
    q = np.asarray(q_wxyz, dtype=float)
    R = Rotation.from_quat(q.reshape(-1, 4), scalar_first=True).as_matrix()
    return R.reshape((*q.shape[:-1], 3, 3))


def rotation_angle_deg(R_a: ArrayLike, R_b: ArrayLike) -> Array:
    """Angle in degrees of the relative rotation R_a^T R_b, shape (...)."""
    R_rel = np.swapaxes(np.asarray(R_a, float), -1, -2) @ np.asarray(R_b, float)
    angle = Rotation.from_matrix(R_rel.reshape(-1, 3, 3)).magnitude()
    return np.degrees(angle).reshape(R_rel.shape[:-2])
