"""What the calibration identified, in plain words first: what the data could not separate and
what that means for the robot, how well the model fits (the residual table and chart), what
the symbols mean, then the parameter table."""

from __future__ import annotations

import io
from typing import Any

from service.document import EstimationSummary
from service.phases import ROUND_SUFFIXES
from service.report.charts import line_chart
from service.report.context import ReportContext
from service.report.markup import esc, number, pair, section, sentence, table
from service.report.symbols import CONSEQUENCES, in_words, legend, partners, taken_up_by
from service.result_text import beyond_geometry

RESIDUAL = "residual |measured - model position| per pose [mm]"


def separability(est: EstimationSummary) -> str:
    """The parameters held at nominal, grouped by what took up their effect, with what that
    means for the robot."""
    if not est.removed:
        return sentence(f"Every candidate parameter could be told apart from the others in "
                        f"these data ({est.rank} identified)")
    groups: dict[str, list[str]] = {}
    for r in est.removed:
        others = partners(r)
        moves = f" moves as {', '.join(others)} together" if others else ""
        groups.setdefault(taken_up_by(r), []).append(
            f"<li><b>{esc(r.name)}</b> ({esc(in_words(r.name))}){esc(moves)}</li>")
    out = [sentence(f"The data could not tell {len(est.removed)} of the candidate parameters "
                    f"apart from others: each is held at its nominal value, {est.rank} are "
                    "identified. Each line names one and what it moves with")]
    for key, items in groups.items():
        out.append(f"<ul class='separability'>{''.join(items)}</ul>"
                   + sentence(f"For these, {CONSEQUENCES[key]}"))
    return "".join(out)


def fit_words(est: EstimationSummary) -> str:
    """The fit's quality in words."""
    well = "well conditioned" if est.condition_number < 1e3 else "poorly conditioned"
    position = (est.noise or {}).get("position") or {}
    if position.get("estimated"):
        chi2 = (f", near 1 by construction: the noise levels were estimated from these data, "
                f"and the position noise they needed, {number(position['value'])} mm, is what "
                "the model leaves unexplained, instrument included")
    elif est.chi2_reduced < 2.0:
        chi2 = ": the residuals are as large as the stated measuring noise explains"
    else:
        chi2 = ": the residuals are larger than the stated measuring noise explains"
    return sentence(
        f"The fit is {well} (condition number {est.condition_number:.3g}: how much a "
        f"measuring error is magnified in the parameters); chi2/dof (1 when the residuals "
        f"match the noise levels) is {est.chi2_reduced:.2f}{chi2}")


REJECTED = "rejected (outlier)"


def pose_numbers(fitted: list[str], rejected: list[str]) -> tuple[list[float], list[float]]:
    """Where each fitted and each rejected pose sits on the chart's x axis: its id when every
    id is a number (the job's pose numbers: a rejected pose in its place among the others),
    else its place in the fitted order, the rejected after the last."""
    try:
        return [float(i) for i in fitted], [float(i) for i in rejected]
    except ValueError:
        n = len(fitted)
        return [float(k) for k in range(1, n + 1)], [float(n + k) for k in
                                                       range(1, len(rejected) + 1)]


def residual_pair(calibration: dict[str, Any], est: EstimationSummary) -> str:
    """The residual per pose, before (nominal model) and after (calibrated model): a table of
    mean, RMS and max beside the chart of the per-pose values; the poses rejected as outliers
    (left out of the fit) are a row of the table and ringed points of the chart, each at its
    residual in the fit that flagged it."""
    residuals = calibration.get("residuals") or {}
    before, after = residuals.get("before"), residuals.get("after")
    if not before or not after:
        return ""
    names = {"before": "before (nominal model)", "after": "after (calibrated model)"}
    summary = {names["before"]: residuals.get("summary_before") or {},
               names["after"]: residuals.get("summary_after") or {}}
    summary[names["before"]].setdefault("mean", est.residual_before_mm)
    summary[names["after"]].setdefault("mean", est.residual_after_mm)
    rows = [[name, s.get("mean"), s.get("rms"), s.get("max")] for name, s in summary.items()]
    rejected = [o for o in calibration.get("outliers") or [] if o.get("rejected")]
    fitted_ids = residuals.get("poses") or [str(k) for k in range(1, len(after) + 1)]
    x_fitted, x_rejected = pose_numbers([str(i) for i in fitted_ids],
                                        [str(o["id"]) for o in rejected])
    poses = {names["before"]: x_fitted, names["after"]: x_fitted}
    series = {names["before"]: before, names["after"]: after}
    words = ""
    if rejected:
        r = [float(o["residual_mm"]) for o in rejected]
        rows.append([REJECTED, sum(r) / len(r), (sum(v * v for v in r) / len(r)) ** 0.5,
                     max(r)])
        poses[REJECTED], series[REJECTED] = x_rejected, r
        which = ", ".join(f"pose {o['id']} ({float(o['residual_mm']):.3f} mm)"
                          for o in rejected)
        words = sentence(
            f"Rejected as {'an outlier' if len(rejected) == 1 else 'outliers'} and left out of "
            f"the fit: {which}, {'each ' if len(rejected) > 1 else ''}ringed on the chart at "
            "its residual in the fit that flagged it")
    tab = table(["model", "mean", "rms", "max"], rows, caption=RESIDUAL, digits=4)
    chart = line_chart("calibration residual per pose", poses, series, y_label=RESIDUAL,
                       x_label="calibration pose", marked=(REJECTED,))
    return pair(tab, chart) + words


def symbols_list(est: EstimationSummary) -> str:
    names = [p.name for p in est.parameters] + [
        n for r in est.removed for n in (r.name, *partners(r))]
    entries = legend(names)
    if not entries:
        return ""
    return ("<p>The parameters' symbols:</p><dl class='symbols'>" + "".join(
        f"<dt>{esc(s)}</dt><dd>{esc(m)}</dd>" for s, m in entries) + "</dl>")


def estimation_body(est: EstimationSummary, calibration: dict[str, Any] | None) -> str:
    out = io.StringIO()
    out.write(symbols_list(est))
    out.write(separability(est))
    out.write("".join(sentence(line) for line in beyond_geometry(est)))
    out.write(fit_words(est))
    if calibration:
        out.write(residual_pair(calibration, est))
    out.write(table(["parameter", "unit", "value", "std error"],
                    [[p.name, p.unit, p.value, p.std_error] for p in est.parameters],
                    caption="identified parameters (value: the error identified, relative to "
                            "the nominal model; std error: its 1-sigma uncertainty)",
                    digits=4))
    f = est.measuring_frame
    if f is not None:
        out.write(sentence(
            f"Robot base in the measuring system's frame: x {f.x:.3f}, y {f.y:.3f}, "
            f"z {f.z:.3f} mm; rx {f.rx:.4f}, ry {f.ry:.4f}, rz {f.rz:.4f} deg"))
    return out.getvalue()


def calibration_section(ctx: ReportContext) -> str | None:
    """Each calibration round's identification."""
    parts = []
    for suffix in ROUND_SUFFIXES:
        est = ctx.result.estimation_of(suffix)
        if est is not None:
            head = "<h3>Round 2</h3>" if suffix else ""
            parts.append(head + estimation_body(est, ctx.result.calibration_of(suffix)))
    if not parts:
        return None
    return section("calibration", "What the calibration identified", "".join(parts))



