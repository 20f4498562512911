"""Inverse kinematics: closed form for ABB-type 6R arms, numerical for any (calibrated) model.

Closed form (`closed_form_ik`): joint 1 about z; joints 2, 3 about y with their axes in the plane
y = 0 (shoulder offset allowed); a spherical wrist x-y-x whose centre lies on axis 4 at home. This
is the nominal IRB 1600 and IRB 120. Eight branches: shoulder front/back x elbow up/down x wrist
no-flip/flip, each flagged reachable and within limits.

Numerical (`numerical_ik`): damped Gauss-Newton on any model, every branch seeded by the closed
form of the model's nearest ideal geometry, so a calibrated model keeps the branch structure.
An arm whose wrist axes do not meet (the UR arms) has no such closed form: it is seeded from the
sampled configurations nearest each target, and its up to 8 slots hold the distinct solutions
found (not labelled branches).

In the arm plane a vector (x, z) is the complex number x + i z; Ry(t) turns it by -t.
"""

from __future__ import annotations

import cmath
import math
import weakref
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import ModelError, UnreachableError
from screwcal.kinematics.forward import (
    forward_kinematics,
    frame_inverses,
    point_jacobian,
    spatial_jacobian,
)
from screwcal.kinematics.model import SerialModel, once_per_object
from screwcal.kinematics.se3 import Array, rotvec_from_rotation

BRANCHES = tuple((s, e, w) for s in ("front", "back") for e in ("up", "down")
                 for w in ("noflip", "flip"))
_IDEAL_AXES = np.array([[0, 0, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]], float)


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
            close = np.abs(model.axis_dirs - _IDEAL_AXES) <= tol + 1e-5 * np.abs(_IDEAL_AXES)
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


@dataclass(frozen=True)
class IKSolutions:
    """All IK branches for N targets.

    q : (N, 8, 6) joint values in rad (controller readings, joint zero removed), NaN where a
        branch does not exist; reachable, within_limits : (N, 8) masks; branches : labels of the
        second axis; residual_mm : (N, 8) position error of each branch's FK vs the target.
    """

    q: Array
    reachable: Array
    within_limits: Array
    residual_mm: Array
    branches: tuple[tuple[str, str, str], ...] = BRANCHES
    limits: Array | None = None  # (6, 2) rad, for choosing among 2 pi-equivalent turns

    @property
    def valid(self) -> Array:
        return self.reachable & self.within_limits

    def toward(self, q_ref: ArrayLike) -> Array:
        """Every branch (N, 8, 6) with each joint moved by whole turns, inside the limits, as
        close as it gets to q_ref (N, 6) or (6,) rad."""
        q_ref = np.broadcast_to(np.asarray(q_ref, float), (self.q.shape[0], self.q.shape[2]))
        return self.q if self.limits is None else _turns_toward(self.q, q_ref[:, None, :],
                                                                 self.limits)

    def nearest(self, q_ref: ArrayLike) -> Array:
        """For each target, the valid branch closest to q_ref (N, 6) or (6,) rad: (N, 6).

        Raises UnreachableError naming the first target that has no valid branch.
        """
        q_ref = np.broadcast_to(np.asarray(q_ref, float), (self.q.shape[0], self.q.shape[2]))
        q = self.toward(q_ref)
        dist = np.where(self.valid, np.linalg.norm(q - q_ref[:, None, :], axis=-1), np.inf)
        none = ~np.isfinite(dist).any(axis=1)
        if none.any():
            k = int(np.flatnonzero(none)[0])
            why = "outside the joint limits on every branch" if self.reachable[k].any() \
                else "out of reach"
            raise UnreachableError(f"target {k} is {why} ({int(none.sum())} of "
                                   f"{len(none)} targets have no valid solution)", index=k)
        return q[np.arange(len(dist)), np.argmin(dist, axis=1)]


def _turns_toward(q: Array, q_ref: Array, limits: Array) -> Array:
    """Each joint moved by whole turns (within the limits) to be closest to q_ref: joints whose
    range passes 360 deg (J6 of the IRB 1600: +-400) have several valid readings of one pose."""
    best = q.copy()
    for turns in (-2, -1, 1, 2):
        moved = q + 2 * np.pi * turns
        inside = (moved >= limits[:, 0]) & (moved <= limits[:, 1])
        better = inside & (np.abs(moved - q_ref) < np.abs(best - q_ref))
        best = np.where(better, moved, best)
    return best


