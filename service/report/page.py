"""The report page: a title, then each section in `SECTIONS` order (the summary first)."""

from __future__ import annotations

import io
import time
from typing import Any

from service.document import JobRecord
from service.report import (
    accuracy,
    backlash,
    calibration,
    conditions,
    correction,
    drift,
    home,
    residual,
    straightness,
    summary,
    timing,
)
from service.report.context import ReportContext, Section
from service.report.markup import CSS, esc

# The report's sections in page order: the summary first. To add a section, write a function
# `(ctx: ReportContext) -> str | None` in a module of its own (markup.section for its heading,
# markup.pair for a table with its chart) and put it here.
SECTIONS: tuple[Section, ...] = (
    summary.summary_section, conditions.robot_section, accuracy.accuracy_section,
    home.home_section, calibration.calibration_section, residual.residual_section,
    backlash.backlash_section,
    correction.correction_section, straightness.straightness_section, drift.drift_section,
    timing.timing_section)


def report_html(job: JobRecord, robot: dict[str, Any]) -> str:
    """The job's report: a self-contained HTML page (inline SVG charts, no external file)."""
    ctx = ReportContext(job, robot)
    out = io.StringIO()
    title = f"screwcal job {job.id}: {job.kind} of {robot['name']}"
    out.write(f"<!doctype html><html lang='en'><head><meta charset='utf-8'>"
              "<meta name='viewport' content='width=device-width, initial-scale=1'>"
              f"<title>{esc(title)}</title><style>{CSS}</style></head><body>"
              f"<header><h1>{esc(title)}</h1><p>State: <b id='state'>{esc(job.state)}</b> "
              f"{esc(job.reason)} &middot; mode {esc(job.mode)} &middot; created "
              f"{time.strftime('%Y-%m-%d %H:%M', time.gmtime(job.created))} UTC, last updated "
              f"{time.strftime('%Y-%m-%d %H:%M', time.gmtime(job.updated))} UTC &middot; "
              "units mm and degrees</p></header>")
    for section in SECTIONS:
        html = section(ctx)
        if html:
            out.write(html)
    out.write("</body></html>")
    return out.getvalue()
