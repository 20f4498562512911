"""Drift over the job (ISO 9283 drift of pose characteristics, service/drift.py): each reference
pose's position change against time, the table of the very same numbers beside it, and whether
the drift since the calibration stayed within what the calibration promised."""

from __future__ import annotations

from service.report.charts import line_chart
from service.report.context import ReportContext
from service.report.markup import pair, section, sentence, table

QUANTITY = "norm of the position change since the first check |p(t) - p(0)| [mm]"


def drift_section(ctx: ReportContext) -> str | None:
    """The drift series: table and chart of the norm, then the verdict since the calibration."""
    drift = ctx.result.drift
    if drift is None or not drift.t_s:
        return None
    rows = [[k, t, n, lst, *(drift.deviation_mm[label][k] for label in drift.reference)]
            for k, (t, n, lst) in enumerate(zip(drift.t_s, drift.poses_before,
                                                drift.list_of_check, strict=True))]
    tab = table(["check", "t s", "poses before", "during", *drift.reference], rows, digits=4,
                caption=QUANTITY, text_columns=(3,))
    chart = line_chart("drift of the reference poses",
                       dict.fromkeys(drift.reference, drift.t_s), drift.deviation_mm,
                       y_label=QUANTITY, x_label="time since the first check [s]")
    body = [sentence(f"{drift.meaning}. Each check measures every reference pose once, "
                     "approached from 1 deg below on every joint; a check under another "
                     "payload than the first starts its own series (a payload's deflection is "
                     "no drift)"), pair(tab, chart)]
    since = drift.since_calibration
    if since:
        verdict = "more than" if since.get("exceeded") else "within"
        body.append(sentence(
            f"Since the calibration (t {since['from_t_s']:.0f} -> {since['to_t_s']:.0f} s) "
            f"the reference poses moved {since['drift_mm']:.3f} mm, {verdict} what the "
            f"calibration promised ({since['promised_mm']:.3f} mm) plus the checks' own noise "
            f"({since['noise_mm']:.3f} mm): {since['meaning']}"))
    return section("drift", "Drift over the job (ISO 9283)", "".join(body))
