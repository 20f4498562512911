"""Straightness of the straight-line path (ISO 12780-1): peak + valley per phase, and the
signed deviations along the line."""

from __future__ import annotations

from service.phases import PERF_PHASE_NAMES
from service.report.charts import line_chart
from service.report.context import ReportContext
from service.report.markup import pair, section, sentence, table
from service.summary import performance_phases

QUANTITY = "deviation u from the least-squares line [mm]"


def straightness_section(ctx: ReportContext) -> str | None:
    """The table of peak, valley and peak + valley per phase, the deviations along the
    line beside it."""
    perf = ctx.result.performance or {}
    lines = {PERF_PHASE_NAMES[p]: line for p in performance_phases(perf)
             if (line := perf[p].straightness) is not None}
    if not lines:
        return None
    rows = [[name, s["peak_mm"], s["valley_mm"], s["peak_to_valley_mm"]]
            for name, s in lines.items()]
    tab = table(["phase", "peak = max u", "valley = -min u", "peak + valley"], rows, digits=4,
                caption=QUANTITY)
    chart = line_chart("straightness along the line",
                       {name: s["along_mm"] for name, s in lines.items()},
                       {name: s["deviation_u_mm"] for name, s in lines.items()},
                       y_label=QUANTITY, x_label="position along the line [mm]", zero_line=True)
    return section("straightness", "Straightness (ISO 12780-1)", sentence(
        "The robot moves along a straight line; each point's signed deviation u is its "
        "distance from the least-squares line fitted to the measured points, in the plane of "
        "largest spread (the second principal direction); the band peak + valley holds every "
        "point") + pair(tab, chart))