def _flange_targets(model: SerialModel, T_world_tool: ArrayLike) -> tuple[Array, Array]:
    """The targets (N, 4, 4) as given (world, tool) and as flange poses in the robot frame."""
    T_world = np.asarray(T_world_tool, dtype=float)
    if T_world.ndim != 3 or T_world.shape[1:] != (4, 4):
        raise ValueError(f"IK targets must have shape (N, 4, 4); got {T_world.shape}")
    base_inv, tool_inv = frame_inverses(model)
    T = T_world if base_inv is None else base_inv @ T_world
    return T_world, T if tool_inv is None else T @ tool_inv


_GIMBAL_TOL = 1e-12
# Per arm branch (front up, front down, back up, back down): joint 1 turned by pi for "back",
# the elbow's bend signed.
_ARM_T1_OFFSET = np.array([0.0, 0.0, np.pi, np.pi])
_ARM_ELBOW_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def _euler_xyx(W: Array) -> Array:
    """Angles (a, b, c) with W = Rx(a) Ry(b) Rx(c), b in [0, pi] (N, 3, 3) -> (N, 3): the
    wrist's joints 4, 5, 6. At b = 0 or pi only a +- c is defined: c is set to 0 (scipy's
    convention for intrinsic angles)."""
    b = np.arccos(np.clip(W[:, 0, 0], -1.0, 1.0))
    a = np.arctan2(W[:, 1, 0], -W[:, 2, 0])
    c = np.arctan2(W[:, 0, 1], W[:, 0, 2])
    lock = np.abs(np.sin(b)) < _GIMBAL_TOL
    if lock.any():
        straight = lock & (W[:, 0, 0] > 0)  # b = 0: W = Rx(a + c)
        a = np.where(straight, np.arctan2(W[:, 2, 1], W[:, 1, 1]), a)
        a = np.where(lock & ~straight, np.arctan2(W[:, 1, 2], W[:, 1, 1]), a)  # b = pi
        c = np.where(lock, 0.0, c)
    return np.stack([a, b, c], axis=-1)


