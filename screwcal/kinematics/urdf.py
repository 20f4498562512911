"""URDF <-> the screw model: the calibrated robot for ROS and offline programming, and any
URDF's serial chain read in.

Written as ROS-Industrial's robot packages name things: links `base_link`, `link_1` ..
`link_6`, `flange` (x out of the flange), `tool0` (z out: screwcal's flange frame); joints
`joint_1` .. `joint_6`, `joint_6-flange`, `flange-tool0`. A calibrated model's joint origins
carry the calibration (as robot_calibration writes them): link i's frame sits on joint i's axis
where the chain stands when the controller reads 0 (the joint zeros folded in), so the URDF's
joint values are the controller's. The measuring system's frame (`measuring_frame`, under
`base_link`) and the measured point (`measured_point`, under `tool0`) are links of their own.
Lumped masses become point-mass `inertial`s (one per link: masses of a link are merged). URDF has
no joint compliance; a model with some is written without it, and says so.

Read with the standard library's XML parser rather than a URDF package: the chain needs only
joint origins, axes, limits and link masses, no meshes, and the core takes no new dependency
for it. Units: URDF's metres and radians, converted at this boundary.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import LumpedMass
from screwcal.kinematics.model import PRISMATIC, SerialModel
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, rotation_from_euler_zyx_deg
from screwcal.kinematics.se3 import Array, exp_twist, invert_transform

_RY90 = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])  # flange -> tool0


def _origin(T: Array) -> str:
    xyz = " ".join(repr(float(v) / 1000.0) for v in T[:3, 3])
    rpy = " ".join(repr(math.radians(float(v))) for v in euler_zyx_deg_from_rotation(T[:3, :3]))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _joint_motion(model: SerialModel, i: int, value: float) -> Array:
    """exp([S_i] value): joint i moved by `value` (rad or mm) in the base frame."""
    w, p = model.axis_dirs[i], model.axis_points_mm[i]
    if model.joint_types[i] == PRISMATIC:
        return exp_twist(np.r_[0.0, 0.0, 0.0, w * value])
    return exp_twist(np.r_[w * value, -np.cross(w, p) * value])


def link_frames(model: SerialModel) -> tuple[list[Array], Array]:
    """Link frames 1..n (robot base frame) with the controller reading 0, and tool0's there."""
    A = np.eye(4)
    frames = []
    for i in range(model.n_joints):
        R_prev, t_prev = A[:3, :3], A[:3, 3]
        A = A @ _joint_motion(model, i, float(model.joint_zero[i]))
        F = np.eye(4)
        F[:3, :3] = A[:3, :3]
        F[:3, 3] = R_prev @ model.axis_points_mm[i] + t_prev  # on the axis, moved by 1..i-1
        frames.append(F)
    return frames, A @ model.home_flange


