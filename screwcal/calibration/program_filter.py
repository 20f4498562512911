"""Compensating a KUKA, FANUC or Universal Robots program: one core for every language.

The rule is the RAPID filter's (`rapid_filter`): each Cartesian target, in its own tool and
frame, is solved on the nominal robot on the branch its flags name (KUKA's Status and Turn,
FANUC's configuration; for UR, whose controller takes the solution nearest where it stands,
the solution nearest the previous target's); the calibrated robot's joints are found next to
that solution (`correction.compensate`); the new target is the nominal pose of those joints,
its flags recomputed from them. Only the six numbers and the flags change; the rest of each
file is kept byte for byte. A target that cannot be compensated is listed with its file, line
and reason, never passed silently.

Each maker's program units and angles (`CONVENTIONS`): KRL mm and A, B, C deg (R = Rz(A)
Ry(B) Rx(C)); FANUC mm and W, P, R deg (R = Rz(R) Ry(P) Rx(W)); URScript m and a rotation
vector in rad. KUKA's frames are on KUKA's FLANGE (x out of the flange), the library's tool0
has z out: FLANGE = tool0 Ry(-90 deg), as ROS-Industrial's KUKA descriptions have it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np

from screwcal.calibration.correction import compensate
from screwcal.kinematics.ik_branches import all_branches, branch_of
from screwcal.kinematics.ik_solutions import IKSolutions
from screwcal.kinematics.maker_configs import (
    FanucConfig,
    branch_index,
    fanuc_config,
    fanuc_select,
    kuka_select,
    kuka_status_turn,
    nearest_chain,
)
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import (
    euler_zyx_deg_near,
    rotation_angle_deg,
    rotation_from_euler_zyx_deg,
)
from screwcal.kinematics.se3 import (
    Array,
    Mask,
    invert_transform,
    rotation_from_rotvec,
    rotvec_from_rotation,
)
from screwcal.programs.program import Frame, Note, Program, Target
from screwcal.tables import unsigned_zeros

if TYPE_CHECKING:
    from screwcal.calibration.residual_model import ResidualModel

_RY90 = np.array([[0.0, 0, 1, 0], [0, 1, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1]])


@dataclass(frozen=True)
class Convention:
    """A language's units and angles, and where its flange frame sits on tool0."""

    mm_per_unit: float
    angles: Literal["abc_deg", "wpr_deg", "rotvec_rad"]
    decimals: tuple[int, int]  # position, orientation, as written back
    flange_to_tool0: Array  # tool0 in the maker's flange frame


CONVENTIONS = {
    "krl": Convention(1.0, "abc_deg", (4, 5), _RY90),
    "fanuc": Convention(1.0, "wpr_deg", (4, 5), np.eye(4)),
    "urscript": Convention(1000.0, "rotvec_rad", (7, 8), np.eye(4)),
}


def world_frame(language: str, nominal: SerialModel) -> Array:
    """The frame a maker's controller calls the world (a target's frame 0), in the robot's
    base frame: FANUC's World lies on axis 1 in the plane of J2 (ROS-Industrial's `base`, 330 mm
    above `base_link` on the LR Mate 200iD), KUKA's `$ROBROOT` and UR's base are the robot base.
    A FANUC model already in the World frame has J2's axis at height 0: the same rule gives
    the identity."""
    T = np.eye(4)
    if language == "fanuc":
        T[:3, 3] = nominal.axis_points_mm[0] + nominal.axis_dirs[0] * float(
            nominal.axis_dirs[0] @ (nominal.axis_points_mm[1] - nominal.axis_points_mm[0]))
    return T


def matrices(values: Array, conv: Convention) -> Array:
    """Poses (N, 4, 4) in mm of six program numbers per row (N, 6)."""
    v = np.asarray(values, float).reshape(-1, 6)
    T = np.tile(np.eye(4), (len(v), 1, 1))
    T[:, :3, 3] = v[:, :3] * conv.mm_per_unit
    if conv.angles == "rotvec_rad":
        T[:, :3, :3] = rotation_from_rotvec(v[:, 3:])
        return T
    rx, ry, rz = (v[:, 5], v[:, 4], v[:, 3]) if conv.angles == "abc_deg" else \
        (v[:, 3], v[:, 4], v[:, 5])
    T[:, :3, :3] = rotation_from_euler_zyx_deg(np.column_stack([rx, ry, rz]))
    return T


