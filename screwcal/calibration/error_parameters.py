"""Error models: which geometric parameters are identified, their names, units and Jacobians.

A parameter vector x (numeric units: rad, mm) applies to a reference model by `apply`, and
`linearisation` gives the rates of the tool point and of its rotation w.r.t. x (and the
joints) exactly (not only at x = 0), so that the solver gets the true Jacobian of the
residuals at every step.

Candidates, per model kind (thesis 2.2.1.2, 3.1, Table 11; Eq. 2.2):

- "frames": nothing of the robot: the nominal model with only the frames fitted (the
  uncalibrated robot's accuracy, the "before" of a calibration).
- "joints": the joint offsets J<i> (what a closed controller can correct, thesis Table 9).
- "thesis": the joint offsets and the link offsets J1pz, J1px, J2pz, J4px (virtual prismatic
  joints after joint i along the home-frame axis, `virtual_joints`).
- compliance (any robot kind, `compliance="j23"` or `"wrist"`): per loaded joint its compliance
  under gravity, J<i>c in deg per kN m (`screwcal.kinematics.compliance`): a joint offset that
  grows with the gravity torque on the joint.
- "full": per revolute joint its direction (2 angles about the two normals of the nominal
  axis), its location (2 shifts along those normals) and its zero; per prismatic joint its
  direction; plus the home flange (3 rotations, 3 translations). The identification keeps an
  independent subset (rank-revealing QR): 4r + 2p + 6 = 30 for a 6R arm with full-pose data
  (Eq. 2.2).

Frames, in every model: the measuring system's frame (`base`: rotation vector and translation
relative to the starting guess) and the measured point's frame on the flange (`tool`), each
identified or known. For position data the tool rotation is not observable; for distance data
the base is not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from screwcal.calibration.parameter_kinds import Carrier, Param, ParamKind
from screwcal.calibration.virtual_joints import parse_name
from screwcal.errors import ModelError
from screwcal.kinematics.compliance import (
    COMPLIANCE_JOINTS,
    COMPLIANCE_UNIT,
    FREE_COMPLIANCE,
    gravity_torques_by_mass,
)
from screwcal.kinematics.forward import (
    checked_joints,
    homogeneous,
    joint_torques_by_mass,
    screw_chain,
)
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import (
    Array,
    cross,
    rotation_from_rotvec,
    skew,
)

ModelKind = Literal["frames", "joints", "thesis", "full"]
THESIS_LINK_OFFSETS = ("J1pz", "J1px", "J2pz", "J4px")
# Table 11's names of the joint offsets. Joint 3 turns about y in the usual frame; the thesis
# still writes J3rz (the thesis, Table 11): it is the joint-3 offset.
THESIS_JOINT_OFFSETS = ("J1rz", "J2ry", "J3rz", "J4rx", "J5ry", "J6rx")


def _frame_params(frame: str, rotation: bool, position: bool) -> list[Param]:
    out = []
    if rotation:
        out += [Param(f"{frame}.r{c}", "deg", ParamKind(f"{frame}_rot"), axis=k)
                for k, c in enumerate("xyz")]
    if position:
        out += [Param(f"{frame}.{c}", "mm", ParamKind(f"{frame}_pos"), axis=k)
                for k, c in enumerate("xyz")]
    return out


def compliance_params(model: SerialModel, compliance: str) -> list[Param]:
    """J<i>c for the joints `compliance` names ("none", "j23", "wrist")."""
    if compliance not in COMPLIANCE_JOINTS:
        raise ModelError(f"compliance is one of {', '.join(COMPLIANCE_JOINTS)}, not "
                         f"'{compliance}'")
    joints = [j for j in COMPLIANCE_JOINTS[compliance]
              if j < model.n_joints and model.joint_types[j] == "R"]
    if joints and not model.all_masses:
        raise ModelError(f"model '{model.name}' has no masses to load its joints: joint "
                         "compliance needs a built-in robot's mass table or a payload")
    if compliance in FREE_COMPLIANCE:  # per joint and arm mass that loads it
        return [Param(f"J{j + 1}c.m{k + 1}", COMPLIANCE_UNIT, ParamKind.COMPLIANCE_MASS,
                      joint=j, axis=k)
                for j in joints for k, m in enumerate(model.masses) if m.link >= j]
    return [Param(f"J{j + 1}c", COMPLIANCE_UNIT, ParamKind.COMPLIANCE, joint=j) for j in joints]


def candidate_params(model: SerialModel, kind: ModelKind, *, base: bool, tool_rotation: bool,
                     tool_position: bool, link_offsets: Sequence[str] | None = None,
                     compliance: str = "none") -> list[Param]:
    """Every candidate parameter of an error model, frames first (they are always needed).
    `link_offsets` names the thesis model's virtual prismatic joints (default: the 6R's
    J1pz, J1px, J2pz, J4px; the planar 3R'2P'3R of 3.1 uses J1px, J2px); `compliance` adds
    the joints' compliance under gravity (`compliance_params`)."""
    gravity = compliance_params(model, compliance) if kind != "frames" else []
    return _candidates(model, kind, base, tool_rotation, tool_position, link_offsets) + gravity


