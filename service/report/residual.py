"""The residual model over joint space (screwcal.calibration.residual_model) of each calibration
round: kept or declined and why, the physical model's and the residual model's out-of-fold
figures side by side, and the uncertainty it gives each prediction."""

from __future__ import annotations

from typing import Any

from service.phases import ROUND_SUFFIXES
from service.report.context import ReportContext
from service.report.markup import section, sentence, table


def residual_body(member: dict[str, Any]) -> str:
    """One round's residual model: the decision, the figures side by side, the band."""
    parts = [sentence(f"Residual model over joint space ({member['mode']}): {member['note']}")]
    cv = member.get("cross_validation")
    if cv:
        parts.append(table(
            ["model", "mean position error mm", "share of the physical model's"],
            [["physical model", cv["physical_mean_mm"], 1.0],
             ["physical + residual", cv["corrected_mean_mm"],
              cv["corrected_mean_mm"] / cv["physical_mean_mm"]
              if cv["physical_mean_mm"] > 0 else None]],
            caption=f"{cv['folds']}-fold cross-validation on {cv['poses']} calibration poses: "
                    "each pose predicted without it", digits=4, text_columns=(0,)))
    if member.get("used"):
        std = member["predictive_std_mm"]["mean_over_calibration_poses"]
        size = member["size_over_calibration_poses_mm"]
        parts.append(sentence(
            "Each prediction and compensated target carries the correction (here "
            f"{size['mean']:.4f} mm on average, at most {size['max']:.4f} mm) and its standard "
            f"deviation (per component, {std:.4f} mm on average), scaled so that 95 % of the "
            f"out-of-fold errors lie in their 95 % band (scale {member['std_scale']:.2f}); a "
            f"configuration beyond {member['reach_length_scales']:.2f} length scales of every "
            "calibration pose gets none. Robot exports (URDF, DH) carry the physical model only"))
    return "".join(parts)


def residual_section(ctx: ReportContext) -> str | None:
    """Each calibration round's residual model; None when no round has one."""
    parts = []
    for suffix in ROUND_SUFFIXES:
        calibration = ctx.result.calibration_of(suffix) or {}
        member = calibration.get("residual_model")
        if isinstance(member, dict):
            parts.append(("<h3>Round 2</h3>" if suffix else "") + residual_body(member))
    if not parts:
        return None
    return section("residual-model", "What the physical model leaves: the residual model",
                   "".join(parts))