def _closed_form_one(geo: WristPartitionedGeometry, T: Array) -> tuple[Array, Array]:
    """`_closed_form_theta` for one flange target (4, 4) in scalar arithmetic: the same
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
            if abs(math.sin(wb)) < _GIMBAL_TOL:  # only a +- c defined: c = 0 (as _euler_xyx)
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


_SLACK = 1e-12
_NAN_ROWS = (math.nan,) * 24  # a shoulder's four branches
_SHOULDER_T1_OFFSET = tuple(_ARM_T1_OFFSET[::2].tolist())  # per shoulder (front, back)
_ELBOW_SIGN = tuple(_ARM_ELBOW_SIGN[:2].tolist())  # per elbow (up, down)


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


def _closed_form_theta(geo: WristPartitionedGeometry, T_flange: Array, slack: float = _SLACK,
                       elbow_floor: float = 0.0) -> tuple[Array, Array]:
    """Joint angles (N, 8, 6) of the ideal geometry and the reachable mask (N, 8).

    For seeding a calibrated model: `slack` accepts targets slightly beyond full extension, and
    `elbow_floor` (rad) keeps the elbow-up and elbow-down seeds apart near it, so that each
    converges to its own branch.
    """
    N = T_flange.shape[0]
    R = T_flange[:, :3, :3]
    R_M = geo.home_flange[:3, :3]
    # Wrist centre: the flange carries the home offset (flange - wrist centre) rigidly.
    wc = T_flange[:, :3, 3] - R @ (R_M.T @ (geo.home_flange[:3, 3] - geo.wrist_home))
    u, f = geo.upper_arm, geo.forearm
    # The four arms (shoulder front/back x elbow up/down) at once, (N, 4); BRANCHES order.
    t1 = np.arctan2(wc[:, 1], wc[:, 0])[:, None] + _ARM_T1_OFFSET
    c1, s1 = np.cos(t1), np.sin(t1)
    r = wc[:, 0, None] * c1 + wc[:, 1, None] * s1
    d = (r - geo.shoulder_x) + 1j * (wc[:, 2, None] - geo.shoulder_z)
    k = (np.abs(d) ** 2 - abs(u) ** 2 - abs(f) ** 2) / (2 * abs(u) * abs(f))
    ok = np.abs(k) <= 1.0 + slack
    bend = np.maximum(np.arccos(np.clip(k, -1, 1)), elbow_floor)
    t3 = _ARM_ELBOW_SIGN * bend - np.angle(u) + np.angle(f)
    t2 = np.angle(u + f * np.exp(-1j * t3)) - np.angle(d)
    # Wrist: W = (Rz(t1) Ry(t2 + t3))^T R R_M^T = Rx(t4) Ry(t5) Rx(t6).
    c23, s23 = np.cos(t2 + t3), np.sin(t2 + t3)
    R123 = np.empty((N, 4, 3, 3))
    R123[..., 0, 0], R123[..., 0, 1], R123[..., 0, 2] = c1 * c23, -s1, c1 * s23
    R123[..., 1, 0], R123[..., 1, 1], R123[..., 1, 2] = s1 * c23, c1, s1 * s23
    R123[..., 2, 0], R123[..., 2, 1], R123[..., 2, 2] = -s23, 0.0, c23
    W = np.swapaxes(R123, -1, -2) @ (R @ R_M.T)[:, None]
    t456 = _euler_xyx(W.reshape(-1, 3, 3)).reshape(N, 4, 3)
    theta = np.empty((N, 4, 2, 6))
    theta[..., :3] = np.stack([t1, t2, t3], axis=-1)[:, :, None]
    theta[:, :, 0, 3:] = t456
    theta[:, :, 1, 3:] = t456 * (1.0, -1.0, 1.0) + (np.pi, 0.0, np.pi)  # the wrist flipped
    theta = theta.reshape(N, 8, 6)
    reach = np.repeat(ok, 2, axis=1)
    theta[~reach] = np.nan
    return theta, reach


def _wrapped(model: SerialModel, theta: Array) -> tuple[Array, Array]:
    """Joint angles (N, 8, 6), NaN where out of reach -> controller readings: the joint zero
    removed, wrapped to [-pi, pi), then moved by a turn where that brings a reading outside the
    limits inside them; and whether each branch is within the limits (N, 8).

    That rule gives each joint a window of one turn its readings fall in (`_reading_tables`),
    so a reading is the window's start plus the angle's remainder modulo a turn: five array
    calls, three when no window is closed at its top."""
    sign, shift, start, lo, hi = _reading_tables(model)
    q = theta if sign is None else theta * sign
    q = (q + shift) % _TAU
    if sign is not None:
        q *= sign
    q += start
    return q, ((q >= lo) & (q <= hi)).all(axis=-1)  # NaN compares False: out of reach is out


_TAU = 2.0 * np.pi


@once_per_object
def _reading_tables(model: SerialModel) -> tuple[Array | None, Array, Array, Array, Array]:
    """Per joint the window of one turn its readings fall in, as (sign, shift, start) with
    reading = start + sign ((sign theta + shift) mod 2 pi), and the lower and upper limits.

    The rule of `_wrapped`: wrapped to [-pi, pi), a reading below `below` (under the lower
    limit, and a turn up no further than the upper one) is turned up, one above `above` turned
    down. So the window is [-pi, pi) for most joints; [below, below + 2 pi) where a turn up can
    happen; (above - 2 pi, above] where a turn down can (sign -1: closed at its top, as the
    rule keeps a reading equal to `above`). No joint can have both (below > -pi needs
    hi > pi, above < pi needs hi < pi). `sign` is None when every joint's is +1."""
    lo, hi = model.limits[:, 0].copy(), model.limits[:, 1].copy()
    # q < lo and q + 2 pi <= hi; q > hi and q - 2 pi >= lo (nextafter: <= as <)
    below = np.minimum(lo, np.nextafter(hi - _TAU, np.inf))
    above = np.maximum(hi, np.nextafter(lo + _TAU, -np.inf))
    down = above < np.pi
    start = np.where(below > -np.pi, below, np.where(down, above, -np.pi))
    sign = np.where(down, -1.0, 1.0)
    shift = -sign * (model.joint_zero + start)
    # Shaped as one target's branches (1, 8, n): for one target the array calls then take
    # numpy's same-shape path, a third of a broadcast's cost at this size.
    sign, shift, start, lo, hi = (np.broadcast_to(a, (1, len(BRANCHES), a.size)).copy()
                                  for a in (sign, shift, start, lo, hi))
    return (sign if down.any() else None), shift, start, lo, hi


