"""Denavit-Hartenberg tables <-> the screw model (thesis Annex A, Eq. A.1-A.2).

Conventions
-----------
- "dh" (standard, Annex A): A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i); joint i turns about
  (or slides along) z_{i-1}.
- "mdh" (modified, Craig): A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i); joint i turns
  about z_i. Row i carries (alpha_{i-1}, a_{i-1}, theta_i, d_i), and Hayati's beta_{i-1} (the
  thesis's "DHM", 2.2.1.1) for a pair of (nearly) parallel axes: A_i = Tx(a_{i-1})
  Rx(alpha_{i-1}) Ry(beta_{i-1}) Rz(theta_i) Tz(d_i), equal to Craig's form when beta = 0. There
  x_{i-1} points to where axis i crosses the plane normal to z_{i-1} through frame i-1's origin,
  instead of along the common normal that runs off to infinity as the axes turn parallel.

The chain is T_robot_flange = dh_base . prod_i A_i(q_i + zero_i) . dh_flange, where `theta`
(revolute) or `d` (prismatic) holds the value at q = 0. DH frames are not unique; from a screw
model this module picks frame 0 at the foot of the robot origin on axis 1, x along the common
normal (a >= 0), d = 0 where axes are parallel, and the last frame on the last axis at the
flange's height. Near-parallel axes give large d in standard DH: the discontinuity the thesis
describes (2.2.1.1); `dh_from_model` refuses such a table (`DegenerateTableError`) and names the
modified form with Hayati's beta, which `dh_from_model(..., "mdh")` uses for every pair of axes
within `HAYATI_DEG` of parallel.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import DegenerateTableError, ModelError
from screwcal.kinematics.model import PRISMATIC, SerialModel
from screwcal.kinematics.se3 import Array, invert_transform, transform_from_rotation_translation

Convention = Literal["dh", "mdh"]
_PARALLEL_TOL = 1e-9
_DIST_TOL = 1e-9
HAYATI_DEG = 5.0  # mdh: consecutive axes closer than this to parallel take a beta
DEGENERATE_RATIO = 10.0  # dh: an offset this many times the robot's size is refused


@dataclass(frozen=True)
class DHRow:
    """One row of a DH table, numeric units (mm, rad). For "mdh", `a_mm`/`alpha` are a_{i-1},
    alpha_{i-1}."""

    a_mm: float
    alpha: float
    d_mm: float
    theta: float
    joint_type: str = "R"
    beta: float = 0.0  # Hayati's rotation about y_{i-1}, "mdh" only (rad)


@dataclass(frozen=True)
class DHTable:
    convention: Convention
    rows: tuple[DHRow, ...]
    dh_base: Array  # robot base <- DH frame 0, (4, 4)
    dh_flange: Array  # DH frame n <- flange, (4, 4)


def _rot_x(a: Array) -> Array:
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*np.shape(a), 4, 4))
    R[..., 0, 0] = 1
    R[..., 1, 1], R[..., 1, 2], R[..., 2, 1], R[..., 2, 2] = c, -s, s, c
    R[..., 3, 3] = 1
    return R


def _rot_y(a: Array) -> Array:
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*np.shape(a), 4, 4))
    R[..., 0, 0], R[..., 0, 2], R[..., 2, 0], R[..., 2, 2] = c, s, -s, c
    R[..., 1, 1] = 1
    R[..., 3, 3] = 1
    return R


def _rot_z(a: Array) -> Array:
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*np.shape(a), 4, 4))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1] = c, -s, s, c
    R[..., 2, 2] = 1
    R[..., 3, 3] = 1
    return R


def _trans(axis: int, d: Array) -> Array:
    T = np.zeros((*np.shape(d), 4, 4))
    T[..., :, :] = np.eye(4)
    T[..., axis, 3] = d
    return T


def dh_link_transform(convention: Convention, row: DHRow, value: ArrayLike) -> Array:
    """A_i for joint values (N,) (rad or mm, zero already added): (N, 4, 4). Eq. A.1."""
    v = np.asarray(value, dtype=float)
    theta = row.theta + (v if row.joint_type == "R" else 0.0)
    d = row.d_mm + (v if row.joint_type == PRISMATIC else 0.0)
    theta = np.broadcast_to(theta, v.shape)
    d = np.broadcast_to(d, v.shape)
    if convention == "dh":
        return _rot_z(theta) @ _trans(2, d) @ _trans(0, np.full(v.shape, row.a_mm)) @ _rot_x(
            np.full(v.shape, row.alpha))
    A = _rot_x(np.full(v.shape, row.alpha)) @ _trans(0, np.full(v.shape, row.a_mm))
    if row.beta:
        A = A @ _rot_y(np.full(v.shape, row.beta))
    return A @ _rot_z(theta) @ _trans(2, d)


def dh_forward_kinematics(table: DHTable, q: ArrayLike, joint_zero: ArrayLike | None = None
                          ) -> Array:
    """Flange pose in the robot base frame from a DH table, (N, n) -> (N, 4, 4). Eq. A.2."""
    q = np.asarray(q, dtype=float)
    zero = np.zeros(q.shape[1]) if joint_zero is None else np.asarray(joint_zero, float)
    T = np.broadcast_to(table.dh_base, (q.shape[0], 4, 4))
    for i, row in enumerate(table.rows):
        T = T @ dh_link_transform(table.convention, row, q[:, i] + zero[i])
    return T @ table.dh_flange


def model_from_dh(table: DHTable, name: str, limits: ArrayLike, joint_zero: ArrayLike | None = None,
                  base: ArrayLike | None = None, tool: ArrayLike | None = None) -> SerialModel:
    """The screw model equivalent to a DH table: joint axes and home flange read off the frames
    at q = 0."""
    n = len(table.rows)
    zero_q = np.zeros(1)
    F = table.dh_base.copy()
    dirs, points = np.zeros((n, 3)), np.zeros((n, 3))
    for i, row in enumerate(table.rows):
        A = dh_link_transform(table.convention, row, zero_q)[0]
        if table.convention == "dh":
            axis_frame = F  # joint i moves about z_{i-1}
            F = F @ A
        else:
            F = F @ A
            axis_frame = F  # joint i moves about z_i
        dirs[i] = axis_frame[:3, 2]
        points[i] = axis_frame[:3, 3]
    M = F @ table.dh_flange
    zero = np.zeros(n) if joint_zero is None else np.asarray(joint_zero, float)
    return SerialModel(name=name, joint_types=tuple(r.joint_type for r in table.rows),
                       axis_dirs=dirs, axis_points_mm=points, home_flange=M,
                       limits=np.asarray(limits, float),
                       joint_zero=zero,
                       base=np.eye(4) if base is None else np.asarray(base, float),
                       tool=np.eye(4) if tool is None else np.asarray(tool, float))


def _unit(v: Array) -> Array:
    return v / np.linalg.norm(v)


def _common_normal(p1: Array, d1: Array, p2: Array, d2: Array) -> tuple[Array, Array] | None:
    """Feet (on line 1, on line 2) of the common normal of two lines, or None when parallel."""
    c = np.cross(d1, d2)
    if np.linalg.norm(c) < _PARALLEL_TOL:
        return None
    # Solve p1 + s d1 + k c = p2 + t d2 for (s, t, k).
    s, t, _ = np.linalg.solve(np.column_stack([d1, -d2, c]), p2 - p1)
    return p1 + s * d1, p2 + t * d2


def _foot(point: Array, p: Array, d: Array) -> Array:
    """Foot of the perpendicular from `point` onto the line (p, d)."""
    foot: Array = p + np.dot(point - p, d) * d
    return foot


def _perp_unit(v: Array, z: Array, fallback: Array) -> Array:
    """v made perpendicular to unit z and normalised; `fallback` (then x, y) when v is along z."""
    for cand in (v, fallback, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
        w = cand - np.dot(cand, z) * z
        if np.linalg.norm(w) > 1e-6:
            return _unit(w)
    raise ModelError("cannot build a DH frame: degenerate axis")  # unreachable for unit z


def _normal_direction(f1: Array, f2: Array, z_a: Array, z_b: Array, x_prev: Array) -> Array:
    """x along the common normal from f1 to f2; for intersecting axes, +-z_a x z_b closest to
    x_prev."""
    if np.linalg.norm(f2 - f1) > _DIST_TOL:
        return _unit(f2 - f1)
    x = _unit(np.cross(z_a, z_b))
    return x if np.dot(x, x_prev) >= 0 else -x


def _frame(x: Array, z: Array, origin: Array) -> Array:
    return transform_from_rotation_translation(np.column_stack([x, np.cross(z, x), z]), origin)


def _angle_about(a: Array, b: Array, axis: Array) -> float:
    return float(np.arctan2(np.dot(np.cross(a, b), axis), np.dot(a, b)))


def dh_from_model(model: SerialModel, convention: Convention = "dh") -> DHTable:
    """A DH (or modified DH) table equivalent to the model's flange kinematics."""
    n = model.n_joints
    w = model.axis_dirs
    p = model.axis_points_mm
    # Frame 0: z on axis 1, origin at the foot of the robot origin, x the robot's x made normal.
    z0 = w[0]
    o0 = _foot(np.zeros(3), p[0], z0)
    x0 = _perp_unit(np.array([1.0, 0, 0]), z0, np.array([0, 1.0, 0]))
    frames = [_frame(x0, z0, o0)]
    rows: list[DHRow] = []
    if convention == "dh":
        for i in range(1, n + 1):
            Fp = frames[-1]
            xp, zp, op = Fp[:3, 0], Fp[:3, 2], Fp[:3, 3]
            if i < n:
                z = w[i]
                feet = _common_normal(op, zp, p[i], z)
                if feet is None:  # parallel: take d = 0
                    o = _foot(op, p[i], z)
                    x = _perp_unit(o - op, zp, xp) if np.linalg.norm(o - op) > _DIST_TOL else xp
                else:
                    o = feet[1]
                    x = _normal_direction(feet[0], feet[1], zp, z, xp)
            else:  # last frame: on axis n, at the flange's height, parallel to frame n-1
                z, x = zp, xp
                o = op + np.dot(model.home_flange[:3, 3] - op, zp) * zp
            frames.append(_frame(x, z, o))
            rows.append(DHRow(a_mm=float(np.dot(o - op, x)), alpha=_angle_about(zp, z, x),
                              d_mm=float(np.dot(o - op, zp)), theta=_angle_about(xp, x, zp),
                              joint_type=model.joint_types[i - 1]))
    else:
        _mdh_frames(model, frames, rows)
    dh_flange = invert_transform(frames[-1]) @ model.home_flange
    if convention == "dh":
        _refuse_degenerate(model, rows, w)
    return DHTable(convention=convention, rows=tuple(rows), dh_base=frames[0], dh_flange=dh_flange)


