"""ABB robot configuration data (`confdata`: cf1, cf4, cf6, cfx) of joint solutions, and the
solution a confdata names.

cf1, cf4, cf6 are the quadrants of axes 1, 4 and 6 (floor of the angle over 90 deg: 0 for
[0, 90), -1 for [-90, 0), ...). cfx numbers the arm configuration of an ABB serial arm (RAPID
reference, `confdata`): 4 x (wrist centre behind axis 1) + 2 x (wrist centre behind the lower
arm) + (axis 5 negative). It is computed from the geometry of the solution, not from a branch
label: the wrist centre (where axes 4 and 5 meet) against the line of axis 1 along the arm's
heading, and against the lower arm (axis 2 to axis 3) in the arm's plane.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from screwcal.errors import UnreachableError
from screwcal.kinematics.forward import joint_axis_lines, spatial_jacobian
from screwcal.kinematics.ik import closed_form_ik
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, cross

QUADRANT_RAD = np.pi / 2
TOL_RAD = 1e-5  # a joint this close (0.0006 deg) to a quadrant edge, or joint 5 to zero, is on it


def _meeting_point(p1: Array, d1: Array, p2: Array, d2: Array) -> Array:
    """The midpoint of the common perpendicular of two lines (N, 3)."""
    n = cross(d1, d2)
    nn = np.sum(n * n, axis=-1)
    t1 = np.sum(cross(p2 - p1, d2) * n, axis=-1) / nn
    t2 = np.sum(cross(p2 - p1, d1) * n, axis=-1) / nn
    midpoint: Array = 0.5 * (p1 + t1[:, None] * d1 + p2 + t2[:, None] * d2)
    return midpoint


def _arm_bits(model: SerialModel, q: Array) -> NDArray[np.int_]:
    """4 x (wrist centre behind axis 1) + 2 x (wrist centre behind the lower arm), (N,)."""
    w, p = joint_axis_lines(model, q, joints=5)
    wrist = _meeting_point(p[:, 3], w[:, 3], p[:, 4], w[:, 4])
    up = w[:, 0]  # axis 1
    heading = cross(w[:, 1], up)  # forward along the arm: axis 2 x axis 1 (x at home)
    heading /= np.linalg.norm(heading, axis=-1, keepdims=True)
    behind_axis1 = np.sum((wrist - p[:, 0]) * heading, axis=-1) < 0.0

    def plane(x: Array) -> tuple[Array, Array]:  # (along the heading, along axis 1)
        return np.sum(x * heading, axis=-1), np.sum(x * up, axis=-1)

    # axis 2 and 3 points are their feet nearest the origin: both in the arm's plane
    lr, lz = plane(p[:, 2] - p[:, 1])
    wr, wz = plane(wrist - p[:, 1])
    behind_lower_arm = lr * wz - lz * wr > 0.0  # in front (home): the wrist ahead of the arm
    bits: NDArray[np.int_] = 4 * behind_axis1 + 2 * behind_lower_arm
    return bits


def _quadrants(q: Array) -> Array:
    """cf1, cf4, cf6 (..., 3) of joint readings (..., 6) rad: floor(angle / 90 deg)."""
    return np.floor(np.degrees(q[..., [0, 3, 5]]) / 90.0 + 1e-9).astype(int)


def confdata(model: SerialModel, q: ArrayLike) -> Array:
    """(N, 4) integers cf1, cf4, cf6, cfx of joint readings q (N, 6) rad of a 6R ABB-type arm."""
    q = np.atleast_2d(np.asarray(q, float))
    cfx = _arm_bits(model, q) + (q[:, 4] < 0.0)
    return np.column_stack([_quadrants(q), cfx]).astype(int)


def _wrist_split(model: SerialModel, q: Array, conf: Array) -> Array:
    """Branches (N, 8, 6) with joint 5 at zero (axes 4 and 6 in line: only their combined
    turn reaches the pose): the turn shared so that joints 4 and 6 lie nearest their asked
    quadrants' points nearest zero (home: both at 0), not wherever the closed form put them."""
    singular = np.abs(np.nan_to_num(q[..., 4], nan=1.0)) < TOL_RAD
    if not singular.any():
        return q
    n, b = np.nonzero(singular)
    qs = q[n, b]
    J = spatial_jacobian(model, qs)
    s = np.where(np.sum(J[:, :3, 3] * J[:, :3, 5], axis=-1) < 0.0, -1.0, 1.0)
    lo4, lo6 = conf[n, 1] * QUADRANT_RAD, conf[n, 2] * QUADRANT_RAD
    r4 = np.clip(0.0, lo4, lo4 + QUADRANT_RAD - TOL_RAD)
    r6 = np.clip(0.0, lo6, lo6 + QUADRANT_RAD - TOL_RAD)
    c = qs[:, 3] + s * qs[:, 5]  # what the pose fixes
    q4 = 0.5 * (r4 + c - s * r6)  # nearest (r4, r6) on q4 + s q6 = c
    out = q.copy()
    out[n, b, 3], out[n, b, 5] = q4, s * (c - q4)
    return out