def urdf_from_model(model: SerialModel) -> str:
    """The URDF document of a model (see the module docstring)."""
    frames, tool0 = link_frames(model)
    n = model.n_joints
    masses: dict[int, list[tuple[float, Array]]] = {}
    for m in model.masses:
        # home_mm is where the mass sits with every joint angle 0; at the controller's 0 the
        # joints up to its link stand at their zeros
        A = np.eye(4)
        for i in range(m.link + 1):
            A = A @ _joint_motion(model, i, float(model.joint_zero[i]))
        A = A @ _joint_motion(model, m.link, 0.0)
        masses.setdefault(m.link, []).append((m.kg, A[:3, :3] @ np.asarray(m.home_mm, float)
                                               + A[:3, 3]))
    lines = ['<?xml version="1.0"?>',
             f'<!-- {model.name}: written by screwcal robot export; lengths m, angles rad -->',
             f'<robot name="{model.name}">', '  <link name="base_link"/>']
    parent, F_parent = "base_link", np.eye(4)
    for i in range(n):
        link = f"link_{i + 1}"
        inertial = ""
        if i in masses:
            kg = sum(k for k, _ in masses[i])
            com = sum(k * c for k, c in masses[i]) / kg
            local = invert_transform(frames[i]) @ np.r_[com, 1.0]
            xyz = " ".join(repr(v / 1000.0) for v in local[:3].tolist())
            inertial = (f'<inertial><origin xyz="{xyz}" rpy="0 0 0"/><mass value='
                        f'"{float(kg)!r}"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" '
                        'izz="0"/></inertial>')
        lines.append(f'  <link name="{link}">{inertial}</link>' if inertial else
                     f'  <link name="{link}"/>')
        kind = "prismatic" if model.joint_types[i] == PRISMATIC else "revolute"
        lo, hi = (model.limits[i] / (1000.0 if kind == "prismatic" else 1.0)).tolist()
        axis = " ".join(repr(float(v)) for v in model.axis_dirs[i])
        lines.append(f'  <joint name="joint_{i + 1}" type="{kind}"><parent link="{parent}"/>'
                     f'<child link="{link}"/>{_origin(invert_transform(F_parent) @ frames[i])}'
                     f'<axis xyz="{axis}"/><limit lower="{lo!r}" upper="{hi!r}" effort="0" '
                     'velocity="0"/></joint>')
        parent, F_parent = link, frames[i]
    flange = tool0 @ invert_transform(_RY90)
    lines += ['  <link name="flange"/>', '  <link name="tool0"/>',
              f'  <joint name="joint_{n}-flange" type="fixed"><parent link="{parent}"/>'
              f'<child link="flange"/>{_origin(invert_transform(F_parent) @ flange)}</joint>',
              '  <joint name="flange-tool0" type="fixed"><parent link="flange"/>'
              f'<child link="tool0"/>{_origin(_RY90)}</joint>',
              '  <link name="measuring_frame"/>',
              '  <joint name="base_link-measuring_frame" type="fixed"><parent link="base_link"/>'
              f'<child link="measuring_frame"/>{_origin(invert_transform(model.base))}</joint>',
              '  <link name="measured_point"/>',
              '  <joint name="tool0-measured_point" type="fixed"><parent link="tool0"/>'
              f'<child link="measured_point"/>{_origin(model.tool)}</joint>',
              '</robot>']
    return "\n".join(lines) + "\n"


def _floats(text: str | None, n: int, where: str) -> Array:
    if text is None:
        return np.zeros(n)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise ModelError(f"{where}: not {n} numbers: '{text}'") from None
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise ModelError(f"{where}: not {n} finite numbers: '{text}'")
    return values


def _transform(elem: ET.Element | None, where: str) -> Array:
    T = np.eye(4)
    if elem is None:
        return T
    T[:3, 3] = _floats(elem.get("xyz"), 3, f"{where} origin xyz") * 1000.0
    T[:3, :3] = rotation_from_euler_zyx_deg(np.degrees(_floats(elem.get("rpy"), 3,
                                                               f"{where} origin rpy")))
    return T


