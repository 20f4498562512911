"""What the correction route did: the ZERO targets, the compensated lists, what it left in the
robot and what nothing corrects."""

from __future__ import annotations

import io

from service.document import CorrectionPlan
from service.phases import ROUND_SUFFIXES
from service.report.context import ReportContext
from service.report.markup import esc, number, section, sentence, table


def correction_body(corr: CorrectionPlan) -> str:
    """The route's ZERO (zero routes), compensated lists (compensate routes), the model's
    forecast, and what stays in the robot."""
    out = io.StringIO()
    if corr.note:
        out.write(sentence(corr.note))
    if corr.zero_command_deg is not None:
        sent = "sent to the controller" if corr.sent else "planned, not sent"
        out.write(sentence(f"ZERO ({sent}; on a real IRC5 the operator enters the offsets on "
                           "the FlexPendant and gives the go-ahead):"))
        out.write(table(["joint", "offset deg", "ZERO target deg", "identified"],
                        [[f"J{i + 1}", o, z, str(ok)] for i, (o, z, ok) in enumerate(zip(
                            corr.offsets_deg or [], corr.zero_command_deg,
                            corr.identified or [], strict=True))], digits=4))
    if corr.compensated_lists:
        out.write(sentence(
            f"Compensated joint targets sent for {', '.join(corr.compensated_lists)} (largest "
            f"joint change {number(corr.max_joint_change_deg or 0.0, 4)} deg): the calibrated "
            "robot reaches the nominal targets; nothing changed in the controller"))
    predicted = corr.predicted_position_error_mm
    if predicted is not None:
        out.write(sentence(f"Model-predicted flange position error on the ISO targets: "
                           f"{number(predicted.before)} mm as programmed, "
                           f"{number(predicted.after)} mm as corrected"))
    if corr.left_in_robot:
        out.write(sentence("Left in the robot by this route (identified, not corrected):")
                  + table(["parameter", "value", "unit"],
                          [[p.name, p.value, p.unit] for p in corr.left_in_robot], digits=4))
    elif corr.left_in_robot is not None:
        out.write(sentence("Left in the robot: nothing the model identified"))
    if corr.not_identified:
        out.write(sentence("Held at their nominal values, not separable from these data (the "
                           "parameters they move with carry their effect: see what the "
                           "calibration identified): " + ", ".join(corr.not_identified)))
    return out.getvalue()


def correction_section(ctx: ReportContext) -> str | None:
    """Each calibration round's correction route."""
    parts = []
    for suffix in ROUND_SUFFIXES:
        corr = ctx.result.correction_of(suffix)
        if corr is not None:
            title = f"{'Round 2 route' if suffix else 'Route'}: {esc(corr.route)}"
            parts.append(f"<h3>{title}</h3>{correction_body(corr)}")
    if not parts:
        return None
    return section("correction", "Correction", "".join(parts))