def _candidates(model: SerialModel, kind: ModelKind, base: bool, tool_rotation: bool,
                tool_position: bool, link_offsets: Sequence[str] | None) -> list[Param]:
    params = _frame_params("base", base, base)
    params += _frame_params("tool", tool_rotation, tool_position)
    n = model.n_joints
    zeros = [Param(f"J{i + 1}", "deg" if model.joint_types[i] == "R" else "mm", ParamKind.ZERO,
                   joint=i)
             for i in range(n)]
    if kind == "thesis":  # named as the thesis names them (Tables 2, 11)
        zeros = [replace(z, name=_thesis_offset_name(model, z.joint)) for z in zeros]
    if kind == "frames":
        return params
    if kind == "joints":
        return params + zeros
    if kind == "thesis":
        if link_offsets is None and n != 6:
            raise ModelError("name the link offsets of the thesis model for a non-6R arm")
        links = []
        for name in (THESIS_LINK_OFFSETS if link_offsets is None else link_offsets):
            j, _, axis = parse_name(name)
            links.append(Param(name, "mm", ParamKind.LINK, joint=j, axis=axis))
        return params + zeros + links
    robot: list[Param] = []
    for i in range(n):
        robot += [Param(f"J{i + 1}.dir.{c}", "deg", ParamKind.DIR, joint=i, axis=k)
                  for k, c in enumerate("uv")]
        if model.joint_types[i] == "R":
            robot += [Param(f"J{i + 1}.pos.{c}", "mm", ParamKind.POINT, joint=i, axis=k)
                      for k, c in enumerate("uv")]
        robot.append(zeros[i])
    robot += _frame_params("home", True, True)
    return params + robot


def _thesis_offset_name(model: SerialModel, joint: int) -> str:
    """Table 11's names for a 6R arm; otherwise J<i>r<axis of the joint at home>."""
    if model.n_joints == 6:
        return THESIS_JOINT_OFFSETS[joint]
    axis = "xyz"[int(np.argmax(np.abs(model.axis_dirs[joint])))]
    return f"J{joint + 1}r{axis}"


def _frame_sides(frames: Sequence[Array], p: Array) -> Array:
    """(3N, 6C): per pose the frames' rotations R and [p - t]x R side by side (the C frames
    (N, 3, 4) with their origins t, the tool point p (N, 3)): R v - [p - t]x R w is the
    point's rate from a local twist (w, v) carried by the frame (`linearisation`)."""
    C, N = len(frames), len(p)
    out = np.empty((N, 3, 2, C, 3))
    R = out[:, :, 0]  # (N, 3, C, 3): row l of every frame's rotation
    arm = np.empty((N, C, 3))
    for c, frame in enumerate(frames):
        R[:, :, c] = frame[:, :, :3]
        np.subtract(p, frame[:, :, 3], out=arm[:, c])
    a0, a1, a2 = (arm[:, :, k, None] for k in range(3))
    out[:, 0, 1] = a1 * R[:, 2] - a2 * R[:, 1]  # the rows of [a]x R, a = p - t
    out[:, 1, 1] = a2 * R[:, 0] - a0 * R[:, 2]
    out[:, 2, 1] = a0 * R[:, 1] - a1 * R[:, 0]
    return out.reshape(3 * N, 6 * C)


