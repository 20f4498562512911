"""The report page of a job: an HTML document with its figures embedded (PNG, base64), readable
in any browser without the service."""

from __future__ import annotations

import base64
import html
import io
import tempfile
from collections.abc import Mapping
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from screwcal.performance import plots
from service.document import (
    CorrectionPlan,
    EstimationSummary,
    HomeCheck,
    JobRecord,
    PerformanceSection,
    ResultDocument,
)
from service.phases import PERF_PHASE_NAMES, ROUND_SUFFIXES
from service.result_text import beyond_geometry, home_moved
from service.summary import before_after

# Thesis Table 13: minutes per activity of a whole calibration.
CSS = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:4px 8px;
text-align:right}th{background:#eee}td:first-child{text-align:left}img{max-width:100%}
.warning{background:#fff3cd;border:1px solid #e0b000;padding:6px}"""


def _png_bytes(draw: Any, *args: Any) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "figure.png"
        draw(*args, path)
        return path.read_bytes()


def report_figures(result: ResultDocument) -> dict[str, bytes]:
    """The report's figures as PNG files: accuracy per point and straightness, before/after,
    and the calibration residual per pose."""
    perf = result.performance or {}
    out: dict[str, bytes] = {}
    residuals = (result.calibration or {}).get("residuals")
    if residuals:
        out["calibration_residuals.png"] = _png_bytes(
            plots.calibration_residuals, residuals["before"], residuals["after"])
    results = {PERF_PHASE_NAMES[name]: s.points for name, s in perf.items() if s.points}
    if results:
        out["accuracy_per_point.png"] = _png_bytes(plots.accuracy_per_point, results)
    lines = {PERF_PHASE_NAMES[name]: SimpleNamespace(
        along_mm=np.array(s.straightness["along_mm"]),
        deviation_u_mm=np.array(s.straightness["deviation_u_mm"]),
        peak_to_valley_mm=s.straightness["peak_to_valley_mm"])
        for name, s in perf.items() if s.straightness is not None}
    if lines:
        out["straightness.png"] = _png_bytes(plots.straightness_along_path, lines)
    return out


def _img(name: str, png: bytes) -> str:
    return (f"<img alt='{html.escape(name)}' src='data:image/png;base64,"
            f"{base64.b64encode(png).decode('ascii')}'>")


def _table(header: list[str], rows: list[list[Any]]) -> str:
    def cell(v: Any) -> str:
        return f"{v:.4f}" if isinstance(v, float) else html.escape(str(v))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{cell(v)}</td>" for v in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def report_html(job: JobRecord, robot: dict[str, Any]) -> str:
    result = job.result
    figures = report_figures(result)
    out = io.StringIO()
    title = f"screwcal job {job.id}: {job.kind} of {robot['name']}"
    out.write(f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
              f"</title><style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>")
    out.write(f"<p>State: <b id='state'>{html.escape(job.state)}</b> "
              f"{html.escape(job.reason)} &middot; mode {job.mode} &middot; "
              "units mm and degrees</p>")
    for warning in result.warnings or []:
        out.write(f"<p class='warning'><b>Warning:</b> {html.escape(warning)}</p>")
    phases, rows = before_after(result.performance or {})
    if rows:
        out.write("<h2>Summary: ISO 9283 before and after</h2>" + _table(
            ["", "unit", *(PERF_PHASE_NAMES[p] for p in phases), "factor"],
            [[r.label, r.unit, *("-" if v is None else float(v) for v in r.values),
              "-" if r.factor is None else f"{r.factor:.1f}x"] for r in rows]))
        if result.frame_note:
            out.write(f"<p>{html.escape(result.frame_note)}</p>")
    if result.home_check is not None:
        out.write(home_section(result.home_check))
        moved = home_moved(result)
        if moved:
            out.write(f"<p>{html.escape(moved[0].upper() + moved[1:])}.</p>")
    if result.test_conditions:
        out.write("<h2>Test conditions</h2>" + _table(
            ["condition", "value"],
            [[k.replace("_", " "), v] for k, v in result.test_conditions.items()]))
    for suffix in ROUND_SUFFIXES:
        corr = result.correction_of(suffix)
        if corr is not None:
            out.write(correction_section(corr, suffix))
    if result.estimation is not None:
        out.write(estimation_section(result.estimation, figures))
    if result.performance:
        out.write(performance_section(result.performance, figures))
    out.write("<h2>Time per phase</h2>" + _table(
        ["phase", "seconds"], [[k, float(v.seconds)] for k, v in job.phases.items()]))
    out.write("<p>The thesis's Table 13, for comparison: set-up 60 min, measurements 90 min "
              "(4 performance rounds and 2 calibration rounds), estimation under 1 min.</p>")
    out.write("</body></html>")
    return out.getvalue()


def estimation_section(est: EstimationSummary, figures: dict[str, bytes]) -> str:
    """The identified parameters, the measuring frame, what was not separable, the fit."""
    out = io.StringIO()
    out.write("<h2>Identified parameters</h2>" + _table(
        ["parameter", "unit", "value", "std error"],
        [[p.name, p.unit, p.value, p.std_error] for p in est.parameters]))
    f = est.measuring_frame
    if f is not None:
        out.write("<p>Robot base in the measuring system's frame: "
                  f"x {f.x:.3f}, y {f.y:.3f}, z {f.z:.3f} mm; rx {f.rx:.4f}, "
                  f"ry {f.ry:.4f}, rz {f.rz:.4f} deg.</p>")
    if est.removed:
        out.write("<p>Not separable from these data (held at nominal): " + ", ".join(
            html.escape(f"{r.name} ({r.reason})") for r in est.removed) + "</p>")
    out.write(f"<p>Rank {est.rank}, condition number {est.condition_number:.3g}, "
              f"chi2/dof {est.chi2_reduced:.2f}; calibration residual "
              f"{est.residual_before_mm:.3f} mm before, "
              f"{est.residual_after_mm:.3f} mm after.</p>")
    out.write("".join(f"<p>{html.escape(line[0].upper() + line[1:])}.</p>"
                      for line in beyond_geometry(est)))
    if "calibration_residuals.png" in figures:
        out.write(_img("calibration residual per pose", figures["calibration_residuals.png"]))
    return out.getvalue()


def home_section(home: HomeCheck) -> str:
    """Table 14: the flange at home, nominal, measured before and after, and the errors."""
    rows: list[list[Any]] = [["nominal", *home.nominal_mm, "-"]]
    for when, measured in (("before", home.before), ("after", home.after)):
        if measured is not None:
            rows.append([f"measured {when}", *measured.measured_mm, "-"])
            rows.append([f"error {when}", *measured.error_mm, measured.distance_mm])
    return ("<h2>Home position check (thesis Table 14)</h2>"
            + _table(["", "x mm", "y mm", "z mm", "|error| mm"], rows)
            + f"<p>{html.escape(home.note)}</p>")


def correction_section(corr: CorrectionPlan, suffix: str) -> str:
    """Which route ran, and what it corrected, compensated, or left in the robot."""
    out = io.StringIO()
    out.write(f"<h2>Correction{' (round 2)' if suffix else ''}: "
              f"{html.escape(corr.route)}</h2>")
    if corr.note:
        out.write(f"<p>{html.escape(corr.note)}</p>")
    if corr.zero_command_deg is not None:
        sent = "sent to the controller" if corr.sent else "planned, not sent"
        out.write(f"<p>ZERO ({sent}; on a real IRC5 the operator enters the offsets on the "
                  "FlexPendant and gives the go-ahead):</p>")
        out.write(_table(["joint", "offset deg", "ZERO target deg", "identified"],
                         [[f"J{i + 1}", float(o), float(z), str(ok)] for i, (o, z, ok) in
                          enumerate(zip(corr.offsets_deg or [], corr.zero_command_deg,
                                        corr.identified or [], strict=True))]))
    if corr.compensated_lists:
        out.write(f"<p>Compensated joint targets sent for {', '.join(corr.compensated_lists)}"
                  f" (largest joint change {corr.max_joint_change_deg or 0.0:.4f} deg): "
                  "the calibrated robot reaches the nominal targets; nothing changed in the "
                  "controller.</p>")
    predicted = corr.predicted_position_error_mm
    if predicted is not None:
        out.write(f"<p>Model-predicted flange position error on the ISO targets: "
                  f"{predicted.before:.3f} mm before, {predicted.after:.4f} mm after.</p>")
    if corr.left_in_robot:
        out.write("<p>Left in the robot by this route (identified, not corrected):</p>" + _table(
            ["parameter", "value", "unit"],
            [[p.name, float(p.value), p.unit] for p in corr.left_in_robot]))
    elif corr.left_in_robot is not None:
        out.write("<p>Left in the robot: nothing the model identified.</p>")
    if corr.not_identified:
        out.write("<p>Not identified from these data (nothing corrects them): "
                  + html.escape(", ".join(corr.not_identified)) + "</p>")
    return out.getvalue()


def performance_section(perf: Mapping[str, PerformanceSection], figures: dict[str, bytes]
                        ) -> str:
    out = io.StringIO()
    out.write("<h2>ISO 9283 pose accuracy and repeatability</h2>")
    rows = []
    for phase, section in perf.items():
        for label, m in section.points.items():
            rows.append([phase, label, m.ap_mm, m.rp_mm, *np.round(m.ap_abc_deg or (), 4)])
    out.write(_table(["phase", "point", "AP mm", "RP mm", "APa deg", "APb deg", "APc deg"],
                     rows))
    if "accuracy_per_point.png" in figures:
        out.write(_img("accuracy per point", figures["accuracy_per_point.png"]))
    if "straightness.png" in figures:
        out.write("<h2>Straightness (ISO 12780-1)</h2>")
        out.write(_img("straightness", figures["straightness.png"]))
    return out.getvalue()
