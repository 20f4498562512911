"""Drift over a long job (ISO 9283 drift of pose characteristics, issue 25 point 5).

A few reference poses (`drift_poses`: the test cube's P1, P2, P4, P3, P5 in that order, each
approached from 1 deg below on every joint, so every joint comes from the same side at every
check) are measured as the job's first poses, then again every `drift_period_poses` measured
poses (or every `drift_period_s` seconds), and after each measured list. They are committed like
every other pose, in their own phase `drift` (index = check x poses per check + position in the
check): a check is due, and which poses of it are missing, is decided from the store alone, so a
restart or a lease takeover completes a check begun, never measures a pose twice, and loses
none.

The result's `drift` section is the series of Eq. D.1 (`screwcal.performance.drift`): per check
its time (s since the first check, the store's clock) and per reference pose the norm of the
change of its measured position since its first measurement under the same payload (a check
interleaved with a list runs with that list's payload; a check under another payload starts its
own series, the deflection a payload change causes being no drift).

What the model promised: the calibration's residual noise level, its estimated position noise
per coordinate (the identification's noise estimate) as a distance, sqrt(3) sigma: the scatter
the calibrated model leaves unexplained. The job warns when the drift since the calibration
(from the check after the calibration list to the job's last check, the mean over the reference
poses of the norm) exceeds it by more than what that mean reads with no drift at all (its mean
plus 3 standard deviations, sqrt(2) s per coordinate for the difference of two checks, s the
checks' own noise from their second differences, in which a drift steady over three checks
cancels).
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from screwcal.performance.drift import drift_series
from service.document import DriftSection, JobOptions, ResultDocument
from service.plans import PlannedPose

DRIFT_PHASE = "drift"
REFERENCE_ORDER = ("P1", "P2", "P4", "P3", "P5")  # the cube's centre, then far-apart corners
APPROACH_DEG = 1.0  # every joint's move onto a reference pose, from below
TIME_PERIOD_CHUNK = 10  # with a period in seconds, checked at least every this many poses
# the mean norm of a 3-D Gaussian difference of sigma sqrt(2) per coordinate, and its spread
_CHI3_MEAN, _CHI3_STD = 1.5958, 0.6734


@dataclass(frozen=True)
class DriftState:
    """What the store says of the drift checks: reference poses committed, when the last was,
    and how many other poses of the job were measured since."""

    committed: int
    last_at: float | None
    poses_since: int


@dataclass(frozen=True)
class DriftSchedule:
    """The reference poses (approach and target pairs) and when they are measured again."""

    references: tuple[PlannedPose, ...]
    period_poses: int
    period_s: float | None = None

    @property
    def per_check(self) -> int:
        return len(self.references)

    def check(self, k: int) -> list[PlannedPose]:
        """Check k's poses, indexed k * per_check + j."""
        return [replace(p, idx=k * self.per_check + j, cycle=k)
                for j, p in enumerate(self.references)]

    def due(self, state: DriftState, now_s: float, end_of_list: bool) -> int | None:
        """The check to measure now (one begun and not finished first), or None."""
        k, partial = divmod(state.committed, self.per_check)
        if partial or k == 0:
            return k
        if state.poses_since == 0:
            return None
        if end_of_list:
            return k
        if self.period_s is not None:
            return k if state.last_at is None or now_s - state.last_at >= self.period_s \
                else None
        return k if state.poses_since >= self.period_poses else None

    def room(self, state: DriftState) -> int:
        """How many poses may be measured before the next check is due (at least 1)."""
        if self.period_s is not None:
            return TIME_PERIOD_CHUNK
        return max(1, self.period_poses - state.poses_since)


def drift_schedule(options: JobOptions, perf_plan: Sequence[PlannedPose]
                   ) -> DriftSchedule | None:
    """The job's schedule from its options and its performance list (None: no drift poses):
    each reference pose after an approach APPROACH_DEG below it on every joint, so that every
    joint comes from the same side at every check (the ISO return point leaves a joint that
    does not move between it and the target on whatever side the pose before left it)."""
    if not options.drift_poses:
        return None
    first = [p for p in perf_plan if p.cycle == 1]
    pairs: list[PlannedPose] = []
    for label in REFERENCE_ORDER[:options.drift_poses]:
        target = next(p for p in first if p.point == label and p.role == "target")
        below = tuple(round(v - APPROACH_DEG, 4) for v in target.joints_deg)
        pairs += [replace(target, joints_deg=below, role="approach"),
                  replace(target, role="reference")]
    return DriftSchedule(tuple(pairs), options.drift_period_poses, options.drift_period_s)


