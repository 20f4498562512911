"""A job's result as the text a person reads in a terminal: the before/after table, what was
identified, the home check, the correction route, the warnings."""

from __future__ import annotations

from collections import Counter

from service.document import CorrectionPlan, EstimationSummary, ResultDocument
from service.job_state import state_said
from service.phases import PERF_PHASE_NAMES, ROUND_SUFFIXES
from service.schemas import JobResult
from service.summary import before_after

# What the parameters that are not a joint's place (their names' first part), in words
FRAME_WORDS = {"base": "the robot base frame", "tool": "the tool (the measured point)",
               "home": "the flange at home"}


def result_table(result: JobResult, times: bool = True) -> str:
    """The before/after table a person reads (`times`: the seconds each phase took)."""
    lines = [f"job {result.id}: {state_said(result.state, result.reason)}"]
    phases, rows = before_after(result.performance or {})
    if rows:
        lines.append(f"  {'ISO 9283':<36}" + "".join(f"{PERF_PHASE_NAMES[p]:>12}" for p in phases)
                     + (f"{'factor':>9}" if len(phases) > 1 else ""))
        for r in rows:
            cells = "".join(f"{v:>9.3f} {r.unit:<2}" if v is not None else f"{'-':>12}"
                            for v in r.values)
            factor = f"{r.factor:>8.1f}x" if r.factor is not None else ""
            lines.append(f"  {r.label:<36}{cells}{factor}")
    if result.estimation is not None:
        lines += _estimation_lines(result.estimation)
    if result.frame_note:
        lines.append(f"  frame: {result.frame_note}")
    home = result.home_check
    for when, measured in (("before", home and home.before), ("after", home and home.after)):
        if measured:
            e = measured.error_mm
            lines.append(f"  home position error {when} (Table 14): x {e[0]:+.3f}, y {e[1]:+.3f}, "
                         f"z {e[2]:+.3f} mm, |e| {measured.distance_mm:.3f} mm")
    moved = home_moved(result)
    if moved:
        lines.append(f"  {moved}")
    for suffix in ROUND_SUFFIXES:
        lines += _route_lines(result.correction_of(suffix), suffix)
    lines += [f"  {line}" for line in drift_and_backlash(result)]
    for warning in result.warnings or []:
        lines.append(f"  WARNING: {warning}")
    if result.phases and times:
        lines.append("  time per phase (s): " + ", ".join(
            f"{k} {v.seconds:.2f}" for k, v in result.phases.items()))
    return "\n".join(lines)


def _estimation_lines(est: EstimationSummary) -> list[str]:
    """The joints' identified parameters, the noise levels measured, what was not separable."""
    joints = [p for p in est.parameters if p.name.startswith("J")]
    others = Counter(p.name.split(".")[0] for p in est.parameters if not p.name.startswith("J"))
    rest = "; the other " + ", ".join(
        f"{n} of {FRAME_WORDS.get(group, group)}" for group, n in others.items()) + \
        " are in the result" if others else ""
    lines = [f"  identified ({len(est.parameters)} parameters, chi2/dof "
             f"{est.chi2_reduced:.2f}): the {len(joints)} of the joints below{rest}:"]
    for p in joints:
        lines.append(f"    {p.name:<8}{p.value:>10.4f} {p.unit:<3} ± {p.std_error:.4f}")
    if est.noise:
        lines.append("    noise levels: " + ", ".join(
            f"{k} {v['value']:.4g} {v['unit']}" + (f" ± {v['std']:.2g}" if v["std"] else "")
            for k, v in est.noise.items() if isinstance(v, dict) and v["measured"]))
    if est.removed:
        lines.append(f"    {len(est.removed)} held at nominal, not separable from these data "
                     "(not corrected): " + ", ".join(r.name for r in est.removed))
    lines += [f"    {line}" for line in beyond_geometry(est)]
    return lines