def program_values(T: Array, conv: Convention, old: Array) -> Array:
    """Six program numbers per pose (N, 6), the angles nearest the old ones (N, 6)."""
    out = np.empty((len(T), 6))
    out[:, :3] = T[:, :3, 3] / conv.mm_per_unit
    if conv.angles == "rotvec_rad":
        out[:, 3:] = rotvec_from_rotation(T[:, :3, :3])
        return out
    ref = old[:, [5, 4, 3]] if conv.angles == "abc_deg" else old[:, 3:]
    rxyz = euler_zyx_deg_near(T[:, :3, :3], ref)
    out[:, 3:] = rxyz[:, [2, 1, 0]] if conv.angles == "abc_deg" else rxyz
    return out


@dataclass
class ProgramReport:
    """What the filter did: counts, the largest change, and what it left with why."""

    compensated: int = 0
    max_position_change_mm: float = 0.0
    max_rotation_change_deg: float = 0.0
    refused: list[Note] = field(default_factory=list)  # targets left unchanged
    not_static: list[Note] = field(default_factory=list)  # what only the run knows
    joint_targets: int = 0
    chosen_nearest: int = 0  # targets without flags: the branch nearest the previous one
    residual: str = ""  # the residual model's corrections, when one was given
    uncorrected: list[Note] = field(default_factory=list)  # beyond the residual model's reach

    @property
    def complete(self) -> bool:
        return not self.refused and not self.not_static

    def summary(self) -> str:
        lines = [f"{self.compensated} targets compensated; largest change "
                 f"{self.max_position_change_mm:.3f} mm, {self.max_rotation_change_deg:.4f} deg"]
        if self.joint_targets:
            lines.append(f"  {self.joint_targets} joint targets left as they are (joints are "
                         "the controller's own: nothing to compensate)")
        if self.chosen_nearest:
            lines.append(f"  {self.chosen_nearest} targets carry no configuration: each on the "
                         "branch nearest the previous target's, as the controller moving "
                         "through the program in order takes it")
        if self.residual:
            lines.append(f"  {self.residual}")
        for title, notes in (("compensated without the residual's correction",
                              self.uncorrected),
                             ("refused (left unchanged)", self.refused),
                             ("not compensated statically", self.not_static)):
            if notes:
                lines.append(f"  {len(notes)} {title}:")
                lines += [f"    {n.path}:{n.line}: {n.name}: {n.reason}" for n in notes]
        return "\n".join(lines)


def _frame_matrix(frames: dict[str, Frame], key: str | None, conv: Convention,
                  what: str) -> Array | str:
    if key is None:
        return np.eye(4)
    f = frames.get(key)
    if f is None:
        return f"{what} {key}: not given (KUKA: --config $config.dat; FANUC: --frames)"
    if f.values is None:
        return f"{what} {key}: {f.problem}"
    return matrices(np.array(f.values), conv)[0]


def filter_program(program: Program, calibrated: SerialModel, nominal: SerialModel, *,
                   start_deg: Array | None = None, residual: ResidualModel | None = None
                   ) -> tuple[dict[str, str], ProgramReport]:
    """Each file's text (by path) with every target compensated, and the report.
    `start_deg`: the joints the robot stands at when the program starts (the first flagless
    target's nearest solution; default all zeros); `residual`: the calibrated robot's residual
    model (`correction.compensate`)."""
    conv = CONVENTIONS[program.language]
    report = ProgramReport(joint_targets=program.joint_targets,
                           not_static=list(program.notes))
    usable: list[Target] = []
    frames: list[tuple[Array, Array]] = []
    flange_from_tool0 = invert_transform(conv.flange_to_tool0)
    world = world_frame(program.language, nominal)
    W_of = {k: (m if isinstance(m, str) else world @ m)
            for k in {t.frame for t in program.targets}
            for m in (_frame_matrix(program.frames, k, conv, "frame"),)}
    tool_of = {k: (m if isinstance(m, str) else flange_from_tool0 @ m)  # tool0 -> TCP
               for k in {t.tool for t in program.targets}
               for m in (_frame_matrix(program.tools, k, conv, "tool"),)}
    for t in program.targets:
        W, tool = W_of[t.frame], tool_of[t.tool]
        why = t.problem or (W if isinstance(W, str) else "") or \
            (tool if isinstance(tool, str) else "")
        if why:
            report.refused.append(Note(t.path, t.line, t.name, why))
            continue
        assert isinstance(W, np.ndarray) and isinstance(tool, np.ndarray)
        usable.append(t)
        frames.append((W, tool))
    texts = dict(program.texts)
    if not usable:
        return texts, report
    start = np.zeros(6) if start_deg is None else np.radians(start_deg)
    replaced = _compensate(program.language, usable, frames, conv, (calibrated, nominal),
                           report, start, residual)
    return _spliced(texts, replaced), report


