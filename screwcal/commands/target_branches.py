"""The branch a target without configuration is solved on (`compensate --targets` and
`--measuring-targets`: a pose file carries no confdata): each target takes the nominal robot's
valid solution nearest the joints of the target before it, the first the one nearest home, as a
controller moving through the targets in order would (`maker_configs.nearest_chain`); and the
words that say which branch each target took and why it changed where it did.

The rule it replaces took every target's solution nearest home: a target next to one whose
wrist stood at q4 27, q6 -168 deg came out wrist-flipped (q4 -151, q6 12 deg) while the command
said "largest joint change 3.99 deg" (the calibration's correction, not the move)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from screwcal.kinematics.ik_solutions import BRANCHES, IKSolutions
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, Mask

_TAU = 2.0 * np.pi
_TURNS = np.arange(-2, 3)


@dataclass(frozen=True)
class BranchChoice:
    """Per target the nominal joints chosen (N, 6) rad (NaN where none), the branch's index in
    `solutions.branches` (-1: none), why (a refusal where there is no solution), and whether
    the IK told the branches apart by posture (closed form) or only numbered them."""

    q_rad: Array
    branch: Array
    found: Mask
    why_none: tuple[str, ...]
    labelled: bool
    solutions: IKSolutions
    nominal: SerialModel

    def label(self, k: int) -> str:
        """Target k's branch in words: 'shoulder front, elbow up, wrist not flipped'."""
        b = int(self.branch[k])
        if b < 0:
            return "none"
        if not self.labelled:  # numbered solutions: their slots differ target by target
            from screwcal.kinematics.confdata import confdata

            cf = confdata(self.nominal, self.q_rad[k:k + 1])[0]
            return f"confdata [{', '.join(str(int(v)) for v in cf)}]"
        shoulder, elbow, wrist = self.solutions.branches[b]
        return f"shoulder {shoulder}, elbow {elbow}, wrist " + (
            "flipped" if wrist == "flip" else "not flipped")


def nominal_solutions(nominal: SerialModel, T_flange: Array) -> tuple[IKSolutions, bool]:
    """Every branch of the flange poses T_flange (N, 4, 4) in the robot base frame on the
    nominal robot (its frames aside): the closed forms of `ik_branches` (labelled by
    posture), else the numerical IK's solutions (numbered), target by target where some are
    out of reach."""
    from screwcal.errors import ModelError, UnreachableError
    from screwcal.kinematics.ik import numerical_ik
    from screwcal.kinematics.ik_branches import all_branches

    robot = nominal.with_frames(np.eye(4), np.eye(4))
    try:
        return all_branches(robot, T_flange), True
    except ModelError:
        pass
    try:
        return numerical_ik(robot, T_flange), False
    except UnreachableError:
        pass
    parts = []
    for k in range(len(T_flange)):
        try:
            parts.append(numerical_ik(robot, T_flange[k:k + 1]))
        except UnreachableError:
            none = (1, len(BRANCHES))  # numerical_ik's columns, sampled or seeded
            parts.append(IKSolutions(q=np.full((*none, robot.n_joints), np.nan),
                                     reachable=np.zeros(none, bool),
                                     within_limits=np.zeros(none, bool),
                                     residual_mm=np.full(none, np.nan), limits=robot.limits))
    return IKSolutions(q=np.concatenate([p.q for p in parts]),
                       reachable=np.concatenate([p.reachable for p in parts]),
                       within_limits=np.concatenate([p.within_limits for p in parts]),
                       residual_mm=np.concatenate([p.residual_mm for p in parts]),
                       limits=robot.limits), False


def choose_branches(nominal: SerialModel, T_flange: Array,
                    start_rad: Array | None = None) -> BranchChoice:
    """Each target's nominal solution nearest the previous target's (the first's nearest
    `start_rad`, default home)."""
    from screwcal.kinematics.maker_configs import branch_index, nearest_chain

    sol, labelled = nominal_solutions(nominal, np.asarray(T_flange, float))
    start = np.zeros(sol.q.shape[2]) if start_rad is None else np.asarray(start_rad, float)
    q, found = nearest_chain(sol, start)
    branch = np.where(found, branch_index(sol, np.nan_to_num(q)), -1)
    why = tuple("" if ok else "it is out of the arm's reach on every branch"
                if not sol.reachable[k].any() else
                "it is outside the joint limits on every branch"
                for k, ok in enumerate(found))
    return BranchChoice(q, branch, found, why, labelled, sol, nominal)


