"""How long each phase of the job took, beside the thesis's Table 13."""

from __future__ import annotations

from service.phases import PHASE_WORDS
from service.report.context import ReportContext
from service.report.markup import section, sentence, table


def timing_section(ctx: ReportContext) -> str | None:
    """Seconds per phase; an emulated robot's are scaled, and the page says so."""
    phases = ctx.job.phases
    if not phases:
        return None
    rows = [[PHASE_WORDS.get(k, k), float(v.seconds)] for k, v in phases.items()]
    scaled = sentence("These are the emulated robot's seconds: its motions run faster than "
                      "real time (the emulator's --time-scale), so the measured phases are far "
                      "shorter than a real robot's; the estimation's seconds are real") \
        if ctx.robot.get("emulation") else ""
    return section("time", "Time per phase", table(["phase", "seconds"], rows, digits=2)
                   + scaled
                   + sentence("The thesis's Table 13, for comparison, on the real robot: set-up "
                              "60 min, measurements 90 min (4 performance rounds and 2 "
                              "calibration rounds), estimation under 1 min"))
