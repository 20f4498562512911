"""Forward kinematics by successive screws and its analytic Jacobians, over a batch of poses.

Every function takes joint values `q` with shape (N, n) (rad for revolute joints, mm for
prismatic ones; the joint zero of the model is added inside) and loops over joints, never over
poses.

One chain per case: the partial products from the base, for what needs each joint's frame
(the Jacobians, the gravity torques, the skeleton: `screw_chain`); the tool pose of a few
configurations (`_few_poses`) and of many (`_many_poses`), equal to rounding and to the partial
products' last one (tests/screwcal/kinematics/test_forward.py). The parameters of an error
model and their Jacobian are `screwcal.calibration.error_parameters.ErrorModel`'s.

Jacobians are *spatial*: column k is the twist (omega, v) in the world frame such that
dT/dx_k T^-1 = hat(column k). `point_jacobian` turns them into the rates of the tool point's
position and of the rotation vector, the order of a pose residual (dx, dy, dz, dphi_x, ...).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from screwcal.kinematics.compliance import gravity_torques_by_mass
from screwcal.kinematics.model import SerialModel, once_per_object
from screwcal.kinematics.se3 import Array, cross, invert_transform, skew

_EYE4 = np.eye(4)


def _joint_generators(model: SerialModel) -> tuple[Array, Array]:
    """G1, G2 (n, 4, 4) with exp(hat(xi) t) = I + sin(t) G1 + (1 - cos(t)) G2 for revolute
    joints (G1 = hat(xi), G2 = hat(xi)^2, Tsai / Rodrigues, Annex B) and I + t G1 for prismatic."""
    n = model.n_joints
    G1 = np.zeros((n, 4, 4))
    K = skew(model.axis_dirs)
    rev = model.is_revolute
    G1[rev, :3, :3] = K[rev]
    G1[rev, :3, 3] = -np.einsum("nij,nj->ni", K[rev], model.axis_points_mm[rev])
    G1[~rev, :3, 3] = model.axis_dirs[~rev]
    G2 = np.where(rev[:, None, None], G1 @ G1, 0.0)
    return G1, G2


@once_per_object
def _generators(model: SerialModel) -> tuple[Array, Array, Array]:
    """G1, G2 and home_flange . tool of a model."""
    return (*_joint_generators(model), model.home_flange @ model.tool)


def checked_joints(model: SerialModel, q: ArrayLike) -> Array:
    """Joint values (N, n) for `model` as a float array; refuses another shape."""
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != model.n_joints:
        raise ValueError(f"joint values for model '{model.name}' must have shape "
                         f"(N, {model.n_joints}); got {q.shape}")
    return q


def screw_chain(model: SerialModel, q: Array, keep: bool, joints: int | None = None,
                tau: Array | None = None) -> tuple[Array, list[Array]]:
    """Successive screws from the base: returns A_n (N, 3, 4) = base . prod exp(...) [:3] and,
    if `keep`, the partial products A_0..A_n (each (N, 3, 4)), A_0 = base; only the first
    `joints` screws when given. A compliant model's joints stand at q + zero + c * tau(q), tau
    at the unbent configuration (the bending's own effect on tau is of second order; `tau`:
    `joint_torques_by_mass`'s, when at hand)."""
    theta = q + model.joint_zero
    if model.has_compliance:
        theta = theta + joint_bend(model, q, tau)
    return _chain_theta(model, theta, keep, joints)


def joint_torques(model: SerialModel, q: ArrayLike) -> Array:
    """(N, n) gravity torques (N m) about the joints at configurations q (N, n), from the
    model's lumped masses and payload (`compliance`)."""
    torques: Array = joint_torques_by_mass(model, q).sum(axis=2)
    return torques


def joint_torques_by_mass(model: SerialModel, q: ArrayLike) -> Array:
    """(N, n, M) the torques of `joint_torques` per mass: the arm's masses, then the payload's
    (when it has one)."""
    q = checked_joints(model, q)
    masses = model.all_masses
    carrying = max((m.link for m in masses), default=-1) + 1  # joints that carry a mass
    _, partial = _chain_theta(model, q + model.joint_zero, keep=True, joints=carrying)
    return gravity_torques_by_mass(model.axis_dirs, model.axis_points_mm, partial, masses,
                                   model.base[:3, 2])


def joint_bend(model: SerialModel, q: Array, tau: Array | None = None) -> Array:
    """(N, n) how far gravity turns each joint (rad): c_j tau_j, or with per-mass coefficients
    sum_k C_jk tau_jk (the payload with its joint's last arm-mass coefficient); `tau`: the
    torques `joint_torques_by_mass` gives, when already at hand."""
    tau = joint_torques_by_mass(model, q) if tau is None else tau
    bend: Array
    if model.compliance_by_mass is None:
        bend = model.compliance * tau.sum(axis=2)
        return bend
    C = model.compliance_by_mass
    if tau.shape[2] > C.shape[1]:  # the payload
        C = np.concatenate([C, C[:, -1:]], axis=1)
    bend = np.einsum("nk,Nnk->Nn", C, tau)
    return bend


def _chain_theta(model: SerialModel, theta: Array, keep: bool, joints: int | None = None
                 ) -> tuple[Array, list[Array]]:
    N = theta.shape[0]
    G1, G2, _ = _generators(model)
    A = np.broadcast_to(model.base[:3], (N, 3, 4)).copy()
    partial = [A] if keep else []
    for i in range(model.n_joints if joints is None else joints):
        flat = A.reshape(-1, 4)
        AG1 = (flat @ G1[i]).reshape(N, 3, 4)
        if model.joint_types[i] == "R":
            AG2 = (flat @ G2[i]).reshape(N, 3, 4)
            t = theta[:, i, None, None]
            A = A + np.sin(t) * AG1 + (1.0 - np.cos(t)) * AG2
        else:
            A = A + theta[:, i, None, None] * AG1
        if keep:
            partial.append(A)
    return A, partial


def homogeneous(A: Array) -> Array:
    """Poses (..., 4, 4) of their top rows (..., 3, 4)."""
    T = np.empty((*A.shape[:-2], 4, 4))
    T[..., :3, :] = A
    T[..., 3, :] = (0.0, 0.0, 0.0, 1.0)
    return T


_FEW = 16  # up to this many configurations, `_few_poses` (fewer, larger array calls)
_BLOCK = 2048  # configurations per block of `_many_poses`: its arrays (~0.3 MB) stay in cache


def forward_kinematics(model: SerialModel, q: ArrayLike) -> Array:
    """Pose of the tool in the world frame, shape (N, n) -> (N, 4, 4). Eq. of Annex B chained.

    Each joint's exponential is one fixed combination of (1, sin q, cos q) (`_exponential_
    tables`); two ways to chain them, tested equal (tests/screwcal/kinematics/test_forward.py):
    a few configurations in a handful of larger array calls (`_few_poses`: the call overhead is
    the cost), many in cache-sized blocks with the configurations along the fast axis
    (`_many_poses`: the memory traffic is the cost)."""
    q = checked_joints(model, q)
    if model.has_compliance:  # the joints stand at q + c tau(q) (`screw_chain`)
        q = q + joint_bend(model, q)
    if q.shape[0] <= _FEW:
        return _few_poses(model, q)
    return _many_poses(model, q)


def _many_poses(model: SerialModel, q: Array) -> Array:
    """Many configurations (N, n): blocks of `_BLOCK` configurations with the configurations
    along the last axis, so that every array call runs over a long contiguous row: the
    partial product A (3, 4, K), per joint one matrix product with the joint's three matrices
    side by side, (12, 4) @ (3, 4, K) -> (3, 12, K), then A = P0 + f P1 + g P2 in place.
    (The batched (N, 3, 4) layout's inner loops run over 4 numbers each: 1.6x the time at
    100,000 configurations.)"""
    C, CT = _exponential_tables(model)
    N, n = q.shape
    rev = model.is_revolute
    T = np.empty((N, 4, 4))
    T[:, 3] = (0.0, 0.0, 0.0, 1.0)
    K = min(N, _BLOCK)
    A, P, tmp = np.empty((3, 4, K)), np.empty((3, 12, K)), np.empty((3, 4, K))
    first = C[0, :, :3, :, None]  # (3, 3, 4, 1): the base folded in
    for s in range(0, N, K):
        qT = np.ascontiguousarray(q[s:s + K].T)
        k = qT.shape[1]
        f = np.where(rev[:, None], np.sin(qT), qT)
        g = np.where(rev[:, None], np.cos(qT), 0.0)
        a, t = A[..., :k], tmp[..., :k]
        np.multiply(first[1], f[0], out=a)
        a += first[0]
        np.multiply(first[2], g[0], out=t)
        a += t
        for i in range(1, n):
            np.matmul(CT[i], a, out=P[..., :k])
            p = P[..., :k].reshape(3, 3, 4, k)  # a view: (row, matrix, column, configuration)
            np.multiply(p[:, 1], f[i], out=a)
            a += p[:, 0]
            np.multiply(p[:, 2], g[i], out=t)
            a += t
        T[s:s + k, :3] = np.moveaxis(a, -1, 0)
    return T


def _few_poses(model: SerialModel, q: Array) -> Array:
    """A few configurations (N, n). One matrix product gives every exponential of every
    configuration from their rows (1, f(q_i), g(q_i)) (the joints' tables side by side in a
    block-diagonal table, `_few_pose_tables`), then `_chained` multiplies them."""
    B = _few_pose_tables(model)
    N, n = q.shape
    sc = np.empty((N, n, 3))
    sc[:, :, 0] = 1.0
    if "P" not in model.joint_types:
        np.sin(q, out=sc[:, :, 1])
        np.cos(q, out=sc[:, :, 2])
    else:
        rev = model.is_revolute
        sc[:, :, 1] = np.where(rev, np.sin(q), q)
        sc[:, :, 2] = np.where(rev, np.cos(q), 0.0)
    E: Array = sc.reshape(N, 3 * n).dot(B)  # (N, 16 n): each joint's exponential, row-major
    if N == 1:
        return _chained(E.reshape(n, 4, 4))[None]
    return _chained(E.reshape(N, n, 4, 4))


def _chained(E: Array) -> Array:
    """The product E_1 E_2 ... E_n of the exponentials, one pose's (n, 4, 4) or a stack's
    (N, n, 4, 4), in one order: the pairs (E_1 E_2)(E_3 E_4)..., then those left to right.
    A stack's pairs in one call (three calls for six joints); one pose's with ndarray.dot, the
    same products (a stack of one costs matmul's stacked machinery, twice dot's at 4 x 4)."""
    n = E.shape[-3]
    half = n // 2
    T: Array
    if E.ndim == 3:
        T = E[0] if n == 1 else E[0].dot(E[1])
        for k in range(2, 2 * half, 2):
            T = T.dot(E[k].dot(E[k + 1]))
        return T.dot(E[-1]) if n % 2 and n > 1 else T
    if n == 1:
        return E[:, 0]
    pairs = E[:, 0:2 * half:2] @ E[:, 1:2 * half:2]
    T = pairs[:, 0]
    for k in range(1, half):
        T = T @ pairs[:, k]
    return T @ E[:, -1] if n % 2 else T


@once_per_object
def _exponential_tables(model: SerialModel) -> tuple[Array, list[Array]]:
    """C (n, 3, 4, 4) such that joint i's exponential at q_i + zero_i is C[i, 0] + f(q_i)
    C[i, 1] + g(q_i) C[i, 2], (f, g) = (sin, cos) for a revolute joint, (q, 0) for a prismatic
    one. With Z_i = exp(hat(xi_i) zero_i), which commutes with the joint's own screw, a
    revolute joint's matrices are Z_i (I + G2), Z_i G1, -Z_i G2 (Rodrigues, Annex B), a
    prismatic one's Z_i, Z_i G1, 0; the base is multiplied into the first joint's matrices and
    home_flange . tool into the last's. Also, per joint, the three matrices' columns side by
    side as rows (12, 4): (k, c) x j -> C[i, k, j, c], for `_many_poses`."""
    G1, G2, flange_tool = _generators(model)
    zero = model.joint_zero[:, None, None]
    rev = model.is_revolute[:, None, None]
    Z = _EYE4 + np.where(rev, np.sin(zero) * G1 + (1.0 - np.cos(zero)) * G2, zero * G1)
    C = np.stack([np.where(rev, Z @ (_EYE4 + G2), Z), Z @ G1, np.where(rev, -(Z @ G2), 0.0)],
                 axis=1)
    C[0] = model.base @ C[0]
    C[-1] = C[-1] @ flange_tool
    CT = [np.ascontiguousarray(Ci.transpose(0, 2, 1).reshape(12, 4)) for Ci in C]
    return C, CT


@once_per_object
def _few_pose_tables(model: SerialModel) -> Array:
    """B (3 n, 16 n), zero but for joint i's block B[3 i:3 i + 3, 16 i:16 i + 16] =
    `_exponential_tables`' C[i] flattened: (1, f(q_i), g(q_i)) times that block is joint i's
    exponential, row-major."""
    C, _ = _exponential_tables(model)
    n = model.n_joints
    B = np.zeros((n, 3, n, 16))
    joints = np.arange(n)
    B[joints, :, joints] = C.reshape(n, 3, 16)
    table: Array = B.reshape(3 * n, 16 * n)
    return table


def flange_kinematics(model: SerialModel, q: ArrayLike) -> Array:
    """Pose of the flange (tool0) in the robot base frame, ignoring base and tool: (N, 4, 4)."""
    T = forward_kinematics(model, q)
    base_inv, tool_inv = frame_inverses(model)
    T = T if base_inv is None else base_inv @ T
    return T if tool_inv is None else T @ tool_inv


@once_per_object
def frame_inverses(model: SerialModel) -> tuple[Array | None, Array | None]:
    """The inverse base and tool of a model (None for an identity), once per model."""
    base_inv = None if np.array_equal(model.base, _EYE4) else invert_transform(model.base)
    tool_inv = None if np.array_equal(model.tool, _EYE4) else invert_transform(model.tool)
    return base_inv, tool_inv


def joint_positions(model: SerialModel, q: ArrayLike) -> Array:
    """The robot's skeleton for drawing, (N, n + 1, 3) world positions: for each joint the foot
    (at home) of the previous skeleton point on its axis — where the joint sits along the chain
    rather than the arbitrary stored axis point — then the tool."""
    q = checked_joints(model, q)
    _, partial = screw_chain(model, q, keep=True)
    prev = np.zeros(3)  # the robot base origin, robot frame
    pts = []
    for i, A in enumerate(partial[:-1]):
        w, p = model.axis_dirs[i], model.axis_points_mm[i]
        foot = p + np.dot(prev - p, w) * w if model.joint_types[i] == "R" else prev
        pts.append(A[:, :, :3] @ foot + A[:, :, 3])
        prev = foot
    pts.append(forward_kinematics(model, q)[:, :3, 3])
    return np.stack(pts, axis=1)


def joint_axis_lines(model: SerialModel, q: ArrayLike, joints: int) -> tuple[Array, Array]:
    """The lines of the first `joints` revolute axes in the world at configurations q (N, n):
    unit directions and each line's point nearest the world origin, (N, joints, 3) each. Only
    the screws before the last asked axis are chained (the columns of `spatial_jacobian`
    without the rest of the chain or the twists' moments)."""
    q = checked_joints(model, q)
    _, partial = screw_chain(model, q, keep=True, joints=joints - 1)
    A = np.stack(partial, axis=1)  # (N, joints, 3, 4): axis i is carried by A_{i-1}
    R, t = A[..., :3], A[..., 3]
    w = np.sum(R * model.axis_dirs[:joints, None, :], axis=-1)  # R @ dir, elementwise:
    p = np.sum(R * model.axis_points_mm[:joints, None, :], axis=-1) + t  # no 3x3 matmul loop
    foot: Array = p - np.sum(p * w, axis=-1, keepdims=True) * w
    return w, foot


def spatial_jacobian(model: SerialModel, q: ArrayLike) -> Array:
    """Spatial Jacobian w.r.t. the joints, shape (N, 6, n): column i = Ad_{A_{i-1}} xi_i."""
    q = checked_joints(model, q)
    _, partial = screw_chain(model, q, keep=True)
    return np.stack([_joint_twist(model, i, partial[i]) for i in range(model.n_joints)], axis=-1)


def _joint_twist(model: SerialModel, i: int, A: Array) -> Array:
    """Twist of joint i carried to the world by the partial product A (N, 3, 4): (N, 6)."""
    R = A[:, :, :3]
    w = R @ model.axis_dirs[i]
    if model.joint_types[i] == "P":
        return np.concatenate([np.zeros_like(w), w], axis=1)
    p = R @ model.axis_points_mm[i] + A[:, :, 3]
    return np.concatenate([w, cross(p, w)], axis=1)


def point_jacobian(J_spatial: ArrayLike, T: ArrayLike) -> Array:
    """Rates of the tool point position and rotation vector from a spatial Jacobian.

    J_spatial (N, 6, P) with rows (omega, v); T (N, 4, 4) the tool poses. Returns (N, 6, P) with
    rows (dx, dy, dz [mm], dphi_x, dphi_y, dphi_z [rad]): dp = v + omega x p, dphi = omega.
    """
    J = np.asarray(J_spatial, dtype=float)
    p = np.asarray(T, dtype=float)[:, :3, 3]
    w = J[:, :3, :]
    v = J[:, 3:, :]
    dp = v + np.swapaxes(cross(np.swapaxes(w, 1, 2), p[:, None, :]), 1, 2)
    return np.concatenate([dp, w], axis=1)