def _distance_on(sol: IKSolutions, k: int, b: int, prev: Array) -> float:
    """How far (joint-space norm, rad) branch b of target k lies from `prev`, at its nearest
    turn inside the limits; inf where it does not exist or leaves the limits."""
    q = sol.q[k, b][None, :] + _TAU * _TURNS[:, None]
    if sol.limits is not None:
        q = np.where((q >= sol.limits[:, 0]) & (q <= sol.limits[:, 1]), q, np.nan)
    if not sol.reachable[k, b]:
        return float("inf")
    d = np.linalg.norm(q - prev, axis=-1)
    return float(np.nan_to_num(d, nan=np.inf).min())


def branch_changes(choice: BranchChoice) -> list[tuple[int, int, str]]:
    """Where a target took another branch than the one before it: (previous target, target,
    why): the branch before does not reach it, or leaves the joint limits there, or lies
    farther from the previous joints."""
    out = []
    sol, q = choice.solutions, choice.q_rad
    done = np.flatnonzero(choice.found).tolist()
    for a, k in pairwise(done):
        b_prev, b = int(choice.branch[a]), int(choice.branch[k])
        if choice.label(a) == choice.label(k) or b_prev < 0 or b < 0:
            continue
        if not choice.labelled:
            why = "it is the solution nearest the joints before"
        elif not sol.reachable[k, b_prev]:
            why = f"the branch before ({choice.label(a)}) does not reach it"
        else:
            old = _distance_on(sol, k, b_prev, q[a])
            if not np.isfinite(old):
                why = (f"on the branch before ({choice.label(a)}) a joint would be outside "
                       "its limits")
            else:
                new = float(np.linalg.norm(q[k] - q[a]))
                why = (f"it lies nearer the joints before ({np.degrees(new):.1f} deg in joint "
                       f"space; {np.degrees(old):.1f} deg on the branch before)")
        out.append((int(a), int(k), why))
    return out


def largest_move(q_rad: Array, found: Array) -> tuple[int, int, int, float] | None:
    """The largest joint move between consecutive targets solved: (previous target, target,
    joint (0-based), move rad); None with fewer than two."""
    done = np.flatnonzero(found)
    if len(done) < 2:
        return None
    steps = np.abs(np.diff(q_rad[done], axis=0))
    i, j = np.unravel_index(int(np.argmax(steps)), steps.shape)
    return int(done[i]), int(done[i + 1]), int(j), float(steps[i, j])


def branch_note(choice: BranchChoice, ids: Sequence[str], lines: Sequence[int],
                q_final_rad: Array, ok: Array, shown: int = 5) -> str:
    """What the user reads: the rule, the branches taken (how many targets each), each change
    of branch with why (the first `shown`), the largest move between consecutive targets of
    the joints written, and how to keep another branch."""
    taken = Counter(choice.label(k) for k in np.flatnonzero(ok).tolist())
    branches = "; ".join(f"{name} for {n} target{'s' if n != 1 else ''}"
                         for name, n in taken.most_common())
    out = [f"  configuration: a pose file carries none, so each target was solved on the "
           f"nominal robot's branch nearest the joints of the target before it (the first: "
           f"nearest home), as a controller moving through them in order takes it: {branches}"]
    changes = [(a, k, why) for a, k, why in branch_changes(choice) if ok[a] and ok[k]]
    for a, k, why in changes[:shown]:
        out.append(f"  branch changed at target {ids[k]} (line {lines[k]}): "
                   f"{choice.label(a)} -> {choice.label(k)}: {why}")
    if len(changes) > shown:
        out.append(f"  ... and {len(changes) - shown} more changes of branch")
    move = largest_move(q_final_rad, ok)
    if move is not None:
        a, k, j, step = move
        out.append(f"  largest move between consecutive targets: joint {j + 1} by "
                   f"{np.degrees(step):.3f} deg (targets {ids[a]} -> {ids[k]})")
    out.append("  to keep another branch, give the targets as a RAPID module with their "
               "confdata (--rapid)")
    return "\n".join(out)
