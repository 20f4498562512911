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


# (label, unit, the figure in a phase's section: the performance package's keys)
ROWS = (
    ("position accuracy AP, mean", "mm", _overall("ap_mm_mean")),
    ("position accuracy AP, max", "mm", _overall("ap_mm_max")),
    ("position repeatability RP, max", "mm", _overall("rp_mm_max")),
    ("orientation accuracy, max |APa,b,c|", "°", _overall("ap_abc_deg_max")),
    ("straightness, peak + valley", "mm", _straightness("peak_to_valley_mm")),
)


@dataclass(frozen=True)
class SummaryRow:
    label: str
    unit: str
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
    rows = [SummaryRow(label, unit, tuple(figure(perf[p]) for p in phases))
            for label, unit, figure in ROWS]
    return phases, [r for r in rows if any(v is not None for v in r.values)]
