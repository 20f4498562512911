"""The report's first section: the figures that belong together in one table (ISO 9283 AP and
RP before and after, the home error, the calibration residual, the model's prediction), each
with what it measures, then how to read them together, then the warnings."""

from __future__ import annotations

from typing import Any

from service.document import ResultDocument
from service.phases import PERF_PHASE_NAMES
from service.report.context import ReportContext
from service.report.markup import esc, number, section, sentence, table
from service.summary import SummaryRow, before_after

HOME_MEANING = ("thesis Table 14: how far the flange is from the nominal home with every joint "
                "at 0, measured before and after the correction")
RESIDUAL_MEANING = ("how far the calibration poses are from the model, mean over the poses: "
                    "before, the nominal model (measuring frame fitted); after, the calibrated "
                    "model, on the very poses it was fitted to (spread over the workspace, "
                    "where AP is measured on the cube only)")
PREDICTED_MEANING = ("the calibrated model's own forecast of the flange error on the ISO "
                     "targets: before, the targets as programmed; after, as corrected")


def _figure_rows(result: ResultDocument, phases: tuple[str, ...], rows: list[SummaryRow]
                 ) -> list[list[Any]]:
    """Rows of (figure, unit, value per column, factor, meaning); the columns are the
    performance phases (before, after, round 2), or before/after when there are none. A
    figure of the first round's correction goes under "after", of the second under
    "round 2"."""
    columns = len(phases) if phases else 2
    out: list[list[Any]] = [[r.label, r.unit, *r.values,
                             "-" if r.factor is None else f"{r.factor:.1f}x", r.meaning]
                            for r in rows]

    def row(label: str, unit: str, meaning: str, *cells: float | None) -> list[Any]:
        return [label, unit, *cells[:columns], *([None] * (columns - len(cells))), "",
                meaning]

    home = result.home_check
    if home is not None and (home.before or home.after):
        out.append(row("home position error |e|", "mm", HOME_MEANING,
                       home.before.distance_mm if home.before else None,
                       home.after.distance_mm if home.after else None))
    estimations = [e for e in (result.estimation, result.estimation_2) if e is not None]
    if estimations:
        out.append(row("calibration residual, mean", "mm", RESIDUAL_MEANING,
                       estimations[0].residual_before_mm,
                       *(e.residual_after_mm for e in estimations)))
    predicted = [c.predicted_position_error_mm for c in (result.correction,
                                                         result.correction_2)
                 if c is not None and c.predicted_position_error_mm is not None]
    if predicted:
        out.append(row("model-predicted error on the ISO targets", "mm", PREDICTED_MEANING,
                       predicted[0].before, *(p.after for p in predicted)))
    return out


def reading(result: ResultDocument, phases: tuple[str, ...]) -> list[str]:
    """How the figures read together, one sentence each (figures of the document only)."""
    out = []
    first, last = (phases[0], phases[-1]) if phases else (None, None)
    ap_after = result.overall(last, "ap_mm_mean") if last and last != first else None
    rp = result.overall(last, "rp_mm_max") if last else None
    est = result.estimation
    if ap_after is not None and est is not None:
        held_out = ("the model carries over to poses it was not fitted to"
                    if ap_after <= 2 * est.residual_after_mm + (rp or 0.0) else
                    "AP after is well above the residual: the test poses differ from the "
                    "calibration's in something the model does not hold (payload, warm-up, the "
                    "region of the workspace), or the model was fitted to noise")
        out.append(f"AP mean after ({number(ap_after)} mm) is measured on the ISO cube, "
                   f"poses the calibration never saw; the calibration residual after "
                   f"({number(est.residual_after_mm)} mm) on the calibration poses themselves: "
                   f"{held_out}")
    if rp is not None and ap_after is not None:
        out.append(f"RP max ({number(rp)} mm) is the robot's own scatter: no calibration "
                   "brings AP below the robot's repeatability")
    predicted = result.correction.predicted_position_error_mm if result.correction else None
    ap_before = result.overall(first, "ap_mm_mean") if first else None
    if predicted is not None and ap_before is not None:
        out.append(f"The calibrated model forecast {number(predicted.before)} mm on the ISO "
                   f"targets as programmed; the robot showed AP mean {number(ap_before)} mm "
                   "before: how well the model accounts for the error of this cell")
    home = result.home_check
    corr = result.correction
    if home is not None and home.before and home.after and corr is not None:
        if corr.zero_command_deg is not None and corr.sent:
            out.append(f"ZERO corrected the controller's joint zeros: the home error went from "
                       f"{number(home.before.distance_mm)} to {number(home.after.distance_mm)} "
                       "mm")
        else:
            out.append(f"The home error stays ({number(home.before.distance_mm)} -> "
                       f"{number(home.after.distance_mm)} mm) because the {corr.route} route "
                       "corrects the programmed targets, not the controller's joint zeros: the "
                       "robot's own zeros are unchanged, and any change between the two is "
                       "drift or backlash over the job")
    return out


def verdict(result: ResultDocument, phases: tuple[str, ...]) -> str | None:
    """Whether it worked, in one sentence a manager can read: ISO 9283 position accuracy
    before and after, the factor, and what is left beside the robot's repeatability; None
    without a performance list before and after."""
    if len(phases) < 2:
        return None
    before = result.overall(phases[0], "ap_mm_mean")
    after = result.overall(phases[-1], "ap_mm_mean")
    rp = result.overall(phases[-1], "rp_mm_max")
    if before is None or after is None or after <= 0:
        return None
    factor = before / after
    if factor < 1.2:
        return (f"The calibration did not make the robot more accurate: position error "
                f"{number(before)} mm before, {number(after)} mm after (ISO 9283 AP, mean)")
    left = "" if rp is None else (
        f"; what is left ({number(after)} mm) is within twice the robot's own scatter "
        f"(repeatability RP max {number(rp)} mm): about as good as this robot can be"
        if after <= 2 * rp else
        f"; what is left ({number(after)} mm) is above twice the robot's own scatter "
        f"(repeatability RP max {number(rp)} mm): something the model does not hold remains "
        "(see the warnings and the residuals below)")
    return (f"It worked: the robot is {factor:,.0f}x more accurate, its position error "
            f"{number(before)} mm before and {number(after)} mm after (ISO 9283 AP, mean over "
            f"the test points){left}")


def summary_section(ctx: ReportContext) -> str | None:
    """The figures that belong together, what each measures, how they read together, the
    warnings."""
    result = ctx.result
    phases, rows = before_after(result.performance or {})
    figures = _figure_rows(result, phases, rows)
    if not figures and not result.warnings:
        return None
    names = [PERF_PHASE_NAMES[p] for p in phases] if phases else ["before", "after"]
    emulated = ctx.robot.get("emulation") or []
    said = verdict(result, phases)
    body = [f"<p class='verdict'><b>{esc(said)}.</b></p>"] if said else []
    body += [sentence(f"These figures come from an emulated robot ({emulated[0].rstrip(':')}): "
                     "what it carries is listed under the robot below")] if emulated else []
    body += [table(["figure", "unit", *names, "factor", "what it measures"], figures,
                  text_columns=(len(names) + 3,), cls="summary")] if figures else []
    if result.frame_note:
        body.append(sentence(result.frame_note))
    body += [sentence(line) for line in reading(result, phases)]
    body += [f"<p class='warning'><b>Warning:</b> {esc(w)}</p>" for w in result.warnings or []]
    return section("summary", "Summary", "".join(body))