def _compensate(language: str, targets: list[Target], frames: list[tuple[Array, Array]],
                conv: Convention, robots: tuple[SerialModel, SerialModel],
                report: ProgramReport, start: Array, residual: ResidualModel | None
                ) -> list[tuple[str, tuple[int, int], str]]:
    """The replacements (path, span, text) of every target compensated."""
    calibrated, nominal = robots
    W = np.array([f[0] for f in frames])
    tool = np.array([f[1] for f in frames])
    values = np.array([t.values for t in targets])
    T_target = matrices(values, conv)
    T_flange = W @ T_target @ invert_transform(tool)
    sol = all_branches(nominal, T_flange)
    q_nominal, found, nearest = _select(language, targets, sol, start)
    report.chosen_nearest = int(nearest.sum())
    for k in np.flatnonzero(~found):
        report.refused.append(Note(targets[k].path, targets[k].line, targets[k].name,
                                   _unreachable(targets[k], sol, int(k))))
    idx = np.flatnonzero(found)
    if idx.size == 0:
        return []
    comp = compensate(calibrated, nominal, T_flange[idx], q_nominal[idx], frame="base",
                      strict=False, residual=residual)
    for row, why in comp.refused:
        t = targets[idx[row]]
        report.refused.append(Note(t.path, t.line, t.name, why))
    keep = comp.ok
    if comp.residual is not None:  # what the residual model corrected, and where it could not
        report.residual = comp.residual.summary()
        report.uncorrected += [Note(targets[idx[k]].path, targets[idx[k]].line,
                                    targets[idx[k]].name, comp.residual.note(k))
                               for k in np.flatnonzero(np.logical_and(
                                   ~comp.residual.within_reach, keep)).tolist()]
    idx, q, tool0 = idx[keep], comp.q_rad[keep], comp.nominal_tool0[keep]
    if idx.size == 0:
        return []
    new_T = invert_transform(W[idx]) @ tool0 @ tool[idx]
    # the flags name the branch (KRL's S, FANUC's configuration); URScript's targets carry none
    branch = branch_of(nominal, tool0, q, branch_index(sol, q_nominal)[idx]) \
        if language != "urscript" else np.full(len(q), -1)
    new_values = program_values(new_T, conv, values[idx])
    report.compensated = len(idx)
    report.max_position_change_mm = float(np.linalg.norm(
        new_T[:, :3, 3] - T_target[idx, :3, 3], axis=1).max())
    report.max_rotation_change_deg = float(rotation_angle_deg(
        new_T[:, :3, :3], T_target[idx, :3, :3]).max())
    return _replacements(language, [targets[k] for k in idx], new_values, q, branch, conv)


def _select(language: str, targets: list[Target], sol: IKSolutions, start: Array
            ) -> tuple[Array, Mask, Mask]:
    """The nominal controller's joints per target, which have them, and which were chosen
    as the nearest (no flags)."""
    flagged = np.array([_has_flags(language, t) for t in targets])
    q_f = np.full((len(targets), 6), np.nan)
    found_f = np.zeros(len(targets), bool)
    if flagged.any() and language == "krl":
        status = np.array([_kuka_int(t.flags["S"].text) if flagged[k] else 0
                           for k, t in enumerate(targets)])
        turn = np.array([_kuka_int(t.flags["T"].text) if flagged[k] else 0
                         for k, t in enumerate(targets)])
        q_f, found_f = kuka_select(sol, status, turn)
    elif flagged.any() and language == "fanuc":
        configs = [parse_fanuc_config(t.flags["CONFIG"].text) if flagged[k] else
                   FanucConfig(False, True, True, (0, 0, 0)) for k, t in enumerate(targets)]
        q_f, found_f = fanuc_select(sol, configs)
    q_f[~flagged] = np.nan
    q, found = nearest_chain(sol, start, q_f)
    found = np.where(flagged, found_f, found)
    return q, found, ~flagged


