"""How each maker's program names the IK branch of a Cartesian target, read off the joints and
used to choose the branch as the controller does.

- KUKA (KRL `E6POS`/`POS` `S` and `T`): Status bit 0 set in the overhead area (the wrist
  centre behind axis 1: the `back` shoulder), bit 1 set when A3 is beyond the stretched arm's
  angle (the elbow `up`, as at KUKA's home A2 -90, A3 +90), bit 2 set when A5 <= 0; Turn bit i
  set when axis i + 1 is negative (KUKA System Software, expert programming: "Status and
  Turn").
- FANUC (LS `CONFIG : 'N U T, 0, 0, 0'`): wrist Flip when J5 > 0 (No flip for the usual
  tool-down postures, J5 = -90), elbow Up or Down, Top (front) or Bottom (back), then the turn
  numbers of J1, J4 and J6: turn k for an angle in [-180 + 360 k, 180 + 360 k) deg.
- Universal Robots: no flags; the controller takes the solution nearest the joints it stands
  at, so a target keeps the branch nearest its predecessor in the program (`nearest_chain`).

Shoulder and elbow come from the physical labels of `ik_branches.all_branches`; the wrist and
the turns from the joint readings themselves. Readings are the model's serial angles: FANUC's
coupled J3 plays no part in a flag.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from screwcal.kinematics.ik_solutions import BRANCHES, IKSolutions
from screwcal.kinematics.se3 import Array, Mask

__all__ = ["FanucConfig", "branch_index", "fanuc_config", "fanuc_select", "kuka_select",
           "kuka_status_turn", "nearest_chain"]

_TAU = 2.0 * np.pi
_SAME_RAD = 1e-7  # a branch equal to given joints (mod a turn) within this
_ZERO_RAD = 1e-5  # a joint this near zero counts as either sign: a target written with the
# pendant's decimals (0.001 mm, 0.0001 deg) places a joint taught at 0.000 no closer than that
_BACK = np.array([s == "back" for s, _, _ in BRANCHES])
_UP = np.array([e == "up" for _, e, _ in BRANCHES])
_TURNS = np.arange(-2, 3)


@dataclass(frozen=True)
class FanucConfig:
    """A FANUC configuration: flip, up, top (front), turn numbers of J1, J4, J6."""

    flip: bool
    up: bool
    top: bool
    turns: tuple[int, int, int]

    def text(self) -> str:
        """As an LS file writes it: 'N U T, 0, 0, 0'."""
        return (f"{'F' if self.flip else 'N'} {'U' if self.up else 'D'} "
                f"{'T' if self.top else 'B'}, {self.turns[0]}, {self.turns[1]}, "
                f"{self.turns[2]}")


def branch_index(sol: IKSolutions, q: Array) -> Array:
    """For each target the branch (N,) of `sol` whose joints equal q (N, 6) rad modulo whole
    turns, -1 where none does."""
    d = np.abs((sol.q - q[:, None, :] + np.pi) % _TAU - np.pi).max(axis=-1)
    hit = np.nan_to_num(d, nan=np.inf) < _SAME_RAD
    return np.where(hit.any(axis=1), np.argmax(hit, axis=1), -1)


def kuka_status_turn(q: Array, branch: Array) -> tuple[Array, Array]:
    """KUKA's Status and Turn (N,) of joints q (N, 6) rad on branches `branch` (N,)."""
    status = _BACK[branch].astype(int) + 2 * _UP[branch].astype(int) + 4 * (q[:, 4] <= 0.0)
    turn = ((q < 0.0) * (1 << np.arange(6))).sum(axis=1)
    return status, turn


def fanuc_config(q: Array, branch: Array) -> list[FanucConfig]:
    """FANUC's configuration of joints q (N, 6) rad (serial) on branches `branch` (N,)."""
    turns = np.floor((np.degrees(q[:, [0, 3, 5]]) + 180.0) / 360.0).astype(int)
    return [FanucConfig(bool(q[k, 4] > 0.0), bool(_UP[b]), not bool(_BACK[b]),
                        (int(t[0]), int(t[1]), int(t[2])))
            for k, (b, t) in enumerate(zip(branch.tolist(), turns, strict=True))]


def _candidates(sol: IKSolutions, arm: Mask | None = None) -> Array:
    """Every branch's joints moved by -2..2 turns (N, 8, 5, 6), NaN outside the limits; with
    `arm` (N, 8), the two branches it allows per target (N, 2, 5, 6), in BRANCHES order."""
    q, reachable = sol.q, sol.reachable
    if arm is not None:  # one shoulder and one elbow: the wrist as it is and flipped
        pair = np.flatnonzero(arm).reshape(len(arm), 2) % len(BRANCHES)
        rows = np.arange(len(arm))[:, None]
        q, reachable = q[rows, pair], reachable[rows, pair]
    q = q[:, :, None, :] + _TAU * _TURNS[None, None, :, None]
    if sol.limits is not None:
        inside = (q >= sol.limits[:, 0]) & (q <= sol.limits[:, 1])
        q = np.where(inside, q, np.nan)
    return np.where(reachable[:, :, None, None], q, np.nan)