def _refuse_degenerate(model: SerialModel, rows: list[DHRow], w: Array) -> None:
    """Standard DH of (nearly, not exactly) parallel axes puts the common normal where the axes
    meet, far off: refuse offsets beyond DEGENERATE_RATIO times the robot's size."""
    size = max(1.0, float(np.abs(model.axis_points_mm).max()),
               float(np.linalg.norm(model.home_flange[:3, 3])))
    for i, r in enumerate(rows):
        worst = max(abs(r.a_mm), abs(r.d_mm))
        if worst > DEGENERATE_RATIO * size:
            j = min(i + 1, len(rows) - 1)  # row i's d and a come from axes i+1 and i+2's normal
            angle = np.degrees(np.arcsin(min(1.0, float(np.linalg.norm(np.cross(w[j - 1], w[j]))))))
            raise DegenerateTableError(
                f"model '{model.name}': standard DH needs an offset of {worst:.3g} mm at joint "
                f"{i + 1} (axes {j} and {j + 1} are {angle:.3g} deg from parallel, so their "
                f"common normal lies far outside the {size:.0f} mm robot); use the modified DH "
                "table with Hayati's beta (mdh), or the screw table (screws), instead")


def _mdh_frames(model: SerialModel, frames: list[Array], rows: list[DHRow]) -> None:
    """Frames 1..n of the modified table on their own axes, x_i along the common normal to axis
    i + 1, or for axes within HAYATI_DEG of parallel towards where axis i + 1 crosses the plane
    normal to z_i (Hayati's beta then takes the tilt)."""
    n, w, p = model.n_joints, model.axis_dirs, model.axis_points_mm
    near = np.sin(np.radians(HAYATI_DEG))
    cross_pt: Array | None = None  # where x_{i-1} meets axis i
    hayati = False  # whether the pair (i-1, i) takes a beta
    for i in range(n):
        Fp = frames[-1]
        xp, zp, op = Fp[:3, 0], Fp[:3, 2], Fp[:3, 3]
        z = w[i]
        h = cross_pt if cross_pt is not None else op + np.dot(_foot(op, p[i], z) - op, xp) * xp
        next_hayati = False
        if i < n - 1:
            zn, pn = w[i + 1], p[i + 1]
            feet = None if np.linalg.norm(np.cross(z, zn)) < near else \
                _common_normal(p[i], z, pn, zn)
            if feet is None:  # parallel (or nearly: Hayati's case)
                o = h
                cross_pt = pn + np.dot(o - pn, z) / np.dot(zn, z) * zn
                x = _unit(cross_pt - o) if np.linalg.norm(cross_pt - o) > _DIST_TOL else \
                    _perp_unit(xp, z, xp)
                next_hayati = True
            else:
                o, cross_pt = feet
                x = _normal_direction(o, cross_pt, z, zn, xp)
        else:
            o, x = h, _perp_unit(xp, z, xp)
        frames.append(_frame(x, z, o))
        a = float(np.dot(h - op, xp))
        if hayati:  # Eq. of the Hayati row: z_i = Rx(alpha) Ry(beta) e_z in frame i-1
            z_rel = Fp[:3, :3].T @ z
            beta = float(np.arcsin(np.clip(z_rel[0], -1.0, 1.0)))
            alpha = float(np.arctan2(-z_rel[1], z_rel[2]))
            c, s = np.cos(alpha), np.sin(alpha)
            x_tilted = Fp[:3, :3] @ np.array([np.cos(beta), s * np.sin(beta),
                                              -c * np.sin(beta)])
        else:
            beta, alpha, x_tilted = 0.0, _angle_about(zp, z, xp), xp
        rows.append(DHRow(a_mm=a, alpha=alpha, d_mm=float(np.dot(o - h, z)),
                          theta=_angle_about(x_tilted, x, z), joint_type=model.joint_types[i],
                          beta=beta))
        hayati = next_hayati