def _has_flags(language: str, t: Target) -> bool:
    if language == "krl":
        return "S" in t.flags and "T" in t.flags
    return language == "fanuc" and "CONFIG" in t.flags


@functools.lru_cache(maxsize=1024)  # a program's S and T take a few values, each many times
def _kuka_int(text: str) -> int:
    """KRL's S or T: decimal, or a binary literal 'B010'."""
    s = text.strip().strip("'")
    return int(s[1:], 2) if s[:1] in "Bb" else int(s)


@functools.lru_cache(maxsize=256)
def parse_fanuc_config(text: str) -> FanucConfig:
    """'N U T, 0, 0, 0' (turn numbers optional: 0)."""
    parts = [p.strip() for p in text.split(",")]
    letters = parts[0].upper().split()
    turns = [int(p) for p in parts[1:4]] + [0] * (3 - len(parts[1:4]))
    return FanucConfig("F" in letters, "D" not in letters, "B" not in letters,
                       (turns[0], turns[1], turns[2]))


def _unreachable(t: Target, sol: IKSolutions, k: int) -> str:
    if not sol.reachable[k].any():
        return "the nominal robot cannot reach it (in its tool and frame)"
    flags = ", ".join(f"{f.name} {f.text}" for f in t.flags.values())
    return f"the nominal robot has no solution with {flags or 'any branch'} in its limits"


def _replacements(language: str, targets: list[Target], values: Array, q: Array,
                  branch: Array, conv: Convention) -> list[tuple[str, tuple[int, int], str]]:
    pos, ang = conv.decimals
    row = ",".join([f"{{:.{pos}f}}"] * 3 + [f"{{:.{ang}f}}"] * 3)
    # one format for them all, correctly rounded as round(v, d) would; no "-0.0"
    numbers = unsigned_zeros(
        ",".join([row] * len(targets)).format(*values.ravel().tolist()).split(","))
    out: list[tuple[str, tuple[int, int], str]] = []
    for k, t in enumerate(targets):
        out += zip((t.path,) * 6, t.spans, numbers[6 * k:6 * k + 6], strict=True)
    if language == "krl":
        status, turn = (a.tolist() for a in kuka_status_turn(q, branch))
        out += [(t.path, t.flags[name].span, _kuka_text(t.flags[name].text, number[k]))
                for k, t in enumerate(targets) for name, number in (("S", status), ("T", turn))
                if name in t.flags]
    elif language == "fanuc":
        configs = fanuc_config(q, branch)
        out += [(t.path, t.flags["CONFIG"].span, configs[k].text())
                for k, t in enumerate(targets) if "CONFIG" in t.flags]
    return out


@functools.lru_cache(maxsize=1024)
def _kuka_text(old: str, number: int) -> str:
    """A KRL S or T in the form it was written: decimal, or 'B010' with as many digits."""
    s = old.strip()
    if s.strip("'")[:1] in "Bb":
        digits = max(len(s.strip("'")) - 1, number.bit_length())
        body = f"{s.strip(chr(39))[0]}{number:0{digits}b}"
        return f"'{body}'" if s.startswith("'") else body
    return str(number)


def _spliced(texts: dict[str, str], replaced: list[tuple[str, tuple[int, int], str]]
             ) -> dict[str, str]:
    by_path: dict[str, list[tuple[tuple[int, int], str]]] = {}
    for path, span, text in replaced:
        by_path.setdefault(path, []).append((span, text))
    out = dict(texts)
    for path, edits in by_path.items():
        edits.sort(key=_start)
        text, at = texts[path], 0
        pieces: list[str] = []
        for (a, b), new in edits:
            pieces += (text[at:a], new)
            at = b
        pieces.append(text[at:])
        out[path] = "".join(pieces)
    return out


def _start(edit: tuple[tuple[int, int], str]) -> int:
    return edit[0][0]