def model_from_urdf(text: str, source: str = "URDF", name: str | None = None
                    ) -> tuple[SerialModel, list[str]]:
    """The serial chain of a URDF from `base_link` (else the root) to `tool0` (else `flange`,
    else the chain's end), with limits and link masses, and notes on what was assumed."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise ModelError(f"{source}: not a URDF (XML error: {err})") from None
    if root.tag != "robot":
        raise ModelError(f"{source}: not a URDF (root element <{root.tag}>, not <robot>)")
    links = {e.get("name", ""): e for e in root.findall("link")}
    by_child: dict[str, ET.Element] = {}  # child link -> its joint
    parent_of: dict[str, str] = {}  # child link -> parent link
    for j in root.findall("joint"):
        child, parent = j.find("child"), j.find("parent")
        if child is None or parent is None:
            raise ModelError(f"{source}: joint '{j.get('name')}' without parent or child")
        by_child[child.get("link", "")] = j
        parent_of[child.get("link", "")] = parent.get("link", "")
    children = set(parent_of.values())
    roots = [n for n in links if n not in by_child]
    start = "base_link" if "base_link" in links else (roots[0] if roots else None)
    if start is None:
        raise ModelError(f"{source}: no root link")
    tip: str | None = next((t for t in ("tool0", "flange") if t in links), None)
    notes = []
    if tip is None:
        leaves = [n for n in links if n not in children]
        tip = max(leaves, key=lambda n: len(_path(parent_of, n, start) or []))
        notes.append(f"no tool0 or flange link: the flange is link '{tip}'")
    path = _path(parent_of, tip, start)
    if path is None:
        raise ModelError(f"{source}: link '{tip}' does not hang from '{start}'")
    T = np.eye(4)
    dirs, points, types, limits = [], [], [], []
    masses = []
    for child_link in path:
        joint = by_child[child_link]
        jname = joint.get("name")
        kind = joint.get("type")
        if joint.find("mimic") is not None:
            raise ModelError(f"{source}: joint '{jname}' mimics another: not a serial arm")
        T = T @ _transform(joint.find("origin"), f"{source}: joint '{jname}'")
        if kind in ("revolute", "continuous", "prismatic"):
            axis_element = joint.find("axis")
            axis = _floats("1 0 0" if axis_element is None else axis_element.get("xyz"), 3,
                           f"{source}: joint '{jname}' axis")
            if np.linalg.norm(axis) == 0:
                raise ModelError(f"{source}: joint '{jname}': zero axis")
            dirs.append(T[:3, :3] @ (axis / np.linalg.norm(axis)))
            points.append(T[:3, 3].copy())
            types.append("P" if kind == "prismatic" else "R")
            limit = joint.find("limit")
            if kind == "continuous" or limit is None:
                limits.append([-2 * math.pi, 2 * math.pi] if kind != "prismatic" else [-1e3, 1e3])
                notes.append(f"joint '{jname}' has no limits: +-360 deg assumed")
            else:
                lo, hi = float(limit.get("lower", "0")), float(limit.get("upper", "0"))
                limits.append([lo * 1000.0, hi * 1000.0] if kind == "prismatic" else [lo, hi])
        elif kind != "fixed":
            raise ModelError(f"{source}: joint '{jname}' of type '{kind}': not a serial arm")
        inertial = links[child_link].find("inertial")
        mass = None if inertial is None else inertial.find("mass")
        if inertial is not None and types and mass is not None:
            kg = float(mass.get("value", "0"))
            if kg > 0:
                com = (T @ _transform(inertial.find("origin"), f"{source}: inertial"))[:3, 3]
                masses.append(LumpedMass(len(types) - 1, kg, tuple(com.tolist())))
    if not types:
        raise ModelError(f"{source}: no moving joint between '{start}' and '{tip}'")
    home = T @ (_RY90 if tip == "flange" else np.eye(4))
    base, tool = _measuring_frames(links, by_child, source)
    model = SerialModel(name=name or root.get("name") or Path(source).stem,
                        joint_types=tuple(types), axis_dirs=np.array(dirs),
                        axis_points_mm=np.array(points), home_flange=home,
                        limits=np.array(limits), base=base, tool=tool, masses=tuple(masses))
    return model, notes


def _measuring_frames(links: dict[str, ET.Element], by_child: dict[str, ET.Element],
                      source: str) -> tuple[Array, Array]:
    """Base (world from robot base) and tool (flange to measured point) from the links
    `measuring_frame` and `measured_point` where the file has them; identity otherwise."""
    base, tool = np.eye(4), np.eye(4)
    if "measuring_frame" in links and by_child.get("measuring_frame") is not None:
        j = by_child["measuring_frame"]
        base = invert_transform(_transform(j.find("origin"), f"{source}: measuring_frame"))
    if "measured_point" in links and by_child.get("measured_point") is not None:
        tool = _transform(by_child["measured_point"].find("origin"), f"{source}: measured_point")
    return base, tool


def _path(parent_of: dict[str, str], tip: str, start: str) -> list[str] | None:
    """The links from `start` down to `tip` (each named by the child link of its joint, `start`
    itself left out), or None when `tip` does not hang from `start`."""
    path = []
    link = tip
    while link != start:
        parent = parent_of.get(link)
        if parent is None:
            return None
        path.append(link)
        link = parent
    return path[::-1]
