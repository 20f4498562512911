"""Outlier rounds on the fit's linearisation: the poses that do not belong, found without a
refit per round (issue 29).

A gross error hides smaller ones: it pulls the fit and inflates the estimated noise, so data
snooping (`diagnostics.pose_tests`) rejects in rounds, the clearly worst first: above the
limit, within half of the worst statistic or beyond the limit whatever the other poses above
it leak into the pose's residual (`without_leaks`: many poses, small leverages, a round takes
every large error at once). Each round refitted from scratch (16 fits for 1 % gross
errors of 0.2-20 mm at 5000 poses); here every round works on the fit's linearisation at its
estimate x instead (Gauss-Newton on the normal equations):

- the rejected poses' rows leave the weighted normal equations and the linear step is solved on
  the rows kept (what a refit moves to first order: gross errors move the estimate by
  hundredths of a millimetre or degree, where the model is linear to far below the noise);
- the residuals of every pose are carried by that step (e + A dx);
- the noise levels are held between re-estimations (the gross errors inflate them: held
  levels can only err on the safe side);
- when no pose exceeds its limit, the variance components are estimated again on the
  linearisation (`noise_levels.levels_on_linearisation`), from the held ones scaled by the
  kept rows' variance factor (one below detection from its edge, `noise_levels.from_start`);
  the rounds go on while that uncovers more.

Why not a robust loss (Huber, Cauchy) with a final clean fit: it names no pose by a test (a
threshold on a weight is not a statistic with a level), its reweighting needs the nonlinear
solve in every iteration, and the down-weighted gross errors still inflate the variance
components the weights come from. Why not warm-started refits: each still builds the Jacobian,
re-estimates the noise and solves; the linearisation gives the same rejections for the cost of
one linear solve per round. The caller then fits the poses kept once more, from the rounds'
estimate and levels: that fit is the result, and its own pose tests confirm the rounds (a pose
they missed starts new rounds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from screwcal.calibration.diagnostics import PoseTest, whitened_pose_tests
from screwcal.calibration.identifiability import Index
from screwcal.calibration.noise_levels import from_start, levels_on_linearisation
from screwcal.calibration.residual_problem import whitening_of_levels
from screwcal.calibration.solvers import gauss_newton_step
from screwcal.kinematics.se3 import Array, Mask

WORST_SHARE = 0.5  # a round rejects the poses within this share of the worst statistic
LEAK_MARGIN = 2.0  # ...and those beyond the limit by this many times what others can leak


@dataclass(frozen=True)
class Rejection:
    """A pose rejected in a round: its index among the poses given, its position residual
    (mm) and statistic in that round, and the round's limit."""

    index: int
    residual_mm: float
    statistic: float
    threshold: float


@dataclass(frozen=True)
class Rounds:
    """What the rounds found: the poses rejected, in order, and the estimate (p,) and
    variance components (3,) of the poses kept, on the linearisation (a refit's start)."""

    rejected: list[Rejection]
    x: Array
    theta: Array


def worst_poses(test: PoseTest, limit: float, cap: int) -> Index:
    """The poses a round rejects, the worst first, at most `cap`: above the limit, and within
    `WORST_SHARE` of the worst statistic or still above it without what the other poses above
    it can leak into theirs (`without_leaks`)."""
    statistic = test.statistic
    above = statistic > limit
    drop = np.flatnonzero(above & ((statistic >= WORST_SHARE * float(statistic.max()))
                                   | (without_leaks(statistic, test.leverage, above) > limit)))
    return drop[np.argsort(-statistic[drop])][:cap]


def without_leaks(statistic: Array, leverage: Array, above: Mask) -> Array:
    """A lower bound of each pose's statistic (N,) without the errors of the poses `above`
    the limit (N,) leaking into its residual through the fit, `LEAK_MARGIN` times the leak.

    In whitened units the residuals are r = (I - H) eps. What pose i's error puts into pose
    j's residual is H_ji eps_i, with |H_ji| <= sqrt(h_j h_i) (H_ji = B_j B_i^T, Cauchy-
    Schwarz; h the leverages) and |eps_i| ~ |Q_i^-1 r_i| <= sqrt(T_i / (1 - h_i)); pose j's
    statistic reads it through Q_j^-1/2, |Q_j^-1/2| <= 1 / sqrt(1 - h_j). So sqrt(T_j) less
    sqrt(h_j / (1 - h_j)) sum_i sqrt(h_i T_i / (1 - h_i)), over the poses above but j: a gross
    error of its own, whatever the others' do. A round rejects it with the worst; a few
    large errors among many poses (leverages ~ p / N) no longer take a round per halving
    of the statistic."""
    h = np.clip(leverage, 0.0, 1.0 - 1e-9)
    gain = np.sqrt(h / (1.0 - h))
    size = np.where(above, gain * np.sqrt(statistic), 0.0)  # sqrt(h_i) |eps_i|
    leak = LEAK_MARGIN * gain * (size.sum() - size)
    bound: Array = np.clip(np.sqrt(statistic) - leak, 0.0, None) ** 2
    return bound


def reject_in_rounds(e: Array, A: Array, V: Array, theta: Array, free: Index, prior: Array,
                     x: Array, whiten: Array, cap: int) -> Rounds:
    """The poses to reject, in the order the rounds reject them (at most `cap`), with the
    estimate and the variance components of the poses kept.

    At the fit's estimate x: residuals e (N, k), their Jacobian A (N, k, p), the unit
    variance components V (3, N, k, k) and the components theta (3,) the fit used (those in
    `free` were estimated, the others are held), the prior's weights (p,) and the fit's own
    whitening (N, k, k) for the first round. The whitening of every pose and the whitened
    Jacobian W A are formed once per set of components (a pose's whitening does not depend on
    which poses are kept): the rounds between re-estimations read the kept poses' rows."""
    e, theta = e.copy(), np.array(theta, dtype=float)
    kept = np.arange(len(e))
    out: list[Rejection] = []
    estimated = True  # the components are those of the rows kept
    W, own = whiten, True  # (the fit's own whitening, until the rounds' components replace it)
    Aw = W @ A
    while len(out) < cap:
        ew = W[kept] @ e[kept, :, None]
        test = whitened_pose_tests(ew, Aw[kept])
        limit = test.threshold()
        if test.statistic.max() <= limit:
            if estimated or not len(free):
                break
            # from the held components scaled by the kept rows' variance factor (what the
            # gross errors put in them gone), one below detection at its edge (`from_start`)
            mask = np.isin(np.arange(len(theta)), free)
            start = from_start(theta, mask, theta * float(np.sum(ew ** 2)) / max(
                ew.size - A.shape[-1], 1), V[:, kept])
            levels = levels_on_linearisation(e[kept], A[kept], V[:, kept], start, free, prior,
                                             x)
            e = e + A @ (levels.x - x)
            theta, x, estimated = levels.theta, levels.x, True
            W = whitening_of_levels(theta, V)
            Aw = W @ A
            continue
        drop = worst_poses(test, limit, cap - len(out))
        out += [Rejection(int(kept[k]), float(np.linalg.norm(e[kept[k], :3])),
                          float(test.statistic[k]), limit) for k in drop]
        kept = np.delete(kept, drop)
        if own:
            W, own = whitening_of_levels(theta, V), False
            Aw = W @ A
        dx = gauss_newton_step(Aw[kept].reshape(-1, A.shape[-1]),
                               (W[kept] @ e[kept, :, None]).reshape(-1), prior, x)
        x, e = x + dx, e + A @ dx
        estimated = False
    return Rounds(out, x, theta)
