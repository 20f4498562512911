"""The prior's scale learned from the data on small sets (empirical Bayes).

The weak prior of `plausible` gives every parameter a standard deviation of half its plausible
range: a joint zero +-5 deg, a length +-5 mm. That is right for what a real robot could be, and
far wider than what a given robot is: a real IRB 120's zeros are off by hundredths of a degree.
With many poses the prior's width does not matter (the data decide). With few (a 24-pose fold
of a touch-probe set, position only: 72 numbers for 39 parameters), least squares spends the
freedom the wide prior leaves on fitting the noise, and the model predicts new poses worse.

The remedy is the prior's own scale estimated from the data, per group of like parameters
(joint zeros, axis tilts, lengths: the groups `PlausibleRanges` names): the robot's parameters
of a group are taken as draws of one zero-mean Gaussian whose variance is estimated by
expectation-maximisation (the type-II maximum-likelihood, or evidence, estimate):

    sigma_g^2 = mean over the group of (x_k^2 + s_k^2)

with x_k the estimate and s_k its posterior standard deviation under the current prior; the
identification is repeated with the new scales until they settle. A group whose parameters the
data show to be large keeps a wide prior; a group that the data find small gets a narrow one.
The scales never exceed the plausible ranges (those still bound the warnings) and never fall
below `FLOOR_SHARE` of them.

Measured (tests/screwcal/calibration/test_empirical_prior.py holds the simulated case,
tests/screwcal/studies/test_tracker_dataset.py the real one):
- the IRB 120 tracker set, 36-pose subsets, position only, 3-fold cross-validation (fits on 24
  poses), 12 subsets: held-out mean 0.495 mm against 0.524 mm with the plausible scale, 0.909x
  a plain full calibration's 0.545 mm (0.962x before); a calibration on 600 other poses of
  the set reaches 0.754x on the same held-out poses, the floor such a fit approaches
  (`python -m screwcal.studies.small_sets`);
- simulated IRB 1600s with errors on every axis, 36 position-only poses, 10 robots: held-out
  0.237 mm against 0.260 mm; the Monte Carlo of `screwcal.studies.position_only` (100 robots,
  30 poses): 0.321 / 0.335 mm against 0.337 / 0.340 mm (point on axis 6 / offset).
It applies where the data are few for the model: fewer than `SMALL_SET_NUMBERS` measured
numbers per identified parameter (a 40-pose full-pose set has 6: unchanged). Beyond that its
gain is small (100 position-only poses: 0.143 against 0.149 mm) and its rounds cost fits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from screwcal.calibration.error_parameters import Param
from screwcal.calibration.plausible import RANGE_SIGMAS, PlausibleRanges
from screwcal.kinematics.se3 import Array
from screwcal.tables import counted

SMALL_SET_NUMBERS = 5.0  # measured numbers per identified parameter below which it applies
ROUNDS = 4  # at most this many refits
SETTLED = 0.1  # stop when no group's scale moves by more than this share
FLOOR_SHARE = 0.01  # a scale never narrower than this share of the plausible range

GROUPS = ("zero_deg", "tilt_deg", "length_mm")  # the PlausibleRanges fields it learns


def group_of(p: Param) -> str | None:
    """The PlausibleRanges field a robot parameter's prior comes from, or None (frames and
    compliance keep their plausible ranges: their scale is the set-up's, not the robot's)."""
    if p.group != "robot" or p.kind.startswith("compliance"):
        return None
    if p.kind == "zero":
        return "zero_deg" if p.is_angle else "length_mm"
    if p.kind in ("dir", "home_rot"):
        return "tilt_deg"
    return "length_mm"


def is_small(n_numbers: int, n_identified: int) -> bool:
    """Whether the data are few for the model (`SMALL_SET_NUMBERS` per parameter)."""
    return n_numbers < SMALL_SET_NUMBERS * max(n_identified, 1)


@dataclass(frozen=True)
class LearnedScales:
    """The prior's ranges after one update, and how far the largest group's scale moved."""

    ranges: PlausibleRanges
    moved: float


def updated_ranges(params: Sequence[Param], values: Array, std_errors: Array,
                   prior: PlausibleRanges, plausible: PlausibleRanges) -> LearnedScales:
    """One expectation-maximisation step of the groups' scales (interface units, as the
    result's values and standard errors), each range RANGE_SIGMAS standard deviations, within
    [FLOOR_SHARE, 1] of the plausible range."""
    sums: dict[str, list[float]] = {g: [] for g in GROUPS}
    for p, v, s in zip(params, values, std_errors, strict=True):
        group = group_of(p)
        if group is not None:
            sums[group].append(float(v) ** 2 + float(np.nan_to_num(s)) ** 2)
    learned, moved = {}, 0.0
    for group, terms in sums.items():
        if not terms:
            continue
        limit = float(getattr(plausible, group))
        new = min(max(RANGE_SIGMAS * float(np.sqrt(np.mean(terms))), FLOOR_SHARE * limit),
                  limit)
        old = float(getattr(prior, group))
        moved = max(moved, abs(new - old) / old)
        learned[group] = new
    return LearnedScales(replace(prior, **learned), moved)


def describe(learned: PlausibleRanges, plausible: PlausibleRanges, rounds: int,
             flagged: int = 0) -> str:
    """The note a result carries: the scales and where they came from; `flagged`: poses that
    looked like outliers under the next, narrower scales (where the rounds stopped)."""
    stop = f"; stopped before narrower scales under which {counted(flagged, 'pose')} " \
        f"looked like {'an outlier' if flagged == 1 else 'outliers'}" if flagged else ""
    if not rounds:
        return f"the plausible ranges (a small set for the model{stop})"
    return (f"learned from the data (empirical Bayes, {rounds} refits; a small set for the "
            f"model): joint zeros +-{learned.zero_deg:.3g} deg, axis tilts "
            f"+-{learned.tilt_deg:.3g} deg, lengths +-{learned.length_mm:.3g} mm (plausible "
            f"ranges +-{plausible.zero_deg:g} deg, +-{plausible.tilt_deg:g} deg, "
            f"+-{plausible.length_mm:g} mm){stop}")
