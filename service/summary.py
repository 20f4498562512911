"""The before/after figures of a job, one computation for the CLI table and the report page."""

from __future__ import annotations

from dataclasses import dataclass

from service.phases import PERF_PHASES

# (label, key in the phase's section, section, unit)
ROWS = (
    ("position accuracy AP, mean", "ap_mm_mean", "overall", "mm"),
    ("position accuracy AP, max", "ap_mm_max", "overall", "mm"),
    ("position repeatability RP, max", "rp_mm_max", "overall", "mm"),
    ("orientation accuracy, max |APa,b,c|", "ap_abc_deg_max", "overall", "°"),
    ("straightness, peak + valley", "peak_to_valley_mm", "straightness", "mm"),
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


def performance_phases(perf: dict) -> tuple[str, ...]:
    return tuple(p for p in PERF_PHASES if p in perf)


def before_after(perf: dict) -> tuple[tuple[str, ...], list[SummaryRow]]:
    """The phases measured and a row per figure (mean and max AP, RP, orientation,
    straightness)."""
    phases = performance_phases(perf)
    rows = [SummaryRow(label, unit, tuple(perf[p].get(section, {}).get(key) for p in phases))
            for label, key, section, unit in ROWS]
    return phases, [r for r in rows if any(v is not None for v in r.values)]
