"""The closed-form inverse kinematics of an ideal ABB-type 6R arm (wrist-partitioned geometry).

Joint 1 about z; joints 2, 3 about y with their axes in the plane y = 0 (shoulder offset
allowed); a spherical wrist x-y-x whose centre lies on axis 4 at home: the nominal IRB 1600 and
IRB 120. The wrist centre fixes joints 1-3 (four arms: shoulder front/back x elbow up/down), the
rest of the rotation fixes joints 4-6 (the wrist as it is, and flipped): eight branches in the
order of `ik_solutions.BRANCHES`.

In the arm plane a vector (x, z) is the complex number x + i z; Ry(t) turns it by -t.
"""

from __future__ import annotations

import cmath
import math
import weakref
from dataclasses import dataclass

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.model import SerialModel, once_per_object
from screwcal.kinematics.se3 import Array, Mask

IDEAL_AXES = np.array([[0, 0, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]], float)


_GEOMETRY: weakref.WeakKeyDictionary[SerialModel, dict[float | None, WristPartitionedGeometry]] \
    = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class WristPartitionedGeometry:
    """Lengths of an ABB-type arm read off a screw model (mm), plus its home flange rotation."""

    shoulder_x: float  # joint-2 axis, x at home
    shoulder_z: float  # joint-2 axis, z at home
    upper_arm: complex  # joint 2 -> joint 3 in the arm plane, x + i z
    forearm: complex  # joint 3 -> wrist centre in the arm plane, x + i z
    wrist_home: Array  # wrist centre at home (3,)
    home_flange: Array  # (4, 4)

    @classmethod
    def from_model(cls, model: SerialModel, tol: float | None = 1e-9) -> WristPartitionedGeometry:
        """Read the geometry; with `tol` None, project a near-ideal (calibrated) model onto the
        ideal structure instead of refusing it. Read once per model object and tolerance."""
        per_model = _GEOMETRY.setdefault(model, {})
        if tol not in per_model:
            per_model[tol] = cls._read(model, tol)
        return per_model[tol]

    @classmethod
    def _read(cls, model: SerialModel, tol: float | None) -> WristPartitionedGeometry:
        if model.n_joints != 6 or not model.is_revolute.all():
            raise ModelError(f"model '{model.name}': the closed-form IK needs 6 revolute joints")
        p = model.axis_points_mm
        wrist = np.array([p[4, 0], 0.0, p[3, 2]])
        if tol is not None:
            # np.allclose's test (atol tol, rtol 1e-5) for all six axes in one array call
            close = np.abs(model.axis_dirs - IDEAL_AXES) <= tol + 1e-5 * np.abs(IDEAL_AXES)
            wrong = (np.flatnonzero(~close.all(axis=1)) + 1).tolist()
            off_plane = (np.flatnonzero(np.abs(p[1:, 1]) > tol) + 2).tolist()
            if wrong or off_plane or abs(p[5, 2] - p[3, 2]) > tol:
                raise ModelError(
                    f"model '{model.name}' is not an ideal ABB-type arm (axes z,y,y,x,y,x in the "
                    f"plane y = 0, wrist axes meeting); joints {sorted(set(wrong + off_plane))} "
                    "differ: use numerical_ik")
        return cls(shoulder_x=float(p[1, 0]), shoulder_z=float(p[1, 2]),
                   upper_arm=complex(p[2, 0] - p[1, 0], p[2, 2] - p[1, 2]),
                   forearm=complex(wrist[0] - p[2, 0], wrist[2] - p[2, 2]),
                   wrist_home=wrist, home_flange=model.home_flange.copy())

_GIMBAL_TOL = 1e-12
# Per arm branch (front up, front down, back up, back down): joint 1 turned by pi for "back",
# the elbow's bend signed.
_ARM_T1_OFFSET = np.array([0.0, 0.0, np.pi, np.pi])
_ARM_ELBOW_SIGN = np.array([1.0, -1.0, 1.0, -1.0])
_SLACK = 1e-12
_NAN_ROWS = (math.nan,) * 24  # a shoulder's four branches
_SHOULDER_T1_OFFSET = tuple(_ARM_T1_OFFSET[::2].tolist())  # per shoulder (front, back)
_ELBOW_SIGN = tuple(_ARM_ELBOW_SIGN[:2].tolist())  # per elbow (up, down)


