"""Joints of a calibrated arm next to a singularity, where Gauss-Newton from a reference stalls
(the wrist's axes 4 and 6 in line; the stretched arm): Levenberg-Marquardt over every target at
once, accepted on the singular tolerances (SINGULAR_TOL_MM, SINGULAR_TOL_DEG). Used by the
compensation (`correction`)."""

from __future__ import annotations

import numpy as np

from screwcal.kinematics.forward import forward_kinematics, point_jacobian, spatial_jacobian
from screwcal.kinematics.ik import pose_error
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, Mask

# Residual scale: mm, and rad x 10 mm, so that the position is met first where the two
# cannot both be (the wrist singularity)
POSE_SCALE = np.r_[np.ones(3), np.full(3, 10.0)]
LM_ITERATIONS = 200  # at most; a batch of wrist-singular targets stops when all settled
_COST_FLOOR = 0.5 * 1e-9**2  # the pose met to 1e-9 mm (scaled): nothing left to fit
_RELATIVE_GAIN = 1e-12  # a step lowering the cost by less has converged
_STEP_FLOOR_RAD = 1e-11  # no joint moved by more: converged (1e-8 mm at a 1 m reach)

WRIST_SINGULAR_DEG = 10.0  # axes 4 and 6 this close to parallel: the wrist singularity's band
# At a calibrated wrist's singularity: the position met to this, the orientation to this
SINGULAR_TOL_MM = 1e-3
SINGULAR_TOL_DEG = 0.05
WRIST_SEED_TILT = np.radians(1.0)


def wrist_axes_cos(model: SerialModel, q: Array) -> Array:
    """(N,) cosine of the angle between axes 4 and 6 at joints q (N, 6)."""
    J = spatial_jacobian(model, q)
    return np.sum(J[:, :3, 3] * J[:, :3, 5], axis=-1)


def wrist_singular(model: SerialModel, q: Array) -> Mask:
    """(N,) joints q (N, n) within WRIST_SINGULAR_DEG of a 6R arm's wrist singularity (axes 4
    and 6 in line)."""
    if model.n_joints != 6 or not np.all(model.is_revolute):
        return np.zeros(len(q), bool)
    return np.abs(wrist_axes_cos(model, q)) > np.cos(np.radians(WRIST_SINGULAR_DEG))


def meets(T: Array, robot: SerialModel, q: Array) -> Mask:
    """(M,) whether the joints q (M, 6) put the flange on T (M, 4, 4) within the singular
    tolerances."""
    return within_singular_tolerances(pose_error(T, forward_kinematics(robot, q)))


def within_singular_tolerances(err: Array) -> Mask:
    """(M,) pose errors (M, 6) (mm, rad) within SINGULAR_TOL_MM and SINGULAR_TOL_DEG."""
    return (np.linalg.norm(err[:, :3], axis=1) <= SINGULAR_TOL_MM) & \
        (np.linalg.norm(err[:, 3:], axis=1) <= np.radians(SINGULAR_TOL_DEG))


def wrist_solutions(robot: SerialModel, T: Array, ref: Array) -> tuple[Array, Mask, Array]:
    """Near the wrist singularity: the joints (M, 6) nearest the reference that reach T
    (M, 4, 4), counting for joints 4 and 6 only their combined turn (what moves the tool
    there); exactly at the singularity the two share that turn equally, so each stays nearest
    its reference value. A calibrated wrist is not quite spherical: at its singularity a sliver
    of orientations is out of reach, so the position is met and the orientation as closely as
    it goes (within SINGULAR_TOL_DEG, else refused). Levenberg-Marquardt from the reference,
    and, where that misses, from it with joint 5 tilted -1 deg, then +1 deg (on the singular
    point itself the tilt has no gradient): the first start whose best fit so far meets the
    target wins. Returns the joints, which have one, and each one's largest change (deg,
    joints 4 and 6 combined)."""
    s = np.sign(wrist_axes_cos(robot, ref))  # axes 4 and 6 alike (+1) or opposed (-1)
    best, cost = fit_poses(robot, T, ref)
    met = meets(T, robot, best)
    miss = np.flatnonzero(~met)
    if miss.size:  # the tilted starts, for the targets the reference's own start missed
        tilted = np.concatenate([ref[miss], ref[miss]])
        tilted[:, 4] += np.repeat([-WRIST_SEED_TILT, WRIST_SEED_TILT], miss.size)
        fits, costs = fit_poses(robot, np.concatenate([T[miss], T[miss]]), tilted)
        for fit, c in ((fits[:miss.size], costs[:miss.size]), (fits[miss.size:],
                                                               costs[miss.size:])):
            better = (c < cost[miss]) & ~met[miss]
            best[miss[better]], cost[miss[better]] = fit[better], c[better]
            met[miss] = meets(T[miss], robot, best[miss])
    q = turned_toward(best, ref)
    d = np.degrees(q - ref)
    combined = d[:, 3] + s * d[:, 5]
    exact = np.abs(wrist_axes_cos(robot, q)) > np.cos(1e-6)  # exactly singular
    d[exact, 3], d[exact, 5] = 0.5 * combined[exact], 0.5 * s[exact] * combined[exact]
    q[exact] = ref[exact] + np.radians(d[exact])
    q_out = np.where(met[:, None], q, ref)
    ok = met & robot.within_limits(q_out)
    measure = np.where(met, np.max(np.abs(np.column_stack(
        [d[:, 0], d[:, 1], d[:, 2], d[:, 4], combined])), axis=1), np.inf)
    return q_out, ok, measure


