"""Which measuring-arm reading belongs to a pose.

The arm streams triples (P1, P2, P3) whenever it probes; nothing in a triple names the pose. A
reading is taken for a pose only when all of these hold:
- it was received after the go-ahead for the pose was sent (the line is drained just before: a
  triple of the previous pose, or an early one, is never read as this pose's);
- it is not a repeat of the previous pose's triple (the arm prints 4 decimals and its noise is
  0.013 mm: two probes never agree to the last digit, so an identical triple is a duplicate);
- the motion it measured agrees with the motion commanded: the distance between the previous
  pose's measured flange and this one (and the angle between their orientations) against the
  same between the nominal flanges at the joints read. Distances and angles do not depend on the
  arm's frame. An uncalibrated robot's own errors change them by up to ~10 % (the thesis's
  Table 11 robot: 279 mm measured for 254 mm commanded), hence the relative tolerance (30 % by
  default); a stale or repeated reading measures no motion at all and is refused whenever the
  commanded motion exceeds the tolerance (about 7 mm by default).
- it is not a re-probe of a pose the robot has left: its holes match no earlier reading of the
  job (to `STALE_MM`, about 5 sigma of the difference of two probes) unless the robot was
  commanded to that same place again (nominal flanges within `REVISIT_MM`; repeatability
  cycles revisit poses). The motion check alone cannot see a stale triple of an older pose whose
  distance to the previous pose happens to agree with the commanded one.
A refused reading is discarded, counted and logged; the pose is measured again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from screwcal.kinematics.pose import rotation_angle_deg

DUPLICATE_MM = 5e-4  # below the arm's last printed digit (0.1 um): the same line sent twice
STALE_MM = 0.1  # two probes of one place: 0.018 mm sigma per coordinate apart (0.013 * sqrt 2)
REVISIT_MM = 1.0  # nominal flanges this close: the robot was sent to the same place again


@dataclass(frozen=True)
class PoseReading:
    """One pose's accepted reading: the holes (3, 3) and the measured tool0 (4, 4), both in the
    arm's frame, and the nominal tool0 (4, 4) at the joints the controller read, base frame."""

    holes_mm: np.ndarray
    flange: np.ndarray
    nominal: np.ndarray


@dataclass(frozen=True)
class MotionTolerance:
    mm: float = 5.0
    rel: float = 0.3
    deg: float = 6.0  # the Table 11 robot: 2.3 deg between two ISO 9283 cube poses


@dataclass(frozen=True)
class EarlierReadings:
    """The job's accepted readings so far: holes (N, 3, 3) in the arm's frame, nominal flange
    positions (N, 3) in the base frame, and each one's (phase, index) for the message."""

    holes_mm: np.ndarray
    nominal_mm: np.ndarray
    names: tuple[str, ...]

    @classmethod
    def empty(cls) -> EarlierReadings:
        return cls(np.empty((0, 3, 3)), np.empty((0, 3)), ())

    def plus(self, reading: PoseReading, name: str) -> EarlierReadings:
        return EarlierReadings(np.concatenate([self.holes_mm, reading.holes_mm[None]]),
                               np.concatenate([self.nominal_mm, reading.nominal[None, :3, 3]]),
                               (*self.names, name))

    def stale_of(self, new: PoseReading) -> str | None:
        """The earlier pose `new` re-probes though the robot was sent elsewhere, or None."""
        if not len(self.names):
            return None
        same_place = np.max(np.abs(self.holes_mm - new.holes_mm), axis=(1, 2)) < STALE_MM
        elsewhere = np.linalg.norm(self.nominal_mm - new.nominal[:3, 3], axis=1) > REVISIT_MM
        hits = np.flatnonzero(same_place & elsewhere)
        return self.names[hits[-1]] if len(hits) else None


def refusal(previous: PoseReading | None, new: PoseReading, tol: MotionTolerance,
            earlier: EarlierReadings | None = None) -> tuple[str, str] | None:
    """(kind, reason) when `new` cannot be the reading of its pose, None when it is accepted.
    Kinds: 'duplicate', 'stale', 'motion'."""
    if previous is None:
        return None
    if np.max(np.abs(new.holes_mm - previous.holes_mm)) < DUPLICATE_MM:
        return "duplicate", "the same triple as the previous pose's (a line sent twice)"
    stale = None if earlier is None else earlier.stale_of(new)
    if stale is not None:
        return "stale", (f"the holes of pose {stale}, measured earlier, though the robot was sent "
                         "elsewhere (a stale reading)")
    measured = float(np.linalg.norm(new.flange[:3, 3] - previous.flange[:3, 3]))
    commanded = float(np.linalg.norm(new.nominal[:3, 3] - previous.nominal[:3, 3]))
    allowed = tol.mm + tol.rel * commanded
    if abs(measured - commanded) > allowed:
        return "motion", (f"measured motion {measured:.2f} mm from the previous pose, commanded "
                          f"{commanded:.2f} mm (tolerance {allowed:.2f} mm): a stale, early or "
                          "foreign reading")
    turned = float(rotation_angle_deg(previous.flange[:3, :3], new.flange[:3, :3]))
    told = float(rotation_angle_deg(previous.nominal[:3, :3], new.nominal[:3, :3]))
    allowed_deg = tol.deg + tol.rel * told
    if abs(turned - told) > allowed_deg:
        return "motion", (f"measured rotation {turned:.2f} deg from the previous pose, "
                          f"commanded {told:.2f} deg (tolerance {allowed_deg:.2f} deg): a stale, "
                          "early or foreign reading")
    return None