def _solutions(model: SerialModel, q: Array, reach: Array, within: Array, T_world: Array,
               check: bool = True) -> IKSolutions:
    if check:  # the FK of every branch against the target (NaN where out of reach)
        N = q.shape[0]
        T = forward_kinematics(model, q.reshape(-1, 6)).reshape(N, 8, 4, 4)
        residual = np.hypot.reduce(T[..., :3, 3] - T_world[:, None, :3, 3], axis=-1)
    else:
        residual = np.full(reach.shape, np.nan)
    return IKSolutions(q=q, reachable=reach, within_limits=within, residual_mm=residual,
                       limits=model.limits)


def closed_form_ik(model: SerialModel, T_world_tool: ArrayLike, require_all: bool = True,
                   check: bool = True) -> IKSolutions:
    """All eight closed-form solutions for targets (N, 4, 4) of an ideal ABB-type model.

    Raises UnreachableError when a target is out of reach on every branch, unless
    `require_all` is False (for screening many candidate targets: read `reachable`).
    `check`: fill `residual_mm` by FK of every branch (False: NaN, a fifth of the time saved).
    """
    geo = WristPartitionedGeometry.from_model(model)
    T_world, T_flange = _flange_targets(model, T_world_tool)
    theta, reach = _closed_form_one(geo, T_flange[0]) if len(T_flange) == 1 else \
        _closed_form_theta(geo, T_flange)
    q, within = _wrapped(model, theta)
    if require_all:
        _raise_unreachable(reach)
    return _solutions(model, q, reach, within, T_world, check)


def _raise_unreachable(reach: Array) -> None:
    if len(reach) == 1 and reach.any():  # one target: a single reduction decides
        return
    some = reach.any(axis=1)
    if some.all():
        return
    none = ~some
    k = int(np.flatnonzero(none)[0])
    raise UnreachableError(f"target {k} is out of the arm's reach on every branch "
                           f"({int(none.sum())} of {len(none)} targets unreachable)", index=k)


def _pose_error(T_target: Array, T: Array) -> Array:
    """(dp, dphi) taking T to T_target: position difference and world-frame rotation vector."""
    dR = T_target[:, :3, :3] @ np.swapaxes(T[:, :3, :3], 1, 2)
    dphi = rotvec_from_rotation(dR)
    return np.concatenate([T_target[:, :3, 3] - T[:, :3, 3], dphi], axis=1)


def _refine(model: SerialModel, targets: Array, q0: Array, tol_mm: float, tol_rad: float,
            max_iter: int, damping: float) -> tuple[Array, Array]:
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
        err = _pose_error(targets[idx], T)
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
        err = _pose_error(targets[idx], forward_kinematics(model, q[idx]))
        converged[idx] = (np.linalg.norm(err[:, :3], axis=1) < tol_mm * 10) & \
                         (np.linalg.norm(err[:, 3:], axis=1) < tol_rad * 10)
    return q, converged


def local_ik(model: SerialModel, T_world_tool: ArrayLike, q_seed: ArrayLike, *,
             tol_mm: float = 1e-9, tol_rad: float = 1e-11, max_iter: int = 30,
             damping: float = 1e-9) -> tuple[Array, Array]:
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
    _raise_unreachable(reach)
    q_wrapped, within = _wrapped(model, out)
    return _solutions(model, q_wrapped, reach, within, T_target)


@once_per_object
def _signed_ideal(model: SerialModel) -> tuple[Array, SerialModel]:
    """Per joint +1 or -1: whether its axis turns with or against the ABB-type direction it is
    nearest (KUKA's A1, A4, A6 and FANUC's J3-J6 turn the other way), and the model with those
    axes reversed, whose angles are the signs times the model's: the closed form seeds it."""
    signs = np.where(np.einsum("ij,ij->i", model.axis_dirs, _IDEAL_AXES) < 0, -1.0, 1.0)
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
    theta0, reach0 = _closed_form_theta(geo, T_flange, slack=0.05, elbow_floor=0.02)
    theta0 = theta0 * signs
    _raise_unreachable(reach0)
    N = T_target.shape[0]
    q0 = np.nan_to_num(theta0 - model.joint_zero).reshape(-1, 6)
    active = reach0.reshape(-1)
    q, converged = q0.copy(), np.zeros_like(active)
    q[active], converged[active] = _refine(model, np.repeat(T_target, 8, axis=0)[active],
                                           q0[active], tol_mm, tol_rad, max_iter, damping)
    reach = converged.reshape(N, 8)
    _raise_unreachable(reach)
    q[~converged] = np.nan
    q_wrapped, within = _wrapped(model, q.reshape(N, 8, 6) + model.joint_zero)
    return _solutions(model, q_wrapped, reach, within, T_target)