def near_singular_solutions(robot: SerialModel, T: Array, ref: Array
                             ) -> tuple[Array, Mask, Array]:
    """Targets (M, 4, 4) that Gauss-Newton from the reference (M, 6) did not reach: next to a
    singularity other than the wrist's (the arm stretched, KUKA's and UR's zero pose), where a
    calibration's small length changes move the solution far along the singular direction.
    Levenberg-Marquardt from the reference, on the branch the reference is on or across the
    stretched pose where the calibrated arm needs it, the same rule as at the wrist: the
    target met within SINGULAR_TOL_MM and SINGULAR_TOL_DEG. Returns the joints (turned toward
    the reference), which met their target, and for each how near the fit gets (mm, deg):
    a target the calibrated arm cannot reach is refused with that distance."""
    q, _ = fit_poses(robot, T, ref)
    q = turned_toward(q, ref)
    err = pose_error(T, forward_kinematics(robot, q))
    gap = np.column_stack([np.linalg.norm(err[:, :3], axis=1),
                           np.degrees(np.linalg.norm(err[:, 3:], axis=1))])
    return q, within_singular_tolerances(err), gap


def fit_poses(robot: SerialModel, T: Array, q0: Array) -> tuple[Array, Array]:
    """Levenberg-Marquardt (Marquardt's diagonal scaling, Nielsen's damping update) from the
    joints q0 (M, 6) toward the flange poses T (M, 4, 4), every target at once: least squares of
    the pose error scaled by POSE_SCALE, with the analytic Jacobian. Each target stops when its
    cost no longer falls by more than rounding, or is met to rounding. Returns the joints and
    their costs (half the squared scaled error) (M,)."""
    q = q0.copy()
    r = pose_error(T, forward_kinematics(robot, q)) * POSE_SCALE
    cost = 0.5 * np.einsum("ij,ij->i", r, r)
    lam, nu = np.full(len(q), 1e-3), np.full(len(q), 2.0)
    active = cost > _COST_FLOOR
    for _ in range(LM_ITERATIONS):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        Tq = forward_kinematics(robot, q[idx])
        J = point_jacobian(spatial_jacobian(robot, q[idx]), Tq) * POSE_SCALE[:, None]
        JT = np.swapaxes(J, 1, 2)
        A = JT @ J
        g = (JT @ r[idx][:, :, None])[:, :, 0]
        D = np.maximum(np.diagonal(A, axis1=1, axis2=2), 1e-12)
        damping = lam[idx, None] * D
        step = np.linalg.solve(A + damping[:, :, None] * np.eye(6), g[:, :, None])[:, :, 0]
        trial = q[idx] + step
        r_trial = pose_error(T[idx], forward_kinematics(robot, trial)) * POSE_SCALE
        c_trial = 0.5 * np.einsum("ij,ij->i", r_trial, r_trial)
        better = c_trial < cost[idx]
        gain = cost[idx] - c_trial
        # the gain against the linear model's: the damping falls as far as the model holds
        predicted = 0.5 * np.einsum("ij,ij->i", step, damping * step + g)
        rho = gain / np.maximum(predicted, 1e-300)
        up, down = idx[better], idx[~better]
        q[up], r[up], cost[up] = trial[better], r_trial[better], c_trial[better]
        lam[up] *= np.maximum(1 / 3, 1 - (2 * rho[better] - 1) ** 3)
        nu[up] = 2.0
        lam[down] *= nu[down]
        nu[down] *= 2.0
        settled = (better & (gain <= _RELATIVE_GAIN * c_trial)) | (cost[idx] <= _COST_FLOOR) | \
            (np.abs(step).max(axis=1) < _STEP_FLOOR_RAD) | (lam[idx] > 1e12)
        active[idx[settled]] = False
    return q, cost


def turned_toward(q: Array, ref: Array) -> Array:
    """q (..., 6) with each revolute joint moved by whole turns as close as it gets to ref."""
    return ref + np.mod(q - ref + np.pi, 2 * np.pi) - np.pi
