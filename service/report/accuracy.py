"""ISO 9283 per point: position accuracy AP, repeatability RP and orientation accuracy, each a
table of the phases' figures per point with the chart of the same figures beside it."""

from __future__ import annotations

from collections.abc import Callable, Mapping

from screwcal.performance.iso9283 import PoseMetrics
from service.document import PerformanceSection
from service.phases import PERF_PHASE_NAMES
from service.report.charts import bar_chart
from service.report.context import ReportContext
from service.report.markup import pair, section, sentence, table
from service.summary import performance_phases

# (quantity as the table's header and the chart's axis say it, unit, the figure of a point)
QUANTITIES: tuple[tuple[str, str, Callable[[PoseMetrics], float | None]], ...] = (
    ("AP = |mean reached - commanded| (norm)", "mm", lambda m: m.ap_mm),
    ("RP = mean + 3 std of |reached - mean|", "mm", lambda m: m.rp_mm),
    ("max(|APa|, |APb|, |APc|) (largest component)", "deg", lambda m: m.ap_abc_max_abs_deg),
)


def quantity_pair(title: str, quantity: str, unit: str,
                  figure: Callable[[PoseMetrics], float | None],
                  perf: Mapping[str, PerformanceSection], phases: tuple[str, ...]) -> str:
    """The table of one figure per point and phase, and its bar chart: the same numbers."""
    labels = list(perf[phases[0]].points)
    series = {PERF_PHASE_NAMES[p]: [figure(perf[p].points[lbl]) if lbl in perf[p].points
                                    else None for lbl in labels] for p in phases}
    head = f"{quantity} [{unit}]"
    rows = [[lbl, *(series[name][k] for name in series)] for k, lbl in enumerate(labels)]
    tab = table(["point", *series], rows, caption=head, digits=4)
    chart = bar_chart(title, labels, series, y_label=head, x_label="ISO 9283 point")
    return pair(tab, chart)


def components_table(perf: Mapping[str, PerformanceSection], phases: tuple[str, ...]) -> str:
    """APa, APb, APc per point and phase: the components the orientation chart's maximum is
    taken of."""
    rows = [[PERF_PHASE_NAMES[p], label, *(m.ap_abc_deg or ())]
            for p in phases for label, m in perf[p].points.items()]
    return table(["phase", "point", "APa deg", "APb deg", "APc deg"], rows, digits=4,
                 caption="APa, APb, APc (Eq. 2.9): mean reached - commanded angle about x, y, "
                         "z")


def accuracy_section(ctx: ReportContext) -> str | None:
    """Per point AP, RP and (full-pose data) orientation accuracy, before and after."""
    perf = ctx.result.performance or {}
    phases = tuple(p for p in performance_phases(perf) if perf[p].points)
    if not phases:
        return None
    body = [sentence(
        "Each ISO 9283 point P1-P5 of the test cube is reached n times (the cycles); AP is the "
        "distance from the commanded position to the mean of the positions reached, RP how "
        "far those positions scatter around their mean. The charts show the very numbers of "
        "the table beside them")]
    titles = ("position accuracy AP per point", "position repeatability RP per point",
              "orientation accuracy per point")
    full_pose = all(m.ap_abc_deg is not None for p in phases for m in perf[p].points.values())
    for title, (quantity, unit, figure) in zip(titles, QUANTITIES, strict=True):
        if unit == "deg" and not full_pose:
            continue
        body.append(f"<h3>{title[0].upper() + title[1:]}</h3>")
        body.append(quantity_pair(title, quantity, unit, figure, perf, phases))
    if full_pose:
        body.append(components_table(perf, phases))
    return section("accuracy", "ISO 9283 pose accuracy and repeatability per point",
                   "".join(body))
