"""Closed-form IK of a Universal Robots arm: the eight solutions of its DH table.

UR's arms have joints 2, 3 and 4 parallel and a wrist whose axes do not meet, so the
wrist-partitioned closed form does not apply. Their DH table (UR's published one: a = (0, a2,
a3, 0, 0, 0), alpha = (90, 0, 0, 90, -90, 0) deg, d = (d1, 0, 0, d4, d5, d6)) solves in closed
form (K. P. Hawkins, *Analytic inverse kinematics for the Universal Robots UR-5/UR-10 arms*,
Georgia Tech, 2013): joint 1 from the wrist-2 point's distance to axis 1 (two), joint 5 from
the flange's offset along the shoulder normal (two), joint 6 from the flange's rotation,
joints 2 and 3 as a planar two-link arm (two), joint 4 what remains.

`URGeometry.of` reads the six lengths off a screw model and holds them to the model's own FK
at a few configurations: a model not of this form (an imported arm in another base frame, a
calibrated model) gives None, never a near solution.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel, once_per_object
from screwcal.kinematics.se3 import Array, invert_transform

__all__ = ["URGeometry", "ur_closed_form"]

_ALPHA = (np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0)
_CHECK_MM = 1e-6  # the DH table's FK against the model's, at a few configurations
_CHECK_Q = np.array([[0.3, -1.1, 0.7, -0.4, 1.2, 0.5], [-2.0, -0.3, -1.9, 2.2, -0.8, 3.0],
                     [1.4, 0.9, 2.4, 0.1, 0.2, -1.3]])


@dataclass(frozen=True)
class URGeometry:
    """UR's DH lengths (mm)."""

    d1: float
    a2: float
    a3: float
    d4: float
    d5: float
    d6: float

    @staticmethod
    def of(model: SerialModel) -> URGeometry | None:
        """The model's UR lengths, or None when its FK is not that of a UR DH table."""
        return _geometry(model)

    def link(self, i: int, theta: Array) -> Array:
        """DH link transforms A_i (..., 4, 4) for angles theta (...,) rad (i from 1)."""
        a = (0.0, self.a2, self.a3, 0.0, 0.0, 0.0)[i - 1]
        d = (self.d1, 0.0, 0.0, self.d4, self.d5, self.d6)[i - 1]
        ca, sa = np.cos(_ALPHA[i - 1]), np.sin(_ALPHA[i - 1])
        c, s = np.cos(theta), np.sin(theta)
        A = np.zeros((*np.shape(theta), 4, 4))
        A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = c, -s * ca, s * sa, a * c
        A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = s, c * ca, -c * sa, a * s
        A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa, ca, d
        A[..., 3, 3] = 1.0
        return A

    def forward(self, q: Array) -> Array:
        T = self.link(1, q[:, 0])
        for i in range(2, 7):
            T = T @ self.link(i, q[:, i - 1])
        return T


@once_per_object
def _geometry(model: SerialModel) -> URGeometry | None:
    if model.n_joints != 6 or not model.is_revolute.all() or model.joint_zero.any():
        return None
    p, F = model.axis_points_mm, model.home_flange
    geo = URGeometry(d1=float(p[1, 2]), a2=float(p[2, 0] - p[1, 0]),
                     a3=float(p[3, 0] - p[2, 0]), d4=float(-p[4, 1]),
                     d5=float(p[4, 2] - p[5, 2]), d6=float(p[5, 1] - F[1, 3]))
    T_dh = geo.forward(_CHECK_Q)
    T_model = flange_kinematics(model, _CHECK_Q)
    if np.abs(T_dh[:, :3, 3] - T_model[:, :3, 3]).max() > _CHECK_MM or \
            np.abs(T_dh[:, :3, :3] - T_model[:, :3, :3]).max() > 1e-9:
        return None
    return geo


_SIGNS = np.array([1.0, -1.0])


def ur_closed_form(geo: URGeometry, T_flange: Array, branch: int | None = None) -> Array:
    """Joint angles (N, 8, 6) rad reaching flange poses (N, 4, 4), NaN where a branch does not
    exist; the second axis in `ik_solutions.BRANCHES` order: shoulder (the sign before joint
    1's arccos), elbow (joint 3's sign: up is negative, as at UR's usual postures), wrist (no
    flip: joint 5 positive). With `branch` (an index of BRANCHES), that one alone: (N, 1, 6)."""
    T = np.asarray(T_flange, float)
    N = T.shape[0]
    shoulder, elbow, wrist = (slice(None),) * 3 if branch is None else \
        (slice(b, b + 1) for b in (branch // 4, branch // 2 % 2, branch % 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        p5 = T[:, :3, 3] - geo.d6 * T[:, :3, 2]  # the wrist-2 point, on axis 5
        psi = np.arctan2(p5[:, 1], p5[:, 0])
        phi = np.arccos(geo.d4 / np.hypot(p5[:, 0], p5[:, 1]))
        t1 = psi[:, None] + _SIGNS[shoulder] * phi[:, None] + np.pi / 2  # (N, 2)
        s1, c1 = np.sin(t1), np.cos(t1)
        p6 = T[:, :3, 3]
        c5 = (p6[:, 0, None] * s1 - p6[:, 1, None] * c1 - geo.d4) / geo.d6
        t5 = np.arccos(c5)[..., None] * _SIGNS[wrist]  # (N, 2, 2): no flip, flip
        T60 = invert_transform(T)
        X, Y = T60[:, :3, 0], T60[:, :3, 1]  # the base's x and y axes in the flange frame
        s5 = np.sin(t5)
        y6 = (-X[:, 1, None] * s1 + Y[:, 1, None] * c1)[..., None] / s5
        x6 = (X[:, 0, None] * s1 - Y[:, 0, None] * c1)[..., None] / s5
        t6 = np.where(np.abs(s5) < 1e-12, 0.0, np.arctan2(y6, x6))
        t1b = np.broadcast_to(t1[..., None], t5.shape)
        T14 = (invert_transform(geo.link(1, t1b)) @ T[:, None, None]
               @ invert_transform(geo.link(6, t6)) @ invert_transform(geo.link(5, t5)))
        x = T14[..., 0, 3] + geo.d4 * T14[..., 0, 1]  # P13 = T14 (0, -d4, 0, 1)
        y = T14[..., 1, 3] + geo.d4 * T14[..., 1, 1]
        L = np.hypot(x, y)
        c3 = (L ** 2 - geo.a2 ** 2 - geo.a3 ** 2) / (2 * geo.a2 * geo.a3)
        t3 = np.arccos(c3)[..., None] * -_SIGNS[elbow]  # (N, 2, 2, 2): up, down
        t2 = -np.arctan2(y, -x)[..., None] + np.arcsin(geo.a3 * np.sin(t3) / L[..., None])
        T13 = geo.link(2, t2) @ geo.link(3, t3)
        T34 = invert_transform(T13) @ T14[..., None, :, :]
        t4 = np.arctan2(T34[..., 1, 0], T34[..., 0, 0])
    theta = np.empty((*t2.shape, 6))  # shoulder, wrist, elbow
    theta[..., 0] = t1[:, :, None, None]
    theta[..., 1], theta[..., 2], theta[..., 3] = t2, t3, t4
    theta[..., 4] = t5[..., None]
    theta[..., 5] = t6[..., None]
    branches = t2.shape[1] * t2.shape[2] * t2.shape[3]
    out: Array = np.swapaxes(theta, 2, 3).reshape(N, branches, 6)  # shoulder, elbow, wrist
    out[~np.isfinite(out).all(axis=-1)] = np.nan
    return out
