"""The robot and the test: what the robot is (and, when emulated, what it carries), the payload
of each list, the compliance and read-back lag identified, and the ISO 9283 test conditions
(warm-up, speed, load, cycles)."""

from __future__ import annotations

from typing import Any

from service.document import EstimationSummary
from service.report.context import ReportContext
from service.report.markup import esc, section, sentence, table

IDENTITY = (("model", "model"), ("serial", "serial number"),
            ("controller_software", "controller software"), ("tool", "tool"))


def robot_rows(robot: dict[str, Any]) -> list[list[Any]]:
    rows: list[list[Any]] = [["robot", robot["name"]]]
    for key, label in IDENTITY:
        value = robot.get(key)
        if key == "model" and isinstance(value, dict):
            value = value.get("name", "")
        if value:
            rows.append([label, value])
    if robot.get("payload_kg") is not None:
        rows.append(["payload mounted (robot record)", f"{robot['payload_kg']:g} kg"])
    return rows


def emulation_text(robot: dict[str, Any]) -> str:
    """What the emulated robot carries, or that the record says nothing about it."""
    lines = robot.get("emulation") or []
    if not lines:
        return ("<p>The robot record states no emulation: a real robot, or an emulated one "
                "added without its realism.</p>")
    return ("<p>An emulated robot. What the emulated true robot carries, as its record "
            "states it (the calibration is not told: it identifies what it can, below):</p>"
            "<ul>" + "".join(f"<li>{esc(line)}</li>" for line in lines) + "</ul>")


def beyond_geometry_rows(est: EstimationSummary) -> list[list[Any]]:
    """Compliance per joint and read-back lag per joint, as identified, with their notes."""
    rows: list[list[Any]] = []
    gravity = est.compliance or {}
    for j in gravity.get("joints") or []:
        rows.append([f"compliance {j['name']}", "deg/kNm", j["compliance_deg_per_knm"],
                     j["std_error"], gravity.get("note") or ""])
    if gravity and not gravity.get("joints"):
        rows.append(["compliance", "deg/kNm", None, None, gravity.get("note") or "none"])
    lag = est.reading_lag or {}
    per_joint = lag.get("per_joint")
    if per_joint:
        rows += [[f"read-back lag J{k + 1}", "fraction", v, None, lag.get("meaning") or ""]
                 for k, v in enumerate(per_joint) if abs(v) >= 1e-5]
    elif lag:
        rows.append(["read-back lag", "fraction", None, None, lag.get("note") or "none"])
    return rows


def robot_section(ctx: ReportContext) -> str | None:
    """The robot, its realism, the payloads, what was identified beyond the geometry, the test
    conditions."""
    result = ctx.result
    body = [table(["", "value"], robot_rows(ctx.robot), text_columns=(1,)),
            emulation_text(ctx.robot)]
    est = result.estimation
    if est is not None:
        rows = beyond_geometry_rows(est)
        payload = (est.compliance or {}).get("payload") or {}
        if rows:
            body.append(sentence(
                "Identified beyond the geometry (joint compliance under gravity: the joint "
                "bends by c * torque; read-back lag: the joint readings trail the true joints "
                "by this fraction of the previous move)"))
            body.append(table(["effect", "unit", "value", "std error", "note"], rows,
                              text_columns=(4,), digits=4))
        if payload:
            cog = ", ".join(f"{v:g}" for v in payload.get("cog_mm", (0.0, 0.0, 0.0)))
            body.append(sentence(f"The calibration identified them carrying "
                                 f"{payload.get('kg', 0.0):g} kg at ({cog}) mm in the flange "
                                 "frame"))
    if result.test_conditions:
        body.append(table(["test condition (ISO 9283)", "value"],
                          [[k, v] for k, v in result.test_conditions.items()],
                          text_columns=(1,), digits=1))
    return section("robot", "The robot and the test conditions", "".join(body))



