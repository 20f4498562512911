"""The before/after figures of a job, one computation for the CLI table and the report page."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from service.document import PerformanceSection
from service.phases import PERF_PHASES


def _overall(key: str) -> Callable[[PerformanceSection], Any]:
    return lambda s: (s.overall or {}).get(key)


def _straightness(key: str) -> Callable[[PerformanceSection], Any]:
    return lambda s: (s.straightness or {}).get(key)


# (label, unit, the figure in a phase's section: the performance package's keys, what it
# measures in one sentence: the report's summary says it beside the figure)
ROWS = (
    ("position accuracy AP, mean", "mm", _overall("ap_mm_mean"),
     "ISO 9283 (Eq. 2.5): the distance from each commanded point of the test cube to the mean "
     "of the positions reached over the cycles, averaged over the points; poses the "
     "calibration never saw"),
    ("position accuracy AP, max", "mm", _overall("ap_mm_max"),
     "the same distance at the worst point of the cube"),
    ("position repeatability RP, max", "mm", _overall("rp_mm_max"),
     "ISO 9283 (7.2.2): how far the robot scatters around its own mean position at a point "
     "(mean + 3 standard deviations), worst point; the robot's own, a calibration leaves it"),
    ("orientation accuracy, max |APa,b,c|", "°", _overall("ap_abc_deg_max"),
     "ISO 9283 (Eq. 2.9): the largest of the three angle errors |APa|, |APb|, |APc| of the "
     "mean reached orientation, over the points"),
    ("straightness, peak + valley", "mm", _straightness("peak_to_valley_mm"),
     "ISO 12780-1: the width of the band around the least-squares line that holds every "
     "measured point of the straight-line path"),
)
@dataclass(frozen=True)
class SummaryRow:
    label: str
    unit: str
    meaning: str
    values: tuple[float | None, ...]  # one per performance phase, in `phases` order

    @property
    def factor(self) -> float | None:
        """before / last after: how many times better (None when either is missing or 0)."""
        first, last = self.values[0], self.values[-1]
        if first is None or last is None or last <= 0 or len(self.values) < 2:
            return None
        return first / last


def performance_phases(perf: Mapping[str, PerformanceSection]) -> tuple[str, ...]:
    return tuple(p for p in PERF_PHASES if p in perf)


def before_after(perf: Mapping[str, PerformanceSection]
                 ) -> tuple[tuple[str, ...], list[SummaryRow]]:
    """The phases measured and a row per figure (mean and max AP, RP, orientation,
    straightness)."""
    phases = performance_phases(perf)
    rows = [SummaryRow(label, unit, meaning, tuple(figure(perf[p]) for p in phases))
            for label, unit, figure, meaning in ROWS]
    return phases, [r for r in rows if any(v is not None for v in r.values)]
