"""The solutions of inverse kinematics: every branch of N targets as controller readings.

`IKSolutions` holds the eight branches' joint readings with their masks (reachable, within the
joint limits) and picks, per target, the valid branch nearest a reference. The readings are the
joint angles with the joint zero removed, wrapped into the one-turn window each joint's limits
give (`controller_readings`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import UnreachableError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel, once_per_object
from screwcal.kinematics.se3 import Array, Mask

BRANCHES = tuple((s, e, w) for s in ("front", "back") for e in ("up", "down")
                 for w in ("noflip", "flip"))
_TAU = 2.0 * np.pi


@dataclass(frozen=True)
class IKSolutions:
    """All IK branches for N targets.

    q : (N, 8, 6) joint values in rad (controller readings, joint zero removed), NaN where a
        branch does not exist; reachable, within_limits : (N, 8) masks; branches : labels of the
        second axis; residual_mm : (N, 8) position error of each branch's FK vs the target.
    """

    q: Array
    reachable: Mask
    within_limits: Mask
    residual_mm: Array
    branches: tuple[tuple[str, str, str], ...] = BRANCHES
    limits: Array | None = None  # (6, 2) rad, for choosing among 2 pi-equivalent turns

    @property
    def valid(self) -> Mask:
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
        none: Mask = ~np.any(np.isfinite(dist), axis=1)
        if none.any():
            k = int(np.flatnonzero(none)[0])
            why = "outside the joint limits on every branch" if self.reachable[k].any() \
                else "out of reach"
            raise UnreachableError(f"target {k} is {why} ({int(none.sum())} of "
                                   f"{len(none)} targets have no valid solution)", index=k)
        nearest: Array = q[np.arange(len(dist)), np.argmin(dist, axis=1)]
        return nearest


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

def controller_readings(model: SerialModel, theta: Array) -> tuple[Array, Mask]:
    """Joint angles (N, 8, 6), NaN where out of reach -> controller readings: the joint zero
    removed, wrapped to [-pi, pi), then moved by a turn where that brings a reading outside the
    limits inside them; and whether each branch is within the limits (N, 8).

    That rule gives each joint a window of one turn its readings fall in (`_reading_tables`),
    so a reading is the window's start plus the angle's remainder modulo a turn: five array
    calls, three when no window is closed at its top."""
    sign, shift, start, lo, hi = _reading_tables(model)
    if theta.shape[-2:] != shift.shape[-2:]:  # not eight branches: the tables' row per joint
        shift, start, lo, hi = shift[0, 0], start[0, 0], lo[0, 0], hi[0, 0]
        sign = None if sign is None else sign[0, 0]
    q = theta if sign is None else theta * sign
    q = _remainder_of_turns(q + shift)
    if sign is not None:
        q *= sign
    q += start
    within: Mask = np.all((q >= lo) & (q <= hi), axis=-1)  # NaN compares False: out of reach
    return q, within


def _remainder_of_turns(x: Array) -> Array:
    """x % 2 pi, the same numbers as numpy's remainder (its own rule: fmod, a turn added to a
    negative remainder, a zero made +0), at a third of its time, a tenth where x has NaN."""
    r: Array = np.fmod(x, _TAU)
    np.add(r, _TAU, out=r, where=r < 0.0)
    r += 0.0
    return r


@once_per_object
def _reading_tables(model: SerialModel) -> tuple[Array | None, Array, Array, Array, Array]:
    """Per joint the window of one turn its readings fall in, as (sign, shift, start) with
    reading = start + sign ((sign theta + shift) mod 2 pi), and the lower and upper limits.

    The rule of `controller_readings`: wrapped to [-pi, pi), a reading below `below` (under
    the lower limit, and a turn up no further than the upper one) is turned up, one above
    `above` turned down. So the window is [-pi, pi) for most joints; [below, below + 2 pi)
    where a turn up can happen; (above - 2 pi, above] where a turn down can (sign -1: closed
    at its top, as the rule keeps a reading equal to `above`). No joint can have both
    (below > -pi needs hi > pi, above < pi needs hi < pi).
    `sign` is None when every joint's is +1."""
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


def solutions_of(model: SerialModel, q: Array, reach: Mask, within: Mask, T_world: Array,
                 check: bool = True) -> IKSolutions:
    if check:  # the FK of every branch against the target (NaN where out of reach)
        N = q.shape[0]
        T = forward_kinematics(model, q.reshape(-1, 6)).reshape(N, q.shape[1], 4, 4)
        residual = np.hypot.reduce(T[..., :3, 3] - T_world[:, None, :3, 3], axis=-1)
    else:
        residual = np.full(reach.shape, np.nan)
    return IKSolutions(q=q, reachable=reach, within_limits=within, residual_mm=residual,
                       limits=model.limits)


def require_reachable(reach: Mask) -> None:
    if len(reach) == 1 and reach.any():  # one target: a single reduction decides
        return
    some: Mask = np.any(reach, axis=1)
    if some.all():
        return
    none = ~some
    k = int(np.flatnonzero(none)[0])
    raise UnreachableError(f"target {k} is out of the arm's reach on every branch "
                           f"({int(none.sum())} of {len(none)} targets unreachable)", index=k)
