"""Joint readings that lag the motion, and the lost motion of the move: estimated with the fit
and corrected.

A controller asked for its joints right after a move returns readings taken before the arm has
settled: each reading still carries part of the move that brought the arm there. The readings are
modelled as q_read = q_true - lambda_j (q_read - q_previous), per joint j, with q_previous the
readings of the pose measured just before (`MeasurementSet.q_previous`). A joint with backlash
stops b_j / 2 short of where its motor says, on the side it came from (`approach_sides`): the
same previous move carries it, by its sign. Estimated apart, each takes the other's share (the
lost motion read as a lag of the opposite sign: on an emulated IRB 1600 whose joints 2-3 lag by
2e-4 and every joint has 0.006-0.01 deg of backlash, the lag alone came out at 75 % on joints
2-3 and -1.5e-4 on joint 1, which has none); so both are estimated together, and with the fit's
own parameters: `reading_increment` is the Gauss-Newton step of the fit extended by their
columns (the parameters' share projected out, not a per-pose minimum-norm joint error, which
spreads a residual over every joint). `correct_lag` applies them to the readings. The
identification alternates the two (`identify(..., lag="auto")`) when the lag diagnostic flags a
joint, keeping the terms beyond `READING_T` standard errors; the commanded joints, when
available, are the better cure.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from screwcal.calibration.measurements import MeasurementSet
from screwcal.kinematics.se3 import Array, Mask

if TYPE_CHECKING:
    from screwcal.calibration.residual_problem import ResidualProblem

READING_T = 3.0  # |value| / std error from which a joint's lag or lost motion is corrected


def previous_move(data: MeasurementSet) -> Array:
    """(N, n) the move that brought the arm to each pose (rad / mm; 0 where unknown)."""
    if data.q_previous is None:
        return np.zeros_like(data.q)
    return np.nan_to_num(data.q - data.q_previous)


def approach_sides(data: MeasurementSet) -> Array:
    """(N, n) the side each joint came to its pose from: +1 from below, -1 from above, 0
    unknown: the data's approach directions where given, else the sign of the previous move."""
    sides = np.sign(previous_move(data))
    if data.directions is not None:
        sides = np.where(data.directions != 0, np.sign(data.directions), sides)
    return sides


def correct_lag(data: MeasurementSet, lag: Array, lost_motion: Array | None = None
                ) -> MeasurementSet:
    """The readings with `lag` (n,) of the previous move added back and, with `lost_motion`
    (n,; rad / mm), half of it taken off on the side each joint came from:
    q + lag (q - q_previous) - lost_motion / 2 side."""
    lost = np.zeros_like(np.asarray(lag, dtype=float)) if lost_motion is None else \
        np.asarray(lost_motion, dtype=float)
    if not np.any(lag) and not np.any(lost):
        return data
    return data.with_q(data.q + np.asarray(lag) * previous_move(data)
                       - 0.5 * lost * approach_sides(data))


def reading_columns(problem: ResidualProblem, x: Array) -> Array:
    """(rows, 2n) the rates of the fit's whitened residuals, prior rows included (zeros), at x
    w.r.t. each joint's lag (n) then lost motion (n). The moves and sides are the problem's
    readings' (corrected already, they differ from those measured by the lag's share of the
    move, 1e-4 of it, and the sides not at all)."""
    data = problem.data
    Jq = problem.joint_jacobian(x)  # (N, k, n)
    per_joint = np.concatenate([previous_move(data), -0.5 * approach_sides(data)], axis=1)
    cols = np.concatenate([Jq, Jq], axis=2) * per_joint[:, None, :]
    B = (problem.whiten @ cols).reshape(-1, cols.shape[-1])
    return np.vstack([B, np.zeros((len(problem.prior), B.shape[1]))])


def reading_increment(problem: ResidualProblem, x: Array, terms: Mask
                      ) -> tuple[Array, Array]:
    """The lag and lost motion per joint (2n,) that, added to the correction the problem's
    readings carry, best explain its residuals at x jointly with its parameters (the
    Gauss-Newton step of the extended fit), and their standard errors (2n,; from the
    residual's own scale). Only the `terms` (2n,) bool are estimated; the others are 0 (their
    standard error inf)."""
    r, A = problem.posterior(x)
    B = reading_columns(problem, x)[:, terms]
    M = np.hstack([A, B])
    norms = np.linalg.norm(M, axis=0)
    norms[norms == 0.0] = 1.0
    U, s, Vt = np.linalg.svd(M / norms, full_matrices=False)
    keep = s > s[0] * 1e-10
    V = Vt[keep].T / norms[:, None]
    solution = -V @ ((U[:, keep].T @ r) / s[keep])
    dof = max(1, len(r) - int(keep.sum()))
    variance = np.sum((V / s[keep]) ** 2, axis=1) * float(r @ r) / dof
    value, std = np.zeros(len(terms)), np.full(len(terms), np.inf)
    value[terms] = solution[A.shape[1]:]
    std[terms] = np.sqrt(variance[A.shape[1]:])
    return value, std


def moving_terms(data: MeasurementSet) -> Mask:
    """(2n,) the lags and lost motions the data can show: those of the joints that move."""
    moves = np.any(previous_move(data) != 0.0, axis=0)
    return np.concatenate([moves, moves])


def commands_for_lost_motion(q: Array, lost_motion: Array, before: Array | None = None
                             ) -> Array:
    """(N, n) the joints to command so that joints which stop half their `lost_motion` (n,)
    short on the side they came from land on `q` (N, n), visited in this order from `before`
    (n,; default: the first): each joint commanded half its lost motion beyond its target, on
    the side its move comes from (for a joint that does not move, the side of its last move)."""
    q = np.asarray(q, dtype=float)
    start = q[:1] if before is None else np.asarray(before, dtype=float)[None]
    sides = np.sign(np.diff(np.vstack([start, q]), axis=0))
    for k in range(1, len(sides)):
        sides[k] = np.where(sides[k] == 0.0, sides[k - 1], sides[k])
    return q + 0.5 * np.asarray(lost_motion, dtype=float) * sides
