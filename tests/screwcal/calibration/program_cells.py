"""Programs of each maker taught on the nominal robot (every declaration form, with tools and
frames), a true robot with errors, and the nominal controller that runs the compensated
program: the round trip of the program filter's tests."""

from __future__ import annotations

import numpy as np

from screwcal.calibration.program_filter import (
    CONVENTIONS,
    matrices,
    parse_fanuc_config,
    world_frame,
)
from screwcal.calibration.virtual_joints import perturbed_axes
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.ik_branches import all_branches
from screwcal.kinematics.maker_configs import (
    branch_index,
    fanuc_config,
    fanuc_select,
    kuka_select,
    kuka_status_turn,
    nearest_chain,
)
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, rotation_angle_deg
from screwcal.kinematics.se3 import invert_transform, rotvec_from_rotation
from screwcal.programs import Program


def true_robot(nominal: SerialModel, rng: np.random.Generator) -> SerialModel:
    """The nominal with 0.3 mm / 0.02 deg axis errors and 0.05 deg zero offsets everywhere."""
    return perturbed_axes(nominal, rng, tilt_deg=0.02, shift_mm=0.3, zero_deg=0.05,
                          flange=False)


def pose(language: str, frame: np.ndarray, tool: np.ndarray, nominal: SerialModel,
         q: np.ndarray) -> list[float]:
    """The six program numbers of the TCP at joints q (6,) rad, in `frame`, with `tool`."""
    conv = CONVENTIONS[language]
    world = world_frame(language, nominal)
    T = invert_transform(world @ frame) @ flange_kinematics(nominal, q[None])[0] @ \
        invert_transform(conv.flange_to_tool0) @ tool
    xyz = T[:3, 3] / conv.mm_per_unit
    if language == "urscript":
        return [*xyz, *rotvec_from_rotation(T[:3, :3])]
    rx, ry, rz = euler_zyx_deg_from_rotation(T[:3, :3])
    return [*xyz, rz, ry, rx] if language == "krl" else [*xyz, rx, ry, rz]


def kuka_flags(nominal: SerialModel, q: np.ndarray) -> tuple[int, int]:
    sol = all_branches(nominal, flange_kinematics(nominal, q[None]))
    s, t = kuka_status_turn(q[None], branch_index(sol, q[None]))
    return int(s[0]), int(t[0])


def fanuc_flags(nominal: SerialModel, q: np.ndarray) -> str:
    sol = all_branches(nominal, flange_kinematics(nominal, q[None]))
    return fanuc_config(q[None], branch_index(sol, q[None]))[0].text()


def controller_tcp(program: Program, truth: SerialModel, nominal: SerialModel,
                   taught: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the true robot's TCP does for each target of a (compensated) program on the
    nominal controller: the TCP poses (N, 4, 4) in the robot base frame, the joints, and the
    wanted TCP poses of the same numbers on the nominal. Targets without flags take the
    solution nearest the taught joints (the robot stands next to them)."""
    conv = CONVENTIONS[program.language]
    frames = [_matrix(program.frames, t.frame, conv) for t in program.targets]
    tools = [_matrix(program.tools, t.tool, conv) for t in program.targets]
    W = world_frame(program.language, nominal) @ np.array(frames)
    tool = np.array(tools)
    P = matrices(np.array([t.values for t in program.targets]), conv)
    T_tool0 = W @ P @ invert_transform(tool) @ conv.flange_to_tool0
    sol = all_branches(nominal, T_tool0)
    N = len(program.targets)
    q = np.full((N, 6), np.nan)
    if program.language == "krl":
        flagged = np.array(["S" in t.flags for t in program.targets])
        s = np.array([int(t.flags["S"].text) if "S" in t.flags else 0
                      for t in program.targets])
        tt = np.array([int(t.flags["T"].text) if "T" in t.flags else 0
                       for t in program.targets])
        q_f, found = kuka_select(sol, s, tt)
        assert found[flagged].all()
        q[flagged] = q_f[flagged]
        # Turn: the signs of the joints the controller took (an independent check)
        assert (((q_f[flagged] < 0) * (1 << np.arange(6))).sum(axis=1) == tt[flagged]).all()
    elif program.language == "fanuc":
        flagged = np.array(["CONFIG" in t.flags for t in program.targets])
        configs = [parse_fanuc_config(t.flags["CONFIG"].text) for t in program.targets]
        q_f, found = fanuc_select(sol, configs)
        assert found.all()
        q = q_f
        assert all((qq[4] > 0) == c.flip for qq, c in zip(q_f, configs, strict=True))
    for k in np.flatnonzero(np.isnan(q).any(axis=1)):
        one = all_branches(nominal, T_tool0[k:k + 1])
        q[k], found_k = nearest_chain(one, taught[k])
        assert found_k.all()
    reached = flange_kinematics(truth, q) @ invert_transform(conv.flange_to_tool0) @ tool
    return reached, q, W @ P


def misses(reached: np.ndarray, wanted: np.ndarray) -> tuple[float, float]:
    """The largest position (mm) and orientation (deg) error."""
    return (float(np.linalg.norm(reached[:, :3, 3] - wanted[:, :3, 3], axis=1).max()),
            float(rotation_angle_deg(reached[:, :3, :3], wanted[:, :3, :3]).max()))


def _matrix(store: dict, key: str | None, conv: object) -> np.ndarray:
    if key is None:
        return np.eye(4)
    return matrices(np.array(store[key].values), conv)[0]
