"""The report page of a job: an HTML document with its figures embedded (PNG, base64), readable
in any browser without the service."""

from __future__ import annotations

import base64
import html
import io
import tempfile
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from screwcal.performance import plots
from screwcal.performance.iso9283 import PoseMetrics

# Thesis Table 13: minutes per activity of a whole calibration.
THESIS_TABLE13_MIN = {"setup": 60, "measuring": 90, "estimation": 1}
CSS = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:4px 8px;
text-align:right}th{background:#eee}td:first-child{text-align:left}img{max-width:100%}"""


def _png_bytes(draw: Any, *args: Any) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "figure.png"
        draw(*args, path)
        return path.read_bytes()


def report_figures(job: dict) -> dict[str, bytes]:
    """The report's figures as PNG files: accuracy per point and straightness, before/after."""
    perf = (job.get("result") or {}).get("performance") or {}
    out: dict[str, bytes] = {}
    results = {name.replace("perf_", ""): {k: PoseMetrics(**v) for k, v in s["points"].items()}
               for name, s in perf.items() if s.get("points")}
    if results:
        out["accuracy_per_point.png"] = _png_bytes(plots.accuracy_per_point, results)
    lines = {name.replace("perf_", ""): SimpleNamespace(
        along_mm=np.array(s["straightness"]["along_mm"]),
        deviation_u_mm=np.array(s["straightness"]["deviation_mm"]),
        peak_to_valley_mm=s["straightness"]["peak_to_valley_mm"])
        for name, s in perf.items() if "straightness" in s}
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


def report_html(job: dict, robot: dict) -> str:
    result = job.get("result") or {}
    out = io.StringIO()
    title = f"screwcal job {job['id']}: {job['kind']} of {robot['name']}"
    out.write(f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
              f"</title><style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>")
    out.write(f"<p>State: <b id='state'>{html.escape(job['state'])}</b> "
              f"{html.escape(job['reason'])} &middot; mode {job['mode']} &middot; "
              "units mm and degrees</p>")
    phases = job.get("phases") or {}
    out.write("<h2>Time per phase</h2>" + _table(
        ["phase", "seconds"], [[k, float(v.get("seconds", 0.0))] for k, v in phases.items()]))
    out.write("<p>The thesis's Table 13, for comparison: set-up 60 min, measurements 90 min "
              "(4 performance rounds and 2 calibration rounds), estimation under 1 min.</p>")
    est = result.get("estimation")
    if est:
        out.write("<h2>Identified parameters</h2>" + _table(
            ["parameter", "unit", "value", "std error"],
            [[p["name"], p["unit"], p["value"], p["std_error"]] for p in est["parameters"]]))
        f = est.get("measuring_frame")
        if f:
            out.write("<p>Robot base in the measuring system's frame: "
                      f"x {f['x']:.3f}, y {f['y']:.3f}, z {f['z']:.3f} mm; rx {f['rx']:.4f}, "
                      f"ry {f['ry']:.4f}, rz {f['rz']:.4f} deg.</p>")
        if est["removed"]:
            out.write("<p>Not separable from these data (held at nominal): " + ", ".join(
                html.escape(f"{r['name']} ({r['reason']})") for r in est["removed"]) + "</p>")
        out.write(f"<p>Rank {est['rank']}, condition number {est['condition_number']:.3g}, "
                  f"chi2/dof {est['chi2_reduced']:.2f}; calibration residual "
                  f"{est['residual_before_mm']:.3f} mm before, "
                  f"{est['residual_after_mm']:.3f} mm after.</p>")
    corr = result.get("correction")
    if corr:
        out.write("<h2>Correction</h2>")
        if "refused" in corr:
            out.write(f"<p>Refused: {html.escape(str(corr['refused']))}</p>")
        else:
            out.write(_table(["joint", "offset deg", "ZERO target deg", "identified"],
                             [[f"J{i + 1}", float(o), float(z), str(ok)] for i, (o, z, ok) in
                              enumerate(zip(corr["offsets_deg"], corr["zero_command_deg"],
                                            corr["identified"], strict=True))]))
    perf = result.get("performance") or {}
    if perf:
        out.write(performance_section(perf, report_figures(job)))
    out.write("</body></html>")
    return out.getvalue()


def performance_section(perf: dict, figures: dict[str, bytes]) -> str:
    out = io.StringIO()
    out.write("<h2>ISO 9283 pose accuracy and repeatability</h2>")
    rows = []
    for phase, section in perf.items():
        for label, m in section.get("points", {}).items():
            rows.append([phase, label, m["ap_mm"], m["rp_mm"], *np.round(m["ap_abc_deg"], 4)])
    out.write(_table(["phase", "point", "AP mm", "RP mm", "APa deg", "APb deg", "APc deg"],
                     rows))
    if "accuracy_per_point.png" in figures:
        out.write(_img("accuracy per point", figures["accuracy_per_point.png"]))
    if "straightness.png" in figures:
        out.write("<h2>Straightness (ISO 12780-1)</h2>")
        out.write(_img("straightness", figures["straightness.png"]))
    return out.getvalue()
