"""Every IK branch of a nominal arm of any of the library's makers, in closed form.

A robot program's controller solves each Cartesian target on its nominal model; to compensate
a program of another maker, the filter must solve it the same way and tell the branches apart:

- ABB-type arms and the arms that are ABB-type but for the direction some joints count
  positive (KUKA's A1, A4, A6; FANUC's J3-J6): the wrist-partitioned closed form on the arm with
  those axes reversed, the angles multiplied back by the signs (`ik._signed_ideal`), labelled
  with `BRANCHES` (shoulder front/back, elbow up/down, wrist no-flip/flip, physical: the same
  label means the same posture whichever way a joint counts);
- Universal Robots arms (axes 2-4 parallel, the wrist's axes offset): the eight solutions of
  the arm's DH table in closed form (`ur_closed_form`), labelled likewise (shoulder, elbow,
  wrist by the sign of joint 5).

Each branch is checked by the model's own forward kinematics: an arm whose geometry is not of
one of these forms (a calibrated model, an imported robot with offsets) is refused by name,
never solved approximately.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from screwcal.errors import ModelError
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.ik import _signed_ideal
from screwcal.kinematics.ik_solutions import (
    BRANCHES,
    IKSolutions,
    controller_readings,
    solutions_of,
)
from screwcal.kinematics.maker_configs import branch_index
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, Mask
from screwcal.kinematics.ur_closed_form import URGeometry, ur_closed_form
from screwcal.kinematics.wrist_partitioned import WristPartitionedGeometry, closed_form_theta

__all__ = ["EXACT_MM", "all_branches", "branch_of"]

EXACT_MM = 1e-6  # a branch's flange this far from its target at most: a closed form is exact


def all_branches(nominal: SerialModel, T_flange: Array, branch: int | None = None
                 ) -> IKSolutions:
    """The eight branches (N, 8, 6) rad (controller readings) reaching flange poses T_flange
    (N, 4, 4) in the robot base frame, with their masks; `residual_mm` holds each branch's
    position error by the model's own FK. With `branch` (an index of BRANCHES), that branch
    alone (second axis of length 1). Raises ModelError for an arm of no known form."""
    T = np.asarray(T_flange, float)
    theta = _theta(nominal, T, branch)
    q, within = controller_readings(nominal, theta)
    reach: Mask = np.all(np.isfinite(theta), axis=-1)
    out = solutions_of(nominal, q, reach, within, T, check=False)
    if branch is not None:
        out = replace(out, branches=(BRANCHES[branch],))
    return _checked(nominal, out, T)


def branch_of(nominal: SerialModel, T_flange: Array, q: Array, hint: Array) -> Array:
    """`maker_configs.branch_index(all_branches(nominal, T_flange), q)`: the first branch (N,)
    whose joints equal q (N, 6) rad modulo whole turns, -1 where none does, solving on a
    wrist-partitioned arm only the branch `hint` (N,) names (q's branch before a small move)
    and its elbow partner. Two branches with other shoulders differ by half a turn of axis 1,
    two with other wrists by half a turn of axis 4: only elbow partners can both equal q (the
    arm stretched). A target on neither, and every target of another arm, is solved on all
    eight."""
    T = np.asarray(T_flange, float)
    hints: NDArray[np.int64] = np.asarray(hint, dtype=np.int64)
    out = np.full(len(q), -1)
    pending = hints >= 0
    if URGeometry.of(nominal) is None and pending.any():
        lo, hi = np.minimum(hints, hints ^ 2), np.maximum(hints, hints ^ 2)  # BRANCHES order
        for first in (lo, hi):  # the first of the two that equals q, as branch_index takes it
            for b in sorted(set(first[pending].tolist())):  # (np.unique loads numpy.ma)
                rows = np.flatnonzero(pending & (first == b))
                theta = _theta(nominal, T[rows], b)  # joints alone: no check by FK needed
                q_b, within = controller_readings(nominal, theta)
                sol = solutions_of(nominal, q_b, np.all(np.isfinite(theta), axis=-1), within,
                                   T[rows], check=False)
                hit = branch_index(sol, q[rows]) == 0
                out[rows[hit]], pending[rows[hit]] = b, False
    rest = np.flatnonzero(out < 0)
    if rest.size:
        out[rest] = branch_index(all_branches(nominal, T[rest]), q[rest])
    return out


def _theta(nominal: SerialModel, T: Array, branch: int | None = None) -> Array:
    """Joint angles (N, 8, 6) (one branch: (N, 1, 6)), NaN where a branch does not exist."""
    if nominal.n_joints != 6 or not nominal.is_revolute.all():
        raise ModelError(f"robot '{nominal.name}': programs are compensated for 6R arms only")
    ur = URGeometry.of(nominal)
    if ur is not None:
        return ur_closed_form(ur, T, branch)
    signs, ideal = _signed_ideal(nominal)
    try:
        geo = WristPartitionedGeometry.from_model(ideal)
    except ModelError:
        raise ModelError(f"robot '{nominal.name}' is neither a wrist-partitioned arm (ABB, KUKA, "
                         "FANUC) nor a Universal Robots arm: no closed form solves its programs "
                         "as its controller does") from None
    theta, _ = closed_form_theta(geo, T, branch=branch)
    return theta * signs


def _checked(nominal: SerialModel, sol: IKSolutions, T: Array) -> IKSolutions:
    """The solutions with each branch's residual filled, a branch that misses its target by
    more than EXACT_MM (an arm only near one of the forms) marked unreachable."""
    N, B = sol.q.shape[:2]
    q = np.nan_to_num(sol.q).reshape(-1, 6)
    F = flange_kinematics(nominal, q).reshape(N, B, 4, 4)
    residual = np.linalg.norm(F[..., :3, 3] - T[:, None, :3, 3], axis=-1)
    rot = np.linalg.norm(F[..., :3, :3] - T[:, None, :3, :3], axis=(-2, -1))
    exact = (residual < EXACT_MM) & (rot < 1e-8) & sol.reachable
    residual = np.where(sol.reachable, residual, np.nan)
    return IKSolutions(q=sol.q, reachable=exact, within_limits=sol.within_limits,
                       residual_mm=residual, branches=sol.branches, limits=sol.limits)
