"""Inverse kinematics: closed form for ABB-type 6R arms, numerical for any (calibrated) model.

Closed form (`closed_form_ik`, the geometry in `wrist_partitioned`): eight branches, shoulder
front/back x elbow up/down x wrist no-flip/flip, each flagged reachable and within limits
(`ik_solutions.IKSolutions`).

Numerical (`numerical_ik`): damped Gauss-Newton on any model, every branch seeded by the closed
form of the model's nearest ideal geometry, so a calibrated model keeps the branch structure.
An arm whose wrist axes do not meet (the UR arms) has no such closed form: it is seeded from the
sampled configurations nearest each target, and its up to 8 slots hold the distinct solutions
found (not labelled branches). `local_ik`: the same refinement from a nearby seed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from screwcal.kinematics.forward import (
    forward_kinematics,
    frame_inverses,
    point_jacobian,
    spatial_jacobian,
)
from screwcal.kinematics.ik_solutions import (
    BRANCHES,
    IKSolutions,
    controller_readings,
    require_reachable,
    solutions_of,
)
from screwcal.kinematics.model import SerialModel, once_per_object
from screwcal.kinematics.se3 import Array, Mask, rotvec_from_rotation
from screwcal.kinematics.wrist_partitioned import (
    IDEAL_AXES,
    WristPartitionedGeometry,
    closed_form_one,
    closed_form_theta,
)

__all__ = ["BRANCHES", "IKSolutions", "WristPartitionedGeometry", "closed_form_ik", "local_ik",
           "numerical_ik", "pose_error"]


def _flange_targets(model: SerialModel, T_world_tool: ArrayLike) -> tuple[Array, Array]:
    """The targets (N, 4, 4) as given (world, tool) and as flange poses in the robot frame."""
    T_world = np.asarray(T_world_tool, dtype=float)
    if T_world.ndim != 3 or T_world.shape[1:] != (4, 4):
        raise ValueError(f"IK targets must have shape (N, 4, 4); got {T_world.shape}")
    base_inv, tool_inv = frame_inverses(model)
    T = T_world if base_inv is None else base_inv @ T_world
    return T_world, T if tool_inv is None else T @ tool_inv

def closed_form_ik(model: SerialModel, T_world_tool: ArrayLike, require_all: bool = True,
                   check: bool = True, branch: int | None = None) -> IKSolutions:
    """All eight closed-form solutions for targets (N, 4, 4) of an ideal ABB-type model; with
    `branch` (an index of BRANCHES), that one alone (second axis of length 1).

    Raises UnreachableError when a target is out of reach on every branch, unless
    `require_all` is False (for screening many candidate targets: read `reachable`).
    `check`: fill `residual_mm` by FK of every branch (False: NaN, a fifth of the time saved).
    """
    geo = WristPartitionedGeometry.from_model(model)
    T_world, T_flange = _flange_targets(model, T_world_tool)
    theta, reach = closed_form_one(geo, T_flange[0]) if len(T_flange) == 1 and branch is None \
        else closed_form_theta(geo, T_flange, branch=branch)
    q, within = controller_readings(model, theta)
    if require_all:
        require_reachable(reach)
    out = solutions_of(model, q, reach, within, T_world, check)
    return out if branch is None else replace(out, branches=(BRANCHES[branch],))

def pose_error(T_target: Array, T: Array) -> Array:
    """(dp, dphi) taking T to T_target: position difference and world-frame rotation vector."""
    dR = T_target[:, :3, :3] @ np.swapaxes(T[:, :3, :3], 1, 2)
    dphi = rotvec_from_rotation(dR)
    return np.concatenate([T_target[:, :3, 3] - T[:, :3, 3], dphi], axis=1)


def _refine(model: SerialModel, targets: Array, q0: Array, tol_mm: float, tol_rad: float,
            max_iter: int, damping: float) -> tuple[Array, Mask]:
    """Damped Gauss-Newton from the joint readings q0 (M, 6) toward targets (M, 4, 4) (world
    tool poses); returns the readings and which converged."""
    q = q0.copy()
    converged = np.zeros(len(q), bool)
    eye = np.eye(6)
    for _ in range(max_iter):
        idx = np.flatnonzero(~converged)
        if idx.size == 0:
            break
        T = forward_kinematics(model, q[idx])
        err = pose_error(targets[idx], T)
        done = (np.linalg.norm(err[:, :3], axis=1) < tol_mm) & \
               (np.linalg.norm(err[:, 3:], axis=1) < tol_rad)
        converged[idx[done]] = True
        idx, err, T = idx[~done], err[~done], T[~done]
        if idx.size == 0:
            break
        J = point_jacobian(spatial_jacobian(model, q[idx]), T)
        JT = np.swapaxes(J, 1, 2)
        step = np.linalg.solve(JT @ J + damping * eye, (JT @ err[:, :, None]))[:, :, 0]
        q[idx] += step
    # A last check for those that converged on the final step.
    idx = np.flatnonzero(~converged)
    if idx.size:
        err = pose_error(targets[idx], forward_kinematics(model, q[idx]))
        converged[idx] = (np.linalg.norm(err[:, :3], axis=1) < tol_mm * 10) & \
                         (np.linalg.norm(err[:, 3:], axis=1) < tol_rad * 10)
    return q, converged


def local_ik(model: SerialModel, T_world_tool: ArrayLike, q_seed: ArrayLike, *,
             tol_mm: float = 1e-9, tol_rad: float = 1e-11, max_iter: int = 30,
             damping: float = 1e-9) -> tuple[Array, Mask]:
    """The joint readings (N, 6) that reach each target, found from a nearby seed (N, 6) by
    damped Gauss-Newton: the same branch and turn as the seed, well defined near the wrist
    singularity where branches meet. For small changes of a known solution (compensation).
    Returns the readings and which targets converged (N,)."""
    T = np.asarray(T_world_tool, dtype=float)
    seed = np.broadcast_to(np.asarray(q_seed, float), (T.shape[0], model.n_joints))
    return _refine(model, T, seed, tol_mm, tol_rad, max_iter, damping)


_WRIST_MEET_MM = 5.0  # a calibrated wrist's axes miss each other by far less
_SAMPLES, _SEEDS, _CHUNK = 2048, 24, 128


@once_per_object
def _wrist_meets(model: SerialModel) -> bool:
    """Whether axes 4, 5 and 6 pass through one point (within _WRIST_MEET_MM): a spherical
    wrist. (The UR's meet pairwise, 4-5 and 5-6, but 4 and 6 are parallel.)"""
    if model.n_joints != 6 or not model.is_revolute.all():
        return False
    w, p = model.axis_dirs, model.axis_points_mm
    c = np.cross(w[3], w[4])
    if np.linalg.norm(c) < 1e-6:
        return False
    # the feet of the common normal of axes 4 and 5: p3 + s w3 and p4 + t w4
    s_, t_, _ = np.linalg.solve(np.column_stack([w[3], -w[4], c]), p[4] - p[3])
    f4, f5 = p[3] + s_ * w[3], p[4] + t_ * w[4]
    centre = (f4 + f5) / 2
    off6 = np.linalg.norm(np.cross(centre - p[5], w[5]))
    return bool(np.linalg.norm(f5 - f4) <= _WRIST_MEET_MM and off6 <= _WRIST_MEET_MM)


@once_per_object
def _sample_table(model: SerialModel) -> tuple[Array, Array]:
    """Fixed sampled readings (M, 6) inside the limits and their flange poses (M, 4, 4)."""
    rng = np.random.default_rng(0)
    q = rng.uniform(model.limits[:, 0], model.limits[:, 1], (_SAMPLES, model.n_joints))
    return q, forward_kinematics(model.with_frames(np.eye(4), np.eye(4)), q)


def _sampled_ik(model: SerialModel, T_target: Array, T_flange: Array, tol_mm: float,
                tol_rad: float, max_iter: int) -> IKSolutions:
    """IK of an arm without a spherical wrist: Gauss-Newton from the _SEEDS sampled
    configurations nearest each target (position, and orientation weighted by the arm's size);
    the distinct solutions (angles equal modulo a turn count once) fill up to 8 slots."""
    qs, Ts = _sample_table(model)
    N, n = T_target.shape[0], model.n_joints
    size = float(np.abs(model.axis_points_mm).max() + np.linalg.norm(model.home_flange[:3, 3]))
    seeds = np.empty((N, _SEEDS), int)
    for k0 in range(0, N, _CHUNK):
        chunk = T_flange[k0:k0 + _CHUNK]
        score = np.linalg.norm(chunk[:, None, :3, 3] - Ts[None, :, :3, 3], axis=-1) + size * \
            np.linalg.norm((chunk[:, None, :3, :3] - Ts[None, :, :3, :3]).reshape(
                len(chunk), len(Ts), 9), axis=-1)
        seeds[k0:k0 + _CHUNK] = np.argpartition(score, _SEEDS, axis=1)[:, :_SEEDS]
    q, converged = _refine(model, np.repeat(T_target, _SEEDS, axis=0),
                           qs[seeds].reshape(-1, n), tol_mm, tol_rad, max_iter, 1e-6)
    q, converged = q.reshape(N, _SEEDS, n), converged.reshape(N, _SEEDS)
    out, reach = np.full((N, len(BRANCHES), n), np.nan), np.zeros((N, len(BRANCHES)), bool)
    for k in range(N):
        found: list[Array] = []
        for theta in q[k, converged[k]] + model.joint_zero:
            if not any(np.abs(np.angle(np.exp(1j * (theta - f)))).max() < 1e-6 for f in found):
                found.append(theta)
            if len(found) == len(BRANCHES):
                break
        for b, theta in enumerate(found):
            out[k, b], reach[k, b] = theta, True
    require_reachable(reach)
    q_wrapped, within = controller_readings(model, out)
    return solutions_of(model, q_wrapped, reach, within, T_target)


@once_per_object
def _signed_ideal(model: SerialModel) -> tuple[Array, SerialModel]:
    """Per joint +1 or -1: whether its axis turns with or against the ABB-type direction it is
    nearest (KUKA's A1, A4, A6 and FANUC's J3-J6 turn the other way), and the model with those
    axes reversed, whose angles are the signs times the model's: the closed form seeds it."""
    signs = np.where(np.einsum("ij,ij->i", model.axis_dirs, IDEAL_AXES) < 0, -1.0, 1.0)
    if (signs > 0).all():
        return signs, model
    return signs, model.derived(axis_dirs=model.axis_dirs * signs[:, None])


def numerical_ik(model: SerialModel, T_world_tool: ArrayLike, *, tol_mm: float = 1e-9,
                 tol_rad: float = 1e-11, max_iter: int = 30, damping: float = 1e-9
                 ) -> IKSolutions:
    """IK of any 6R model, every branch refined by damped Gauss-Newton from the closed form of
    the model's nearest ideal geometry. A branch counts as reachable when it converged."""
    T_target, T_flange = _flange_targets(model, T_world_tool)
    if not _wrist_meets(model):
        return _sampled_ik(model, T_target, T_flange, tol_mm, tol_rad, max(max_iter, 60))
    signs, ideal = _signed_ideal(model)
    geo = WristPartitionedGeometry.from_model(ideal, tol=None)
    # A calibrated arm may reach a little beyond its ideal twin: seed from the stretched pose.
    theta0, reach0 = closed_form_theta(geo, T_flange, slack=0.05, elbow_floor=0.02)
    theta0 = theta0 * signs
    require_reachable(reach0)
    N = T_target.shape[0]
    q0 = np.nan_to_num(theta0 - model.joint_zero).reshape(-1, 6)
    active = reach0.reshape(-1)
    q, converged = q0.copy(), np.zeros_like(active)
    q[active], converged[active] = _refine(model, np.repeat(T_target, 8, axis=0)[active],
                                           q0[active], tol_mm, tol_rad, max_iter, damping)
    reach = converged.reshape(N, 8)
    require_reachable(reach)
    q[~converged] = np.nan
    q_wrapped, within = controller_readings(model, q.reshape(N, 8, 6) + model.joint_zero)
    return solutions_of(model, q_wrapped, reach, within, T_target)
