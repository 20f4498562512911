"""Among models that fit equally, the one nearest nominal: plausible ranges, the weak prior
they give, and the directions the prior (not the data) decided.

Where the data leave a direction of the parameters free or nearly so (the measured point on
joint 6's axis with position-only data: joint 6's zero, and combinations of axis tilts, frames
and the tool that move no measured point), least squares alone wanders along it and returns
any of many equivalent models (one had joint 5's zero at 151 deg and axes tilted 14-19 deg, yet
predicted positions to 0.02 mm). A zero-mean Gaussian prior on every parameter, with the
plausible range as its standard deviation, picks the solution nearest nominal in those
directions (the maximum a posteriori estimate; Tikhonov regularisation with the prior's
scaling), sigma_k being half the range (the range holds 95 % of the prior):

    minimise |W (f(x) - y)|^2 + sum_k (x_k / sigma_k)^2

A determined direction, with standard error s from the data, is pulled toward nominal by the
factor s^2 / (s^2 + sigma^2): for the well-determined ones (s ~ 0.001-0.01 deg against sigma
1-5 deg) by less than 1e-4 of itself, far below its own standard error; a test holds this.

The directions the prior decided are those where the data carry less information than the
prior: the eigenvectors of D J^T J D (J the whitened Jacobian, D = diag(sigma)) with
eigenvalues below 1 (a data standard error in that direction larger than the prior's).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from screwcal.calibration.error_parameters import Param
from screwcal.kinematics.compliance import COMPLIANCE_UNIT
from screwcal.kinematics.se3 import Array

RANGE_SIGMAS = 2.0  # a plausible range is this many of the prior's standard deviations (95 %)


@dataclass(frozen=True)
class PlausibleRanges:
    """+- ranges (interface units) beyond which no real robot's parameter lies: joint zeros,
    axis tilts (and the home flange's rotation), lengths (axis shifts, link offsets, the home
    flange's position), the measuring frame and the measured point relative to where the
    alignment put them, joint compliance. They scale the prior and bound the warnings."""

    zero_deg: float = 10.0
    tilt_deg: float = 2.0
    length_mm: float = 10.0
    frame_rotation_deg: float = 10.0
    frame_position_mm: float = 100.0
    compliance_deg_per_knm: float = 10.0

    def of(self, p: Param) -> float:
        """The range of parameter p, in its interface unit."""
        if p.kind in ("compliance", "compliance_mass"):
            return self.compliance_deg_per_knm
        if p.group != "robot":
            return self.frame_rotation_deg if p.is_angle else self.frame_position_mm
        if p.kind == "zero":
            return self.zero_deg if p.is_angle else self.length_mm
        if p.kind in ("dir", "home_rot"):
            return self.tilt_deg
        return self.length_mm  # point, link, home_pos

    def describe(self) -> str:
        return (f"joint zeros +-{self.zero_deg:g} deg, axis tilts +-{self.tilt_deg:g} deg, "
                f"lengths +-{self.length_mm:g} mm, frames +-{self.frame_rotation_deg:g} deg / "
                f"+-{self.frame_position_mm:g} mm of the alignment, compliance "
                f"+-{self.compliance_deg_per_knm:g} {COMPLIANCE_UNIT}")


def prior_sigma(params: Sequence[Param], ranges: PlausibleRanges) -> Array:
    """The prior's standard deviation per parameter, numeric units (rad, mm): its range over
    RANGE_SIGMAS."""
    return np.array([np.radians(ranges.of(p)) if p.is_angle else ranges.of(p)
                     for p in params]) / RANGE_SIGMAS


def held_directions(gram: Array, sigma: Array, names: Sequence[str], limit: int = 8
                    ) -> list[str]:
    """The parameter combinations the prior, not the data, decided (the data's information
    Jw^T Jw (p, p) of the whitened Jacobian Jw, prior sigma (p,)): each as its largest terms
    (in units of the prior's sigma), with how much of the prior's information the data give
    in that direction."""
    if gram.shape[1] == 0:
        return []
    information, vectors = np.linalg.eigh(gram * np.outer(sigma, sigma))
    out = []
    for k in np.flatnonzero(information < 1.0)[:limit]:
        v = vectors[:, k]
        top = [t for t in np.argsort(-np.abs(v))[:3] if abs(v[t]) > 0.2]
        terms = " ".join(f"{v[t]:+.2f} {names[t]}" for t in top)
        out.append(f"{terms} (the data give {max(information[k], 0.0):.2g} of the prior's "
                   "information)")
    return out


def outside_ranges(params: Sequence[Param], values: Array, std_errors: Array,
                   ranges: PlausibleRanges) -> list[str]:
    """A line per parameter (interface values) beyond its plausible range."""
    out = []
    for p, v, s in zip(params, values, std_errors, strict=True):
        bound = ranges.of(p)
        if abs(v) > bound:
            out.append(f"{p.name} {v:+.3g} {p.unit} (+- {s:.2g}) is outside the plausible "
                       f"+-{bound:g} {p.unit}")
    return out
