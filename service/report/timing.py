"""How long each phase of the job took, beside the thesis's Table 13."""

from __future__ import annotations

from service.report.context import ReportContext
from service.report.markup import section, sentence, table


def timing_section(ctx: ReportContext) -> str | None:
    """Seconds per phase."""
    phases = ctx.job.phases
    if not phases:
        return None
    return section("time", "Time per phase", table(
        ["phase", "seconds"], [[k, float(v.seconds)] for k, v in phases.items()], digits=2)
        + sentence("The thesis's Table 13, for comparison: set-up 60 min, measurements 90 min "
                   "(4 performance rounds and 2 calibration rounds), estimation under 1 min"))
