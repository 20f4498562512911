"""Calibration of the real IRB 120 laser-tracker data: calibrate on a random half of the poses,
validate on the other half, and look at what the residual is made of.

    python -m screwcal.studies.tracker_study [--data DIR] [--seed 0]

Models compared: the nominal robot with only the tracker frame and the reflector's offset fitted
("frames", the robot's uncalibrated accuracy), the thesis's virtual joints, the full model, and
the full model with the joints' compliance under gravity ("full+c", `--compliance auto`: joints
2 and 3 when the data support them), and that with readings that lag the motion corrected
("full+c+lag", `--lag auto`: the lag estimated on the calibration half corrects the held-out
readings too), and that with the residual model over joint space ("+residual",
`--residual-model auto`: kept only when cross-validation on the calibration half says so; its
95 % band's coverage of the held-out errors beside it; `screwcal.studies.residual_model` for
the whole comparison).
Errors are those of reflector 1's position on the held-out poses, never on the fitted ones.
The tracker's noise is taken as 0.05 mm (a laser tracker at 2.5 m); the joint readings as exact.
"""

from __future__ import annotations

import argparse
from typing import Literal

import numpy as np

from screwcal.calibration.error_parameters import ModelKind
from screwcal.calibration.identify import CalibrationResult, identify
from screwcal.calibration.lag import correct_lag
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.residual_stage import held_out_figures, learn_residual
from screwcal.errors import DataFileError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.robots import irb120
from screwcal.kinematics.se3 import Array
from screwcal.studies.tracker_dataset import (
    TrackerData,
    add_data_argument,
    locate_dataset,
    read_tracker_dataset,
)

# label -> (model kind, compliance, lag) of the identification
MODELS: dict[str, tuple[ModelKind, str, Literal["none", "auto"]]] = {
    "frames": ("frames", "none", "none"), "thesis": ("thesis", "none", "none"),
    "full": ("full", "none", "none"), "full+c": ("full", "auto", "none"),
    "full+c+lag": ("full", "auto", "auto")}


def position_errors(result: CalibrationResult, data: MeasurementSet) -> Array:
    return np.linalg.norm(forward_kinematics(result.model, data.q)[:, :3, 3]
                          - data.positions_mm, axis=1)