def _pick(cand: Array, wanted: Array) -> tuple[Array, Mask]:
    """The joints (N, 6) of the first branch of `cand` (N, B, 5, 6) where every joint has a
    turn that `wanted` (N, B, 5, 6) accepts (the first such turn), and which targets have one."""
    ok_turn = wanted & np.isfinite(cand)
    joint_ok = ok_turn.any(axis=2)  # (N, B, 6)
    branch_ok = joint_ok.all(axis=-1)
    found = branch_ok.any(axis=1)
    b = np.argmax(branch_ok, axis=1)
    n = np.arange(cand.shape[0])
    turn = np.argmax(ok_turn[n, b], axis=1)  # (N, 6)
    q = np.take_along_axis(cand[n, b], turn[:, None, :], axis=1)[:, 0, :]
    q[~found] = np.nan
    return q, found


def kuka_select(sol: IKSolutions, status: Array, turn: Array) -> tuple[Array, Mask]:
    """The joints (N, 6) the controller takes for targets with Status and Turn (N,), and
    which targets have them. Status names the shoulder and the elbow: only their two
    branches are looked at."""
    bits: NDArray[np.int64] = np.asarray(status, dtype=np.int64)
    turns: NDArray[np.int64] = np.asarray(turn, dtype=np.int64)
    arm = (_BACK[None, :] == (bits[:, None] & 1).astype(bool)) & \
        (_UP[None, :] == (bits[:, None] & 2).astype(bool))
    cand = _candidates(sol, arm)
    negative = ((turns[:, None] >> np.arange(6)) & 1).astype(bool)  # (N, 6)
    neg = negative[:, None, None, :]
    wanted = np.where(neg, cand <= _ZERO_RAD, cand >= -_ZERO_RAD)
    a5_negative = (bits & 4).astype(bool)[:, None, None]
    wanted[..., 4] &= np.where(a5_negative, cand[..., 4] <= _ZERO_RAD,
                               cand[..., 4] > -_ZERO_RAD)
    return _pick(cand, wanted)


def fanuc_select(sol: IKSolutions, configs: list[FanucConfig]) -> tuple[Array, Mask]:
    """The joints (N, 6) the controller takes for targets with these configurations (Up
    and Top name the arm: only its two branches are looked at)."""
    arm = (_UP[None, :] == np.array([c.up for c in configs], bool)[:, None]) & \
        (_BACK[None, :] != np.array([c.top for c in configs], bool)[:, None])
    cand = _candidates(sol, arm)
    flip = np.array([c.flip for c in configs])[:, None, None]
    turns = np.array([c.turns for c in configs])  # (N, 3)
    wanted = np.ones(cand.shape, bool)
    k = np.floor((np.degrees(np.nan_to_num(cand[..., [0, 3, 5]])) + 180.0) / 360.0)
    wanted[..., [0, 3, 5]] = k == turns[:, None, None, :]
    wanted[..., 4] = np.where(flip, cand[..., 4] > -_ZERO_RAD, cand[..., 4] <= _ZERO_RAD)
    return _pick(cand, wanted)


def nearest_chain(sol: IKSolutions, start: Array, fixed: Array | None = None
                  ) -> tuple[Array, Mask]:
    """Each target's valid solution nearest the previous target's (the first target's nearest
    `start` (6,) rad), as a controller moving through the program in order takes it (Universal
    Robots; targets written without flags); rows of `fixed` (N, 6) that are not NaN are
    already chosen (by their flags) and only carried on. Which targets have one."""
    N = sol.q.shape[0]
    out = np.full((N, 6), np.nan)
    found = np.zeros(N, bool)
    prev = np.asarray(start, float)
    carried: Mask = np.zeros(N, bool)
    if fixed is not None:
        carried = np.all(np.isfinite(fixed), axis=1)
        out[carried], found[carried] = fixed[carried], True
    free = np.flatnonzero(~carried)
    if free.size == 0:
        return out, found
    # NaN (no such solution) as infinity: never nearest, and a target with none stays unfound
    cand = np.nan_to_num(_candidates(sol)[free].reshape(free.size, -1, 6), nan=np.inf)
    for i, k in enumerate(free.tolist()):  # sequential: each choice depends on the one before
        if k > 0 and carried[k - 1]:  # the flagged target just before: carried on from it
            prev = out[k - 1]
        d = cand[i] - prev
        dist = np.sqrt(np.add.reduce(d * d, axis=-1))  # np.linalg.norm's sum, bit for bit
        j = int(dist.argmin())
        if dist[j] < np.inf:
            out[k], found[k], prev = cand[i, j], True, cand[i, j]
    return out, found