def beyond_geometry(est: EstimationSummary) -> list[str]:
    """The joint compliance identified (or why none) with the payload it was under, the
    read-back lag, and how much of the error before the model explains (the terminal's and the
    report's sentences)."""
    lines = []
    gravity = est.compliance or {}
    payload = gravity.get("payload") or {}
    if gravity:
        joints = gravity.get("joints") or []
        note = f" ({gravity['note']})" if gravity.get("note") else ""
        cog = ", ".join(f"{v:g}" for v in payload.get("cog_mm", (0.0, 0.0, 0.0)))
        lines.append("joint compliance: " + (", ".join(
            f"{j['name']} {j['compliance_deg_per_knm']:.3f} ± {j['std_error']:.3f} deg/kNm"
            for j in joints) if joints else "none") + f"{note}; calibrated carrying "
            f"{payload.get('kg', 0.0):g} kg at ({cog}) mm")
    lag = est.reading_lag or {}
    if lag:
        per_joint = lag.get("per_joint")
        lines.append("read-back lag: " + (", ".join(
            f"J{k + 1} {v:.5f}" for k, v in enumerate(per_joint) if abs(v) >= 1e-5)
            + " (fraction of the previous move)" if per_joint else (lag.get("note") or "none")))
    if est.explained_share is not None:
        lines.append(f"the model explains {100 * est.explained_share:.3f} % of the error before "
                     f"(mean square of the calibration residual; mean "
                     f"{est.residual_before_mm:.3f} -> {est.residual_after_mm:.3f} mm left)")
    return lines


def drift_and_backlash(result: ResultDocument) -> list[str]:
    """The lost motion identified per joint, and the drift of the reference poses (the
    terminal's lines)."""
    lines = []
    backlash = result.backlash
    if backlash:
        lines.append("lost motion (backlash): " + ", ".join(
            f"{j['joint']} {j['backlash_deg']:.4f} ± {j['std_deg']:.4f} deg"
            for j in backlash["joints"] if j["identified"]) + f" ({backlash['pairs']} pairs "
            "approached from both sides); " + backlash["compensation"])
    drift = result.drift
    if drift is not None and drift.t_s:
        last = ", ".join(f"{label} {drift.deviation_mm[label][-1]:.3f}"
                         for label in drift.reference)
        lines.append(f"drift of the reference poses over {drift.t_s[-1]:.0f} s "
                     f"({len(drift.t_s)} checks): {last} mm (norm of the position change "
                     "since the first check)")
    return lines


def home_moved(result: ResultDocument) -> str | None:
    """How far home moved over a job that sent nothing to the controller (drift, backlash)."""
    home = result.home_check
    if not (home and home.before and home.after and result.correction is not None
            and result.correction.zero_command_deg is None):
        return None
    moved = [a - b for a, b in zip(home.after.error_mm, home.before.error_mm, strict=True)]
    return (f"home moved over the job (drift, backlash; nothing was sent to the controller): "
            f"{sum(v * v for v in moved) ** 0.5:.3f} mm")


def _route_lines(corr: CorrectionPlan | None, suffix: str) -> list[str]:
    """What the correction route did, compensated, or left in the robot."""
    if corr is None:
        return []
    head = f"  correction{' (round 2)' if suffix else ''}: {corr.route}"
    lines = []
    if corr.route == "none":
        return [f"{head} ({corr.note or ''})"]
    if corr.zero_command_deg is not None:
        sent = "sent" if corr.sent else "planned, not sent"
        lines.append(f"{head}; ZERO {sent} (deg): "
                     + " ".join(f"{v:.4f}" for v in corr.zero_command_deg))
    else:
        lines.append(head)
    if corr.compensated_lists:
        lines.append(f"    compensated joint targets for {', '.join(corr.compensated_lists)} "
                     f"(largest joint change {corr.max_joint_change_deg or 0:.3f} deg)")
    predicted = corr.predicted_position_error_mm
    if predicted is not None:
        lines.append(f"    model-predicted flange error on the ISO targets: "
                     f"{predicted.before:.3f} -> {predicted.after:.3f} mm")
    if corr.left_in_robot:
        lines.append("    left in the robot (not corrected by this route): " + ", ".join(
            f"{p.name} {p.value:+.3f} {p.unit}" for p in corr.left_in_robot))
    elif corr.left_in_robot is not None:
        lines.append("    left in the robot: nothing the model identified")
    if corr.not_identified:
        lines.append("    held at nominal, not separable from these data (the parameters "
                     "they move with carry their effect): " + ", ".join(corr.not_identified))
    return lines