def split_half(n: int, seed: int) -> tuple[Array, Array]:
    perm = np.random.default_rng(seed).permutation(n)
    return np.sort(perm[: n // 2]), np.sort(perm[n // 2:])


def run_study(dataset: TrackerData, seed: int = 0, full_pose: bool = True) -> dict:
    data = dataset.measurements(full_pose=full_pose)
    cal_idx, val_idx = split_half(len(data), seed)
    cal, val = data.take(cal_idx), data.take(val_idx)
    out: dict = {"poses": len(data), "calibration": len(cal), "validation": len(val),
                 "rejected_rows": len(dataset.rejected), "models": {}}
    for label, (kind, compliance, lag) in MODELS.items():
        # noise levels from the data
        result = identify(irb120(), cal, kind=kind, compliance=compliance, lag=lag)
        seen = val if result.reading_lag is None else correct_lag(val, result.reading_lag,
                                                                 result.reading_lost_motion)
        e = position_errors(result, seen)  # held-out readings corrected as the fit's were
        noise = result.noise
        out["models"][label] = {"mean": float(e.mean()), "max": float(e.max()),
                               "rms": float(np.sqrt(np.mean(e**2))), "rank": result.rank,
                               "chi2_reduced": result.chi2_reduced, "seconds": result.seconds,
                               "converged": result.converged,
                               "noise_mm": noise.position_mm if noise else None,
                               "joint_noise_deg": noise.joint_deg if noise else None,
                               "outliers": sum(o.rejected for o in result.outliers),
                               "warnings": result.warnings,
                               "compliance": [(p.name, float(v), float(sd)) for p, v, sd in
                                              zip(result.params, result.values,
                                                  result.std_errors, strict=True)
                                              if p.kind.startswith("compliance")],
                               "compliance_note": result.compliance_note,
                               "lag_note": result.lag_note}
        if label == "full":
            out["residual_analysis"] = residual_analysis(result, val)
        if label == "full+c+lag":
            outcome = learn_residual(result, cal, "auto")
            out["residual_model"] = {**held_out_figures(result, outcome, val),
                                     "note": outcome.note}
    return out


def residual_analysis(result: CalibrationResult, val: MeasurementSet) -> dict:
    """Mean held-out error by quartile of each joint, of the reach, and by file order."""
    e = position_errors(result, val)
    qd = np.degrees(val.q)

    def by_quartile(values: Array) -> list[float]:
        bins = np.digitize(values, np.percentile(values, [25, 50, 75]))
        return [float(e[bins == b].mean()) for b in range(4)]

    rows = np.array([int(i) for i in val.ids])
    reach = np.linalg.norm(forward_kinematics(irb120(), val.q)[:, :3, 3], axis=1)
    return {"by_joint_quartile": {f"J{j + 1}": by_quartile(qd[:, j]) for j in range(6)},
            "by_reach_quartile": by_quartile(reach),
            "by_row_block_of_200": [float(e[(rows > a) & (rows <= a + 200)].mean())
                                    for a in range(0, 1000, 200)],
            "percentiles_50_90_99": np.percentile(e, [50, 90, 99]).tolist()}


def format_study(s: dict) -> str:
    lines = [f"IRB 120, laser tracker, {s.get('joints', 'measured')} joints: {s['poses']} poses "
             f"kept ({s['rejected_rows']} rejected), calibrate on {s['calibration']}, validate "
             f"on {s['validation']} unseen",
             f"  {'model':<8}{'mean':>9}{'RMS':>9}{'max':>9}{'rank':>6}{'noise':>9}"
             f"{'joint':>9}{'outliers':>9}   (mm; noise levels found: mm, deg +-)"]
    for kind, m in s["models"].items():
        lines.append(f"  {kind:<8}{m['mean']:>9.3f}{m['rms']:>9.3f}{m['max']:>9.3f}"
                     f"{m['rank']:>6}{m['noise_mm'] or 0:>9.3f}{m['joint_noise_deg'] or 0:>9.4f}"
                     f"{m['outliers']:>9}")
        lines += [f"    warning: {w}" for w in m["warnings"]]
        if m.get("compliance"):
            lines.append("    joint compliance (deg/kNm): " + ", ".join(
                f"{n} {v:.2f} +- {sd:.2f}" for n, v, sd in m["compliance"]))
    rm = s.get("residual_model")
    if rm:
        lines.append(f"  +residual (full+c+lag with --residual-model auto): held-out mean "
                     f"{rm['physical_mean_mm']:.4f} -> {rm['corrected_mean_mm']:.4f} mm, max "
                     f"{rm['physical_max_mm']:.3f} -> {rm['corrected_max_mm']:.3f} mm"
                     + (f", 95 % band coverage {100 * rm['coverage_95']:.1f} %"
                        if rm["used"] else "") + f"; {rm['note']}")
    ra = s.get("residual_analysis")
    if ra:
        lines.append("  full model, held-out mean error by quartile (low -> high):")
        for name, vals in ra["by_joint_quartile"].items():
            lines.append(f"    {name}: " + " ".join(f"{v:.3f}" for v in vals))
        lines.append("    reach: " + " ".join(f"{v:.3f}" for v in ra["by_reach_quartile"]))
        lines.append("    file rows in blocks of 200: "
                     + " ".join(f"{v:.3f}" for v in ra["by_row_block_of_200"]))
    return "\n".join(lines)


def parser() -> argparse.ArgumentParser:
    """`python -m screwcal.studies.tracker_study`'s options."""
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_data_argument(p)
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the calibration/validation split (default 0)")
    p.add_argument("--joints", choices=["measured", "commanded", "both"], default="both",
                   help="the joints read back (before the arm settled) or the targets sent")
    p.add_argument("--position-only", action="store_true",
                   help="use reflector 1's position only, not the three-reflector frame")
    return p


def main() -> None:
    parser_ = parser()
    args = parser_.parse_args()
    try:
        folder = locate_dataset(args.data)
    except DataFileError as err:
        parser_.exit(2, f"error: {err}\n")
    for joints in (("measured", "commanded") if args.joints == "both" else (args.joints,)):
        dataset = read_tracker_dataset(folder, joints=joints)
        if joints == "measured" or args.joints != "both":
            print(dataset.report())
        study = run_study(dataset, args.seed, not args.position_only)
        print(format_study({**study, "joints": joints}))


if __name__ == "__main__":
    main()