def _checks(schedule: DriftSchedule, drift_rows: Sequence[Mapping[str, Any]]
            ) -> dict[int, dict[str, Mapping[str, Any]]]:
    """The complete checks: k -> {reference label: its committed row}."""
    by_idx = {int(r["idx"]): r for r in drift_rows}
    out = {}
    for k in range(len(by_idx) // schedule.per_check + 1):
        poses = schedule.check(k)
        if all(p.idx in by_idx for p in poses):
            out[k] = {p.point: by_idx[p.idx] for p in poses if p.role == "reference"}
    return out


def drift_section(schedule: DriftSchedule, drift_rows: Sequence[Mapping[str, Any]],
                  other_rows: Sequence[Mapping[str, Any]], list_payloads: Mapping[str, str],
                  calibration_phases: Sequence[str] = (),
                  promised_sigma: float | None = None) -> DriftSection | None:
    """The result's drift section from the committed rows (each with id, idx, phase, created,
    flange_pose). `list_payloads`: phase -> a label of what the flange carried in it (checks
    under different payloads are separate series). `calibration_phases`: the job's measured
    calibration lists, in order (drift since the last one); `promised`: its mean position
    estimated position noise per coordinate (mm), what its model promised."""
    checks = _checks(schedule, drift_rows)
    if not checks:
        return None
    labels = [p.point for p in schedule.references if p.role == "reference"]
    ks = sorted(checks)
    others = sorted(other_rows, key=lambda r: int(r["id"]))
    ids = [int(r["id"]) for r in others]
    first_ids = [min(int(r["id"]) for r in checks[k].values()) for k in ks]
    before = [bisect_left(ids, i) for i in first_ids]  # the poses committed before each check
    lists = [_list_of(others, ids, i) for i in first_ids]
    t = np.array([float(checks[k][labels[0]]["created"]) for k in ks])
    p = np.array([[checks[k][label]["flange_pose"][:3] or checks[k][label]["holes_mm"][0]
                   for label in labels] for k in ks])  # (one point measured: its position)
    deviation = np.zeros((len(ks), len(labels)))
    for load in dict.fromkeys(list_payloads.get(x, "") for x in lists):
        rows = [i for i, x in enumerate(lists) if list_payloads.get(x, "") == load]
        deviation[rows] = drift_series(t[rows], p[rows]).deviation_mm
    section = DriftSection(
        reference=labels, t_s=(t - t[0]).round(3).tolist(), poses_before=before,
        list_of_check=lists,
        deviation_mm={label: deviation[:, j].round(4).tolist()
                      for j, label in enumerate(labels)},
        quantity="norm of the change of the reference pose's measured position since its "
                 "first measurement under the same payload, mm (Eq. D.1)",
        meaning="ISO 9283 drift of pose characteristics: the reference poses (the test "
                "cube's points, each approached from 1 deg below on every joint) re-measured "
                "during the job; t_s seconds since the first check")
    cal = [i for i, x in enumerate(lists) if x in calibration_phases]
    if promised_sigma is not None and cal:
        section.since_calibration = _since_calibration(
            t, p, lists, list_payloads, labels, cal[-1], promised_sigma)
    return section


def _list_of(others: Sequence[Mapping[str, Any]], ids: Sequence[int], first_id: int) -> str:
    """The list a check was interleaved with: the pose measured just before it (the job's
    first check: the one just after). `others` sorted by id, `ids` theirs."""
    earlier = bisect_left(ids, first_id)
    if earlier:
        return str(others[earlier - 1]["phase"])
    later = bisect_right(ids, first_id)
    return str(others[later]["phase"]) if later < len(others) else ""


def _since_calibration(t: np.ndarray, p: np.ndarray, lists: list[str],
                       list_payloads: Mapping[str, str], labels: list[str], at: int,
                       promised_sigma: float) -> dict[str, Any] | None:
    """Drift from the last check taken with the calibration list (its end) to the job's last
    check under the same payload as the latest check; None when no check follows it."""
    last = len(lists) - 1
    load = list_payloads.get(lists[last], "")
    start = at if list_payloads.get(lists[at], "") == load else next(
        (i for i in range(at + 1, last) if list_payloads.get(lists[i], "") == load), None)
    if start is None or start >= last:
        return None
    series = drift_series(t[start:last + 1], p[start:last + 1])
    mean = float(series.deviation_mm[-1].mean())
    promised = float(np.sqrt(3.0) * promised_sigma)
    same = [i for i in range(len(lists)) if list_payloads.get(lists[i], "") == load]
    # the checks' own noise from second differences (a drift steady over three checks cancels;
    # p_k+1 - 2 p_k + p_k-1 has variance 6 s^2 per coordinate)
    bends = np.diff(p[same], n=2, axis=0)
    sigma = float(np.sqrt(np.mean(bends**2) / 6.0)) if len(bends) else 0.0
    noise = sigma * np.sqrt(2.0) * (_CHI3_MEAN + 3.0 * _CHI3_STD / np.sqrt(len(labels)))
    return {"from_t_s": float(t[start] - t[0]), "to_t_s": float(t[last] - t[0]),
            "drift_mm": round(mean, 4),
            "per_reference_mm": dict(zip(labels, series.deviation_mm[-1].round(4).tolist(),
                                         strict=True)),
            "promised_mm": round(promised, 4), "noise_mm": round(float(noise), 4),
            "exceeded": bool(mean > promised + noise),
            "meaning": "drift: mean over the reference poses of the norm of their position "
                       "change from the check after the calibration list to the job's last "
                       "check; promised: the calibration's residual noise level, its estimated "
                       "position noise per coordinate as a distance (sqrt 3 sigma); noise: "
                       "what that mean reads with no drift (its mean plus 3 standard "
                       "deviations, s from the second differences of the checks)"}


def drift_warnings(result: ResultDocument) -> list[str]:
    """The warning a user must see when the robot drifted more since its calibration than the
    model promised."""
    since = result.drift.since_calibration if result.drift is not None else None
    if not since or not since.get("exceeded"):
        return []
    return [f"drift since the calibration: the reference poses moved {since['drift_mm']:.3f} "
            f"mm (mean over them of the norm of the position change, t = "
            f"{since['from_t_s']:.0f} -> {since['to_t_s']:.0f} s), more than the calibration "
            f"promised: its residual noise level {since['promised_mm']:.3f} mm (the estimated "
            "position noise per coordinate, as a distance), plus the checks' own noise "
            f"{since['noise_mm']:.3f} mm. The robot changed "
            "after it was calibrated (warm-up, temperature): calibrate it warm (warm-up "
            "cycles) or again"]