def closed_form_one(geo: WristPartitionedGeometry, T: Array) -> tuple[Array, Mask]:
    """`closed_form_theta` for one flange target (4, 4) in scalar arithmetic: the same
    formulas, a fraction of the array calls' overhead (a test holds the two equal). Returns
    theta (1, 8, 6) and reach (1, 8)."""
    o, R_M, (au, af, pu, pf) = _one_target_tables(geo)
    (r00, r01, r02, px), (r10, r11, r12, py), (r20, r21, r22, pz), _ = T.tolist()
    wx = px - (r00 * o[0] + r01 * o[1] + r02 * o[2])
    wy = py - (r10 * o[0] + r11 * o[1] + r12 * o[2])
    wz = pz - (r20 * o[0] + r21 * o[1] + r22 * o[2])
    M0, M1, M2 = ([a0 * m0 + a1 * m1 + a2 * m2 for m0, m1, m2 in R_M]  # R R_M^T
                  for a0, a1, a2 in ((r00, r01, r02), (r10, r11, r12), (r20, r21, r22)))
    u, f = geo.upper_arm, geo.forearm
    theta: list[float] = []
    reach: list[bool] = []
    base = math.atan2(wy, wx)
    for t1_offset in _SHOULDER_T1_OFFSET:  # front, back; each with the elbow up, then down
        t1 = base + t1_offset
        c1, s1 = math.cos(t1), math.sin(t1)
        d = complex(wx * c1 + wy * s1 - geo.shoulder_x, wz - geo.shoulder_z)
        k = (abs(d) ** 2 - au * au - af * af) / (2.0 * au * af)
        if abs(k) > 1.0 + _SLACK:
            theta += _NAN_ROWS
            reach += (False,) * 4
            continue
        bend, phase_d = math.acos(min(1.0, max(-1.0, k))), cmath.phase(d)
        for elbow in _ELBOW_SIGN:
            t3 = elbow * bend - pu + pf
            t2 = cmath.phase(u + f * cmath.exp(-1j * t3)) - phase_d
            c23, s23 = math.cos(t2 + t3), math.sin(t2 + t3)
            # W = (Rz(t1) Ry(t23))^T M: the rows of R123^T are R123's columns
            a0, a1, a2 = c1 * c23, s1 * c23, -s23
            w00 = a0 * M0[0] + a1 * M1[0] + a2 * M2[0]
            w01 = a0 * M0[1] + a1 * M1[1] + a2 * M2[1]
            w02 = a0 * M0[2] + a1 * M1[2] + a2 * M2[2]
            w10 = c1 * M1[0] - s1 * M0[0]
            a0, a1, a2 = c1 * s23, s1 * s23, c23
            w20 = a0 * M0[0] + a1 * M1[0] + a2 * M2[0]
            wb = math.acos(min(1.0, max(-1.0, w00)))
            if abs(math.sin(wb)) < _GIMBAL_TOL:  # only a +- c defined: c = 0 (as closed_form_theta)
                w11 = c1 * M1[1] - s1 * M0[1]
                if w00 > 0:
                    wa = math.atan2(a0 * M0[1] + a1 * M1[1] + a2 * M2[1], w11)
                else:
                    wa = math.atan2(c1 * M1[2] - s1 * M0[2], w11)
                wc = 0.0
            else:
                wa, wc = math.atan2(w10, -w20), math.atan2(w01, w02)
            theta += (t1, t2, t3, wa, wb, wc, t1, t2, t3, wa + math.pi, -wb, wc + math.pi)
            reach += (True, True)  # the wrist as it is, then flipped
    return np.array(theta).reshape(1, 8, 6), np.array(reach).reshape(1, 8)


@once_per_object
def _one_target_tables(geo: WristPartitionedGeometry
                       ) -> tuple[list[float], list[list[float]], tuple[float, ...]]:
    """As Python floats: the home offset of the flange from the wrist centre in the flange
    frame, the home flange rotation R_M, and the upper arm's and forearm's lengths and angles
    in the arm plane."""
    R_M = geo.home_flange[:3, :3]
    o = R_M.T @ (geo.home_flange[:3, 3] - geo.wrist_home)
    u, f = geo.upper_arm, geo.forearm
    return o.tolist(), R_M.tolist(), (abs(u), abs(f), cmath.phase(u), cmath.phase(f))