def solution_for_confdata(model: SerialModel, T_flange: ArrayLike, conf: ArrayLike,
                          strict: bool = True) -> tuple[Array, Array]:
    """The joint readings (N, 6) rad that reach flange poses T_flange (N, 4, 4) (robot base
    frame) with the configuration `conf` (N, 4): cf1, cf4, cf6 quadrants and cfx, within the
    limits, and which targets have one (N,). `strict`: raise UnreachableError naming the first
    target that has none."""
    T = np.asarray(T_flange, float)
    conf = np.atleast_2d(np.asarray(conf, int))
    sol = closed_form_ik(model.with_frames(base=np.eye(4), tool=np.eye(4)), T,
                         require_all=False, check=False)
    N = T.shape[0]
    centre = np.zeros((N, 6))
    centre[:, [0, 3, 5]] = (conf[:, :3] + 0.5) * QUADRANT_RAD
    q = sol.toward(centre)  # (N, 8, 6): axes 1, 4, 6 turned toward the asked quadrants
    q = _wrist_split(model, q, conf)
    # A reading within TOL_RAD of a quadrant's edge (or of joint 5's zero) is in either: the
    # numbers of a robtarget (9-decimal quaternions, 0.1 um positions) place the joints no
    # closer than that, and the nominal home is on every edge at once
    qq = np.nan_to_num(q)
    quadrant_ok = (_quadrants(qq - TOL_RAD) == conf[:, None, :3]) | \
        (_quadrants(qq + TOL_RAD) == conf[:, None, :3])
    wanted_arm, wanted_negative = conf[:, None, 3] & ~1, (conf[:, None, 3] & 1).astype(bool)
    q5 = qq[:, :, 4]
    sign_ok = np.where(wanted_negative, q5 < TOL_RAD, q5 > -TOL_RAD)
    match = sol.valid & np.all(quadrant_ok, axis=-1) & sign_ok
    # The arm's configuration (wrist centre against axis 1 and the lower arm) does not depend
    # on the wrist: computed on the no-flip branch of each branch still in question (the
    # quadrants leave one or two of eight), the flip one sharing it.
    partner = np.array([sol.branches.index((b[0], b[1], "noflip")) for b in sol.branches])
    rows, branches = np.nonzero(match)
    if rows.size:
        pairs, which = np.unique(rows * len(partner) + partner[branches], return_inverse=True)
        arm = _arm_bits(model, qq[pairs // len(partner), pairs % len(partner)])[which]
        match[rows, branches] = arm == wanted_arm[rows, 0]
    none = ~match.any(axis=1)
    if strict and none.any():
        k = int(np.flatnonzero(none)[0])
        why = "out of reach" if not sol.reachable[k].any() else \
            f"not reachable with confdata {conf[k].tolist()} inside the joint limits"
        raise UnreachableError(f"target {k} is {why}", index=k)
    return q[np.arange(N), np.argmax(match, axis=1)], ~none
