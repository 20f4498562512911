"""URDF <-> the screw model: the calibrated robot for ROS and offline programming, and any
URDF's serial chain read in.

Written as ROS-Industrial's robot packages name things: links `base_link`, `link_1` ..
`link_6`, `flange` (x out of the flange), `tool0` (z out: screwcal's flange frame); joints
`joint_1` .. `joint_6`, `joint_6-flange`, `flange-tool0`. A calibrated model's joint origins
carry the calibration (as robot_calibration writes them): link i's frame sits on joint i's axis
where the chain stands when the controller reads 0 (the joint zeros folded in), so the URDF's
joint values are the controller's (a FANUC arm's J2/J3 coupling written in as a mimic joint,
`joint_3_coupling`, so that joint_3 takes FANUC's J3; read back as one serial joint). The
measuring system's frame (`measuring_frame`, under `base_link`) and the measured point
(`measured_point`, under `tool0`) are links of their own.
Lumped masses become point-mass `inertial`s (one per link: masses of a link are merged). URDF has
no joint compliance; a model with some is written without it, and says so.

Read (`urdf_tree`: the document checked and refused by file, line and element, XML attacks
refused by defusedxml) rather than through a URDF package: the chain needs only joint origins,
axes, limits and link masses, no meshes. The chain may start at any link fixed to the base
(`base_link`, or ROS-Industrial's `base`, the controller's frame) and end at any link.
Units: URDF's metres and radians, converted at this boundary.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import LumpedMass
from screwcal.kinematics.model import PRISMATIC, JointRating, SerialModel
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, pose_from_transform
from screwcal.kinematics.se3 import Array, exp_twist, invert_transform
from screwcal.kinematics.urdf_tree import Joint, Origin, UrdfTree, read_tree

_RY90 = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])  # flange -> tool0


def _origin(T: Array) -> str:
    xyz = " ".join(repr(float(v) / 1000.0) for v in T[:3, 3])
    rpy = " ".join(repr(math.radians(float(v))) for v in euler_zyx_deg_from_rotation(T[:3, :3]))
    return f'<origin xyz="{xyz}" rpy="{rpy}"/>'


def _joint_names(model: SerialModel) -> list[str]:
    """The names the description gave (URDF's joint_a1, shoulder_pan_joint), else joint_1 ..
    joint_n (also when the given ones are not unique or collide with the links' names)."""
    default = [f"joint_{i + 1}" for i in range(model.n_joints)]
    if not model.ratings:
        return default
    given = [r.name or d for r, d in zip(model.ratings, default, strict=True)]
    reserved = {"joint_3_coupling", f"joint_{model.n_joints}-flange", "flange-tool0",
                "base_link-measuring_frame", "tool0-measured_point"}
    if len(set(given)) < len(given) or reserved & set(given) or \
            any(not re.fullmatch(r"[\w.\-/]+", g) for g in given):
        return default
    return given


def _rating(model: SerialModel, i: int) -> tuple[float, float]:
    """URDF's effort (N m, N) and velocity (rad/s, m/s) of joint i: the description's, else 0
    (unknown, as ROS-Industrial's files write it)."""
    if not model.ratings:
        return 0.0, 0.0
    r = model.ratings[i]
    speed = 0.0 if r.velocity is None else r.velocity / (
        1000.0 if model.joint_types[i] == PRISMATIC else 1.0)
    return float(r.effort or 0.0), float(speed)


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


def urdf_from_model(model: SerialModel, j23_coupling: bool = False,
                    more_links: Sequence[tuple[str, Array]] = ()) -> str:
    """The URDF document of a model (see the module docstring). `j23_coupling`: FANUC's J2/J3
    coupling written in, so that joint_3 takes the controller's J3 reading (J3 = q3 - q2): a
    joint `joint_3_coupling` on joint 3's axis that mimics joint_2, then joint_3 on the same
    axis. `more_links`: links fixed to base_link, by name and pose in it (mm), e.g.
    ROS-Industrial's `base`, the frame the controller reports in."""
    if j23_coupling and (model.n_joints < 3 or model.joint_types[1:3] != ("R", "R")):
        raise ModelError(f"model '{model.name}': FANUC's J2/J3 coupling needs revolute joints 2 "
                         "and 3")
    frames, tool0 = link_frames(model)
    n = model.n_joints
    names = _joint_names(model)
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
        origin = _origin(invert_transform(F_parent) @ frames[i])
        if j23_coupling and i == 2:  # turned by J2 first, then by the controller's J3
            lo2, hi2 = model.limits[1].tolist()
            lines.append('  <link name="link_3_coupling"/>')
            lines.append(f'  <joint name="joint_3_coupling" type="revolute"><parent link='
                         f'"{parent}"/><child link="link_3_coupling"/>{origin}<axis xyz="{axis}"/>'
                         f'<limit lower="{lo2!r}" upper="{hi2!r}" effort="0" velocity="0"/>'
                         f'<mimic joint="{names[1]}" multiplier="1" offset="0"/></joint>')
            parent, origin = "link_3_coupling", _origin(np.eye(4))
        effort, speed = _rating(model, i)
        lines.append(f'  <joint name="{names[i]}" type="{kind}"><parent link="{parent}"/>'
                     f'<child link="{link}"/>{origin}'
                     f'<axis xyz="{axis}"/><limit lower="{lo!r}" upper="{hi!r}" '
                     f'effort="{effort!r}" velocity="{speed!r}"/></joint>')
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
              *(f'  <link name="{name}"/><joint name="base_link-{name}" type="fixed"><parent '
                f'link="base_link"/><child link="{name}"/>{_origin(T)}</joint>'
                for name, T in more_links),
              '  <link name="measured_point"/>',
              '  <joint name="tool0-measured_point" type="fixed"><parent link="tool0"/>'
              f'<child link="measured_point"/>{_origin(model.tool)}</joint>',
              '</robot>']
    return "\n".join(lines) + "\n"


def model_from_urdf(data: str | bytes, source: str = "URDF", name: str | None = None,
                    base_link: str | None = None, tip_link: str | None = None
                    ) -> tuple[SerialModel, list[str]]:
    """The serial chain of a URDF from `base_link` (default the link named base_link, else the
    root) to `tip_link` (default tool0, else flange turned to z out, else the end of the
    longest chain), with limits and link masses, and notes on what was chosen or assumed. The
    base may sit above the chain's first moving joint through fixed joints (ROS-Industrial's
    `base`: the frame the controller reports in)."""
    tree = read_tree(data, source)
    notes: list[str] = []
    start = _chosen(tree, base_link, "--base-link") if base_link else \
        ("base_link" if "base_link" in tree.links else tree.root)
    tip = _chosen(tree, tip_link, "--tip-link") if tip_link else _default_tip(tree, notes)
    climbed, chain = _route(tree, start, tip)
    T = np.eye(4)
    for j in climbed:
        T = invert_transform(j.origin.T) @ T
    dirs, points, types, limits, masses, ratings = [], [], [], [], [], []
    moving: list[Joint] = []
    for k, j in enumerate(chain):
        if j.mimic is not None:
            _coupling(tree, j, moving, chain[k + 1:], notes)
            T = T @ j.origin.T
            continue
        if j.kind in ("floating", "planar"):
            raise ModelError(f"{tree.where(j)} of type '{j.kind}': not a serial arm")
        T = T @ j.origin.T
        if j.kind != "fixed":
            moving.append(j)
            dirs.append(T[:3, :3] @ j.axis)
            points.append(T[:3, 3].copy())
            types.append(PRISMATIC if j.kind == "prismatic" else "R")
            limits.append(_limits(j, tree, notes))
            ratings.append(JointRating(j.name, j.effort, None if j.velocity is None else
                                       j.velocity * (1000.0 if j.kind == "prismatic" else 1.0)))
        inertial = tree.links[j.child].inertial
        if inertial is not None and types and inertial.kg > 0:
            com = (T @ inertial.origin.T)[:3, 3]
            masses.append(LumpedMass(len(types) - 1, inertial.kg, tuple(com.tolist())))
    if not types:
        raise ModelError(f"{source}: no moving joint between '{start}' and '{tip}'")
    home = T @ (_RY90 if tip == "flange" else np.eye(4))
    names = ", ".join(j.name for j in moving)
    notes[:0] = [f"chain from '{start}'{' (default; --base-link)' if not base_link else ''} to "
                 f"'{tip}'{' (default; --tip-link)' if not tip_link else ''}: "
                 f"{len(types)} moving joints ({names})"]
    notes += _other_bases(tree, start) + _placeholder_masses(tree, chain)
    base, tool = _measuring_frames(tree, start, tip)
    try:
        model = SerialModel(name=name or tree.name or Path(source).stem,
                            joint_types=tuple(types), axis_dirs=np.array(dirs),
                            axis_points_mm=np.array(points), home_flange=home,
                            limits=np.array(limits), base=base, tool=tool,
                            masses=tuple(masses), ratings=tuple(ratings))
    except ModelError as err:
        raise ModelError(f"{source}: {err}") from None
    return model, notes


def _coupling(tree: UrdfTree, j: Joint, before: list[Joint], after: list[Joint],
              notes: list[str]) -> None:
    """A mimic joint is read only as FANUC's J2/J3 coupling (what `robot export` writes for a
    FANUC arm): it follows the moving joint before it one to one, and the next joint turns
    about the same axis through the same point; the two read as one serial joint."""
    assert j.mimic is not None
    target, multiplier, offset = j.mimic
    nxt = after[0] if after else None
    if not (before and before[-1].name == target and multiplier == 1.0 and offset == 0.0
            and j.kind in ("revolute", "continuous") and nxt is not None
            and nxt.kind in ("revolute", "continuous") and nxt.origin == Origin()
            and np.allclose(nxt.axis, j.axis)):
        raise ModelError(f"{tree.where(j)} mimics joint '{target}': not a serial arm (a mimic "
                         "joint is read only as FANUC's J2/J3 coupling: following the joint "
                         "before it one to one, on the next joint's axis)")
    notes.append(f"joints '{j.name}' (mimics '{target}') and '{nxt.name}': FANUC's J2/J3 "
                 f"coupling, read as one serial joint (its angle {nxt.name} + {target}); give "
                 "calibrate, predict and compensate the controller's readings with "
                 "--joint-convention fanuc")


def _chosen(tree: UrdfTree, link: str, option: str) -> str:
    if link not in tree.links:
        some = ", ".join(list(tree.links)[:12]) + (" ..." if len(tree.links) > 12 else "")
        raise ModelError(f"{tree.source}: {option} '{link}' is not a link of the file (links: "
                         f"{some})")
    return link


def _default_tip(tree: UrdfTree, notes: list[str]) -> str:
    for t in ("tool0", "flange"):
        if t in tree.links:
            return t
    parents = {j.parent for j in tree.joint_of.values()}
    leaves = [n for n in tree.links if n not in parents]
    tip = max(leaves, key=lambda n: sum(j.kind != "fixed" for j in tree.upward(n)))
    notes.append(f"no tool0 or flange link: the flange is link '{tip}', the end of the chain "
                 "with the most moving joints (--tip-link to choose another)")
    return tip


def _route(tree: UrdfTree, start: str, tip: str) -> tuple[list[Joint], list[Joint]]:
    """The fixed joints climbed from `start` to the lowest link above `tip` too, and the joints
    from there down to `tip` (in order)."""
    down = tree.upward(tip)
    above_tip = {tip} | {j.parent for j in down}
    climbed, link = [], start
    for j in tree.upward(start):
        if link in above_tip:
            break
        if j.kind != "fixed":
            raise ModelError(f"{tree.where(j)} ({j.kind}) lies between '{start}' and the chain "
                             f"to '{tip}': '{start}' moves with the arm; choose a --base-link "
                             "below the first moving joint's parent")
        climbed.append(j)
        link = j.parent
    chain = []
    for j in down:
        if j.child == link:
            break
        chain.append(j)
    return climbed, chain[::-1]


def _limits(j: Joint, tree: UrdfTree, notes: list[str]) -> list[float]:
    if j.kind == "continuous" or j.limit is None:
        notes.append(f"joint '{j.name}' ({j.kind}) has no limits: "
                     f"{'+-1000 mm' if j.kind == 'prismatic' else '+-360 deg'} assumed")
        return [-1e3, 1e3] if j.kind == "prismatic" else [-2 * math.pi, 2 * math.pi]
    lo, hi = j.limit
    return [lo * 1000.0, hi * 1000.0] if j.kind == "prismatic" else [lo, hi]


def _other_bases(tree: UrdfTree, start: str) -> list[str]:
    """ROS-Industrial's `base` (the controller's frame: FANUC's World, UR's base) when the
    chain starts elsewhere and the file places it differently."""
    if start == "base" or "base" not in tree.links:
        return []
    T = tree.fixed_transform(start, "base")
    if T is None or np.allclose(T, np.eye(4), atol=1e-9):
        return []
    from screwcal.kinematics.robots import pose_words

    return [f"link 'base' (ROS-Industrial: the frame the controller reports in) is at "
            f"{pose_words(pose_from_transform(T).tolist())} in '{start}': --base-link base "
            "imports the robot in it"]


def _placeholder_masses(tree: UrdfTree, chain: list[Joint]) -> list[str]:
    """Every moving link with the same mass and inertia at its origin: figures written to fill
    the file (ROS-Industrial's KUKA files: 2 kg each), not the arm's."""
    inertials = [(j.child, tree.links[j.child].inertial) for j in chain if j.kind != "fixed"]
    given = [(n, i) for n, i in inertials if i is not None and i.kg > 0]
    if len(given) < 3 or len({(i.kg, i.inertia) for _, i in given}) > 1 or \
            any(any(i.origin.xyz_m) for _, i in given):
        return []
    return [f"placeholder masses: links {', '.join(repr(n) for n, _ in given)} all carry "
            f"{given[0][1].kg:g} kg at their origins with the same inertia, as files without the "
            "arm's figures do; imported as lumped masses: replace them with the arm's before "
            "calibrating joint compliance"]


def _measuring_frames(tree: UrdfTree, start: str, tip: str) -> tuple[Array, Array]:
    """Base (world from robot base) and tool (flange to measured point) from the links
    `measuring_frame` and `measured_point` where the file has them fixed to the base and the
    flange; identity otherwise."""
    base, tool = np.eye(4), np.eye(4)
    if "measuring_frame" in tree.links:
        T = tree.fixed_transform(start, "measuring_frame")
        if T is not None:
            base = invert_transform(T)
    if "measured_point" in tree.links:
        T = tree.fixed_transform(tip, "measured_point")
        if T is not None:
            tool = (_RY90 if tip == "flange" else np.eye(4)).T @ T
    return base, tool