def closed_form_theta(geo: WristPartitionedGeometry, T_flange: Array, slack: float = _SLACK,
                      elbow_floor: float = 0.0, branch: int | None = None
                      ) -> tuple[Array, Mask]:
    """Joint angles (N, 8, 6) of the ideal geometry and the reachable mask (N, 8); with
    `branch` (an index of `ik_solutions.BRANCHES`), that branch alone: (N, 1, 6) and (N, 1).

    For seeding a calibrated model: `slack` accepts targets slightly beyond full extension, and
    `elbow_floor` (rad) keeps the elbow-up and elbow-down seeds apart near it, so that each
    converges to its own branch.

    The formulas of `closed_form_one` over arrays (N, arms), element by element: the wrist's
    rotation W's five entries that its angles need, no 3x3 products per arm.
    """
    N = T_flange.shape[0]
    arms = slice(None) if branch is None else slice(branch // 2, branch // 2 + 1)
    o, R_M, (au, af, pu, pf) = _one_target_tables(geo)
    R = T_flange[:, :3, :3]
    M = R @ np.array(R_M).T  # R R_M^T: W = (Rz(t1) Ry(t2 + t3))^T M = Rx(t4) Ry(t5) Rx(t6)
    # Wrist centre: the flange carries the home offset (flange - wrist centre) rigidly.
    wc = T_flange[:, :3, 3] - R @ np.array(o)
    # The arms (shoulder front/back x elbow up/down), (N, arms); BRANCHES order.
    t1 = np.arctan2(wc[:, 1], wc[:, 0])[:, None] + _ARM_T1_OFFSET[arms]
    c1, s1 = np.cos(t1), np.sin(t1)
    dx = wc[:, 0, None] * c1 + wc[:, 1, None] * s1 - geo.shoulder_x
    dz = np.broadcast_to(wc[:, 2, None] - geo.shoulder_z, dx.shape)
    k = (dx * dx + dz * dz - au * au - af * af) / (2.0 * au * af)
    ok = np.abs(k) <= 1.0 + slack
    bend = np.maximum(np.arccos(np.clip(k, -1.0, 1.0)), elbow_floor)
    t3 = _ARM_ELBOW_SIGN[arms] * bend - pu + pf
    u, f = geo.upper_arm, geo.forearm
    c3, s3 = np.cos(t3), np.sin(t3)  # u + f exp(-i t3), its angle less d's
    t2 = np.arctan2(u.imag + f.imag * c3 - f.real * s3, u.real + f.real * c3 + f.imag * s3) \
        - np.arctan2(dz, dx)
    c23, s23 = np.cos(t2 + t3), np.sin(t2 + t3)
    m = [[M[:, i, j, None] for j in range(3)] for i in range(3)]
    # the rows of R123^T are R123's columns: (c1 c23, s1 c23, -s23), (-s1, c1, 0),
    # (c1 s23, s1 s23, c23)
    a0, a1, a2 = c1 * c23, s1 * c23, -s23
    w00 = a0 * m[0][0] + a1 * m[1][0] + a2 * m[2][0]
    w01 = a0 * m[0][1] + a1 * m[1][1] + a2 * m[2][1]
    w02 = a0 * m[0][2] + a1 * m[1][2] + a2 * m[2][2]
    w10 = c1 * m[1][0] - s1 * m[0][0]
    b0, b1 = c1 * s23, s1 * s23
    w20 = b0 * m[0][0] + b1 * m[1][0] + c23 * m[2][0]
    wb = np.arccos(np.clip(w00, -1.0, 1.0))
    wa, wc6 = np.arctan2(w10, -w20), np.arctan2(w01, w02)
    lock = np.abs(np.sin(wb)) < _GIMBAL_TOL  # only a +- c defined: c = 0 (scipy's convention
    if lock.any():  # for intrinsic angles)
        w11 = c1 * m[1][1] - s1 * m[0][1]
        w21 = b0 * m[0][1] + b1 * m[1][1] + c23 * m[2][1]
        w12 = c1 * m[1][2] - s1 * m[0][2]
        straight = lock & (w00 > 0)  # b = 0: W = Rx(a + c)
        wa = np.where(straight, np.arctan2(w21, w11), wa)
        wa = np.where(lock & ~straight, np.arctan2(w12, w11), wa)  # b = pi
        wc6 = np.where(lock, 0.0, wc6)
    A = t1.shape[1]
    theta: Array = np.empty((N, A, 2, 6))
    theta[:, :, :, 0] = t1[:, :, None]
    theta[:, :, :, 1] = t2[:, :, None]
    theta[:, :, :, 2] = t3[:, :, None]
    theta[:, :, 0, 3], theta[:, :, 0, 4], theta[:, :, 0, 5] = wa, wb, wc6
    theta[:, :, 1, 3], theta[:, :, 1, 4], theta[:, :, 1, 5] = wa + np.pi, -wb, wc6 + np.pi
    reach = np.repeat(ok, 2, axis=1)
    theta = theta.reshape(N, 2 * A, 6)
    if branch is not None:
        theta, reach = theta[:, branch % 2, None], reach[:, branch % 2, None]
    theta[~reach] = np.nan
    return theta, reach