def _rot_jacobian_left(phi: Array) -> Array:
    """Left Jacobian of SO(3): exp(phi + d) = exp(J_l(phi) d) exp(phi) to first order."""
    theta = float(np.linalg.norm(phi))
    K = skew(phi)
    if theta < 1e-8:
        return np.eye(3) + 0.5 * K
    return (np.eye(3) + (1 - np.cos(theta)) / theta**2 * K
            + (theta - np.sin(theta)) / theta**3 * K @ K)


@dataclass(frozen=True)
class ErrorModel:
    """A reference model and the parameters identified on it."""

    reference: SerialModel
    params: tuple[Param, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    def subset(self, keep: Sequence[int]) -> ErrorModel:
        return ErrorModel(self.reference, tuple(self.params[k] for k in keep))

    def to_interface(self, x: ArrayLike) -> Array:
        """Numeric values (rad, mm) -> interface units (deg, mm)."""
        x = np.asarray(x, dtype=float)
        return np.where([p.is_angle for p in self.params], np.degrees(x), x)

    def from_interface(self, values: ArrayLike) -> Array:
        v = np.asarray(values, dtype=float)
        return np.where([p.is_angle for p in self.params], np.radians(v), v)

    # -- applying x ------------------------------------------------------------------------
    def _collect(self, x: Array) -> dict[str, Any]:
        m = self.reference
        n = m.n_joints
        out: dict[str, Any] = {"zero": np.zeros(n), "compliance": np.zeros(n),
               "compliance_mass": np.zeros((n, len(m.masses))), "link": {},
               "dir": np.zeros((n, 2)), "point": np.zeros((n, 2)),
               "home_rot": np.zeros(3), "home_pos": np.zeros(3), "base_rot": np.zeros(3),
               "base_pos": np.zeros(3), "tool_rot": np.zeros(3), "tool_pos": np.zeros(3)}
        for p, v in zip(self.params, x, strict=True):
            if p.kind in ("zero", "compliance"):
                out[p.kind][p.joint] += v
            elif p.kind == "link":
                out["link"][p.name] = v
            elif p.kind in ("dir", "point", "compliance_mass"):
                out[p.kind][p.joint, p.axis] += v
            else:
                out[p.kind][p.axis] += v
        return out

    def apply(self, x: ArrayLike) -> SerialModel:
        """The model with the parameter values x (numeric units) applied to the reference."""
        x = np.asarray(x, dtype=float)
        m = self.reference
        c = self._collect(x)
        normals = self._normals_table
        dirs = m.axis_dirs + np.einsum("nk,nkj->nj", c["dir"], normals)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        points = m.axis_points_mm + np.einsum("nk,nkj->nj", c["point"], normals)
        for name, value in c["link"].items():  # as virtual_joints.apply_virtual_joints
            j, _, axis = parse_name(name)
            points[j + 1:, axis] += value
            c["home_pos"][axis] += value

        def framed(T0: Array, rot: Array, pos: Array) -> Array:
            if not rot.any() and not pos.any():
                return T0
            T = T0.copy()
            T[:3, :3] = rotation_from_rotvec(rot) @ T0[:3, :3]
            T[:3, 3] += pos
            return T

        by_mass = m.compliance_by_mass
        if "compliance_mass" in self._layout["kinds"]:
            by_mass = (np.zeros_like(c["compliance_mass"]) if by_mass is None else by_mass) \
                + c["compliance_mass"] / 1000.0
        return m.derived(axis_dirs=dirs, axis_points_mm=points,
                         joint_zero=m.joint_zero + c["zero"],
                         compliance=m.compliance + c["compliance"] / 1000.0,  # per kN m -> N m
                         compliance_by_mass=by_mass,
                         home_flange=framed(m.home_flange, c["home_rot"], c["home_pos"]),
                         base=framed(m.base, c["base_rot"], c["base_pos"]),
                         tool=framed(m.tool, c["tool_rot"], c["tool_pos"]))

    # -- the Jacobian ----------------------------------------------------------------------
    @cached_property
    def _normals_table(self) -> Array:
        """(n, 2, 3): the two normals of each reference axis (fixed for this error model)."""
        w = self.reference.axis_dirs
        helper = np.where((np.abs(w[:, 0]) < 0.9)[:, None], [1.0, 0, 0], [0, 1.0, 0])
        u = np.cross(w, helper)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        return np.stack([u, np.cross(w, u)], axis=1)

    @cached_property
    def _layout(self) -> dict:
        """Column indices by kind, each column's joint and axis, fixed for this error model."""
        kinds: dict[str, list[int]] = {}
        for col, p in enumerate(self.params):
            kinds.setdefault(p.kind, []).append(col)
        idx = {k: np.array(v, dtype=int) for k, v in kinds.items()}
        joint = np.array([p.joint for p in self.params], dtype=int)
        axis = np.array([p.axis for p in self.params], dtype=int)
        return {"kinds": idx, "joint": joint, "axis": axis}

    @cached_property
    def _carriers(self) -> tuple[Array, Array]:
        """Per column, the frame that carries its local twist to the world and the frame whose
        carried twist is subtracted (-1: none), among the frames `linearisation` stacks: the
        partial products A_0..A_n, the flange pose (n + 1) and the identity (n + 2); from
        each kind's carrier (`ParamKind.carrier`)."""
        n, P = self.reference.n_joints, len(self.params)
        first, second = np.empty(P, dtype=int), np.full(P, -1)
        for col, p in enumerate(self.params):
            carrier = p.kind.carrier
            if carrier is Carrier.JOINT:
                first[col] = p.joint
            elif carrier is Carrier.NEXT_JOINT:
                first[col] = p.joint + 1
            elif carrier is Carrier.AXIS:  # a displacement of axis i: Ad_{A_i} - Ad_{A_i+1}
                first[col], second[col] = p.joint, p.joint + 1
            elif carrier is Carrier.HOME:
                first[col] = n
            elif carrier is Carrier.TOOL:
                first[col] = n + 1
            else:
                first[col] = n + 2
        return first, second

    def linearisation(self, x: ArrayLike, q: ArrayLike) -> tuple[Array, Array, Array]:
        """Tool poses T (N, 4, 4) and the rates of the tool point (mm) and of its rotation
        vector (rad), rows (dx, dy, dz, dphi_x, dphi_y, dphi_z) as a pose residual's: w.r.t.
        the parameters (N, 6, P) and w.r.t. the joints (N, 6, n), exact at x, from one chain.

        A local twist (w, v) carried by a frame (R, t) moves the tool point p at
        dp = R v + (R w) x (p - t) = R v - [p - t]x R w, and turns it at R w. With the frames'
        R and [p - t]x R side by side, (3N, 3C) each for the C frames (the partial products,
        the flange, the identity), and every column's local twist placed in its carrier's
        block of a (3C, P + n) table (minus the subtracted frame's), all the columns, the
        joints' too, are two matrix products: no loop over parameters or carriers."""
        x = np.asarray(x, dtype=float)
        model = self.apply(x)
        q = checked_joints(model, q)
        tau = None
        if model.has_compliance:  # the torques at the unbent configuration, once
            tau = joint_torques_by_mass(model, q)
        A_end, partial = screw_chain(model, q, keep=True, tau=tau)
        if tau is None and self._has_compliance_columns:  # unbent: the same chain
            tau = gravity_torques_by_mass(model.axis_dirs, model.axis_points_mm, partial,
                                          model.all_masses, model.base[:3, 2])
        N, n = q.shape
        C = n + 3
        flange = (A_end.reshape(-1, 4) @ model.home_flange).reshape(N, 3, 4)
        world = np.zeros((N, 3, 4))
        world[:, :, :3] = np.eye(3)
        T = homogeneous((flange.reshape(-1, 4) @ model.tool).reshape(N, 3, 4))
        sides = _frame_sides([*partial, flange, world], T[:, :3, 3])
        W, V = self._twist_tables(model, self._collect(x), C)
        J = np.empty((N, 6, W.shape[1]))
        J[:, :3] = (sides @ np.vstack([V, -W])).reshape(N, 3, -1)
        J[:, 3:] = (sides[:, :3 * C] @ W).reshape(N, 3, -1)
        P = len(self.params)
        if tau is not None:
            self._scale_compliance(J[:, :, :P], tau, len(model.masses))
        return T, J[:, :, :P], J[:, :, P:]

    @cached_property
    def _has_compliance_columns(self) -> bool:
        return any(k in self._layout["kinds"] for k in ("compliance", "compliance_mass"))

    def _twist_tables(self, model: SerialModel, c: dict[str, Any], C: int
                      ) -> tuple[Array, Array]:
        """The local twists (w: W, v: V) of every parameter, then of every joint, each placed
        in its carrier's 3-row block (minus in the subtracted frame's): (3 C, P + n) each."""
        local = self._local_twists(model, c)
        n, P = model.n_joints, len(self.params)
        first, second = self._carriers
        joints = np.arange(n)
        rev = model.is_revolute[:, None]
        w_joint = np.where(rev, model.axis_dirs, 0.0)
        v_joint = np.where(rev, cross(model.axis_points_mm, model.axis_dirs), model.axis_dirs)
        table = np.zeros((2, C, 3, P + n))
        cols = np.arange(P)
        table[0, first, :, cols] = local[:3].T
        table[1, first, :, cols] = local[3:].T
        two = second >= 0
        table[0, second[two], :, cols[two]] -= local[:3, two].T
        table[1, second[two], :, cols[two]] -= local[3:, two].T
        table[0, joints, :, P + joints] = w_joint
        table[1, joints, :, P + joints] = v_joint
        return table[0].reshape(3 * C, -1), table[1].reshape(3 * C, -1)

    def _local_twists(self, model: SerialModel, c: dict[str, Array]) -> Array:
        """Each parameter's twist (6, P) in the frame of its carrier, at the model of x."""
        lay = self._layout
        normals = self._normals_table
        local = np.zeros((6, len(self.params)))
        kinds, joint, axis = lay["kinds"], lay["joint"], lay["axis"]
        for kind in ("zero", "compliance", "compliance_mass"):  # compliance: a zero scaled by
            # the torque (_scale_compliance)
            if kind not in kinds:
                continue
            cols = kinds[kind]
            j = joint[cols]
            w = model.axis_dirs[j]
            rev = model.is_revolute[j]
            local[:3, cols] = np.where(rev[:, None], w, 0.0).T
            local[3:, cols] = np.where(rev[:, None], cross(model.axis_points_mm[j], w), w).T
        if "link" in kinds:
            cols = kinds["link"]
            local[3 + axis[cols], cols] = 1.0  # a translation of the chain after the joint
        if "point" in kinds:
            cols = kinds["point"]
            local[3:, cols] = normals[joint[cols], axis[cols]].T
        if "dir" in kinds:
            cols = kinds["dir"]
            j = joint[cols]
            w, pt = model.axis_dirs[j], model.axis_points_mm[j]
            e = normals[j, axis[cols]]
            raw = self.reference.axis_dirs[j] + np.einsum("kc,kcj->kj", c["dir"][j], normals[j])
            dw = (e - np.sum(e * w, axis=1, keepdims=True) * w) / np.linalg.norm(
                raw, axis=1, keepdims=True)  # d normalize(raw)/dx
            a = cross(w, dw)
            local[:3, cols] = a.T
            local[3:, cols] = cross(pt, a).T
        for frame, T0 in (("home", model.home_flange), ("base", model.base),
                          ("tool", model.tool)):
            if f"{frame}_rot" in kinds:
                cols = kinds[f"{frame}_rot"]
                w = _rot_jacobian_left(c[f"{frame}_rot"])[:, axis[cols]]
                local[:3, cols] = w
                local[3:, cols] = cross(T0[:3, 3], w.T).T  # about the frame origin
            if f"{frame}_pos" in kinds:
                cols = kinds[f"{frame}_pos"]
                local[3 + axis[cols], cols] = 1.0
        return local

    def _scale_compliance(self, J: Array, tau: Array, arm: int) -> None:
        """The compliance columns of J (N, 6, P), in place, from the gravity torques tau
        (N, n, M) per mass (`arm` of them the arm's): d theta_j / d c_j = tau_j(q),
        d theta_j / d C_jk = tau_jk(q) with the payload's torque riding on the last arm mass's
        coefficient (kN m; the bending's own effect on tau is of second order)."""
        kinds, joint, axis = self._layout["kinds"], self._layout["joint"], self._layout["axis"]
        if "compliance" in kinds:
            cols = kinds["compliance"]
            J[:, :, cols] *= tau.sum(axis=2)[:, joint[cols]][:, None, :] / 1000.0
        if "compliance_mass" in kinds:
            cols = kinds["compliance_mass"]
            if tau.shape[2] > arm:
                tau = tau.copy()
                tau[:, :, arm - 1] += tau[:, :, arm]
            J[:, :, cols] *= tau[:, joint[cols], axis[cols]][:, None, :] / 1000.0
