"""`screwcal calibrate` and `screwcal compensate` (../shared/spec/data-formats.md).

    screwcal calibrate --robot irb1600 --data measurements.csv --out result.json
                       [--model full|thesis|joints] [--solver lm|de] [--weight-mm W]
                       [--base-frame unknown|known] [--residual pose|position|distance]
    screwcal compensate --model result.json --targets targets.csv --out compensated.csv

By default the measuring system's frame and the measured point's offset from the flange are
identified with the robot's errors; `--base-frame known` says the data are already in the robot
base frame and the measured point is the flange. `--weight-mm W` selects the thesis's Eq. 2.4
objective with that W; otherwise residuals are weighted statistically by the noise levels, which
are estimated from the data (variance components) unless `--noise-mm` / `--joint-noise-deg` fix
them; the result reports the levels used with their uncertainty.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from screwcal.calibration import base_alignment
from screwcal.calibration.base_alignment import base_from_sweeps, fit_circle, read_sweeps_csv
from screwcal.calibration.correction import compensate
from screwcal.calibration.identify import NoiseModel, identify
from screwcal.calibration.measurements import read_measurements_csv
from screwcal.calibration.resultfile import result_document
from screwcal.errors import DataFileError, JointLimitError, UnreachableError
from screwcal.kinematics.modelfile import PoseIn, load_model, resolve_model
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
from screwcal.tables import joint_columns, read_numeric_csv, write_csv_atomic


def run_calibrate(args: argparse.Namespace) -> int:
    nominal = resolve_model(args.robot)
    data = read_measurements_csv(args.data, nominal)
    weighting = "eq2.4" if args.weight_mm is not None else "statistical"
    noise = NoiseModel(position_mm=args.noise_mm, joint_deg=args.joint_noise_deg)
    base_guess = None
    if args.base_guess:
        base_guess = base_from_sweeps(nominal, *read_sweeps_csv(args.base_guess))
    result = identify(nominal, data, kind=args.model, residual=args.residual,
                      frames=args.base_frame, solver=args.solver, weighting=weighting,
                      weight_mm=args.weight_mm or 1.0, noise=noise, base_guess=base_guess)
    settings = {"model": args.model, "solver": args.solver, "base_frame": args.base_frame,
                "residual": result.residual_kind, "weighting": weighting,
                "weight_mm": args.weight_mm, "noise_mm": args.noise_mm,
                "joint_noise_deg": args.joint_noise_deg, "data": str(args.data),
                "poses": len(data)}
    doc = result_document(result, nominal.name, settings)
    Path(args.out).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    b, a = doc["residuals"]["summary_before"], doc["residuals"]["summary_after"]
    print(f"{args.model} model, {len(data)} poses, rank {result.rank}/{result.n_candidates}: "
          f"residual mean {b['mean']:.3f} -> {a['mean']:.3f} mm, max {b['max']:.3f} -> "
          f"{a['max']:.3f} mm{'' if result.converged else ' (NOT converged)'} -> {args.out}")
    if result.noise is not None:
        print("noise levels: " + _noise_line(result.noise.to_dict())
              + f"; chi2/dof {result.chi2_reduced:.2f}")
    if result.degenerate:
        print("warning: some requested parameters cannot be identified from these data; see "
              "removed_parameters in the result")
    return 0 if result.converged else 1


def _noise_line(noise: dict) -> str:
    parts = []
    for name in ("position", "orientation", "joint"):
        n = noise[name]
        if not n["measured"]:
            continue
        how = f"+- {n['std']:.2g} (estimated)" if n["estimated"] else "(fixed)"
        parts.append(f"{name} {n['value']:.4g} {n['unit']} {how}")
    return ", ".join(parts)


def run_compensate(args: argparse.Namespace) -> int:
    calibrated = load_model(args.model)
    robot = args.robot or json.loads(Path(args.model).read_text(encoding="utf-8")).get("robot")
    nominal = resolve_model(robot) if robot else calibrated
    table = read_numeric_csv(args.targets, ["x", "y", "z", "rx", "ry", "rz"])
    T = transform_from_pose(table.take(["x", "y", "z", "rx", "ry", "rz"]))
    try:
        comp = compensate(calibrated, nominal, T)
    except (UnreachableError, JointLimitError) as err:
        line = table.lines[err.index] if err.index is not None else None
        raise DataFileError(table.path, f"no compensated target: {err}", line=line) from None
    q_deg = calibrated.joints_to_deg(comp.q_rad)
    poses = pose_from_transform(comp.nominal_tool0)
    header = ["id", *joint_columns(calibrated.n_joints), "x", "y", "z", "rx", "ry", "rz"]
    write_csv_atomic(args.out, header, ([i, *(f"{v:.4f}" for v in q), *(f"{v:.4f}" for v in p)]
                                        for i, q, p in zip(table.ids, q_deg, poses, strict=True)))
    print(f"compensated {len(q_deg)} targets -> {args.out} (joint targets, and the nominal "
          f"tool0 poses of model '{nominal.name}' to program)")
    return 0


def run_align(args: argparse.Namespace) -> int:
    nominal = resolve_model(args.robot)
    j1, j2, q1 = read_sweeps_csv(args.sweeps)
    base = base_from_sweeps(nominal, j1, j2, q1)
    c1, c2 = fit_circle(j1), fit_circle(j2)
    doc = {"robot": nominal.name, "base": PoseIn.of(base).model_dump(),
           "meaning": "pose of the robot base frame in the measuring system's frame (mm, deg)",
           "j1_circle_rms_mm": c1.rms_mm, "j2_circle_rms_mm": c2.rms_mm}
    Path(args.out).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    b = doc["base"]
    print(f"robot base in the measuring frame: x {b['x']:.3f} y {b['y']:.3f} z {b['z']:.3f} mm, "
          f"rx {b['rx']:.4f} ry {b['ry']:.4f} rz {b['rz']:.4f} deg; circle fits RMS "
          f"{c1.rms_mm:.3f} / {c2.rms_mm:.3f} mm -> {args.out}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    a = sub.add_parser("align", help="base frame from joint 1 and joint 2 sweeps (thesis 4.6)",
                       description=base_alignment.__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    a.add_argument("--robot", required=True, help="built-in robot or model file")
    a.add_argument("--sweeps", required=True,
                   help="CSV: joint (1|2), q1 (deg), x, y, z (mm), in the order probed")
    a.add_argument("--out", required=True, help="JSON with the base pose")
    a.set_defaults(func=run_align)

    p = sub.add_parser("calibrate", help="identify the robot's geometric errors from a CSV",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robot", required=True, help="built-in robot (irb1600, irb120) or model file")
    p.add_argument("--data", required=True, help="measurement CSV (q1..q6, x, y, z[, rx, ry, rz])")
    p.add_argument("--out", required=True, help="result JSON to write")
    p.add_argument("--model", choices=["full", "thesis", "joints", "frames"], default="full",
                   help="error model (frames: the nominal robot, only the frames fitted)")
    p.add_argument("--solver", choices=["lm", "de"], default="lm")
    p.add_argument("--weight-mm", type=float, default=None,
                   help="W of Eq. 2.4 (selects that objective; default: statistical weighting)")
    p.add_argument("--base-frame", choices=["unknown", "known"], default="unknown")
    p.add_argument("--residual", choices=["pose", "position", "distance"], default=None,
                   help="default: pose for full-pose data, position otherwise")
    p.add_argument("--base-guess", metavar="SWEEPS_CSV",
                   help="start the base frame from the thesis's joint 1/joint 2 sweeps (4.6)")
    p.add_argument("--noise-mm", type=float, default=None,
                   help="fix the measuring noise, 1 sigma (default: estimated from the data)")
    p.add_argument("--joint-noise-deg", type=float, default=None,
                   help="fix the random joint error, uniform +- (default: estimated)")
    p.set_defaults(func=run_calibrate)

    c = sub.add_parser("compensate", help="joint targets that make the calibrated robot reach "
                       "desired poses", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    c.add_argument("--model", required=True, help="calibration result (or model file)")
    c.add_argument("--targets", required=True,
                   help="CSV of desired poses: id, x, y, z, rx, ry, rz (measuring frame)")
    c.add_argument("--out", required=True, help="CSV to write: id, q1..q6, x..rz (nominal tool0)")
    c.add_argument("--robot", help="nominal model, when the result does not name it")
    c.set_defaults(func=run_compensate)
