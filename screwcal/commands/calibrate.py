"""`screwcal calibrate`: identify a robot's errors from measured poses (files: docs/formats.md).

    screwcal calibrate --robot irb1600 --data measurements.csv --out result.json
                       [--error-model full|thesis|joints|frames] [--solver lm|de]
                       [--weight-mm W] [--base-frame unknown|known]
                       [--residual pose|position|distance] [--residual-model auto|none|gp]

--robot is a library robot (`screwcal robot list`) or a robot file (`screwcal robot import`,
docs/robots.md). By default the measuring system's frame and the measured point's offset from
the flange are identified with the robot's errors; `--base-frame known` says the data are
already in the robot base frame and the measured point is the flange. `--weight-mm W` selects
the thesis's Eq. 2.4 objective with that W; otherwise residuals are weighted statistically by
the noise levels, which are estimated from the data (variance components) unless `--noise-mm`
/ `--joint-noise-deg` fix them; the result reports the levels used with their uncertainty.
`--model` is the offline contract's name of `--error-model`.

After identification, `--residual-model` (default auto) learns what the physical model leaves of
the measured point's position as a function of the joints (a Gaussian process, docs/formats.md
"residual_model"); auto keeps it only when cross-validation on the calibration poses shows it
beats the physical model by more than its spread. predict and compensate then add its
correction, with its standard deviation.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from screwcal.arguments import (
    ERROR_MODELS,
    add_payload_arguments,
    check_outputs,
    non_negative_float,
    positive_float,
)
from screwcal.commands.joint_convention import add_joint_convention

if TYPE_CHECKING:
    from screwcal.calibration.identify_result import CalibrationResult
    from screwcal.calibration.measurements import MeasurementSet
    from screwcal.calibration.plausible import PlausibleRanges
    from screwcal.kinematics.model import SerialModel

# The numeric modules are imported inside each command: `screwcal --help` and the other
# subcommands do not pay for scipy.optimize and pydantic.


ALIGN_DOC = """`screwcal align`: the robot base frame in the measuring system's frame, by hand
(thesis 4.6, Fig. 40); also what `calibrate --base-guess` starts from.

A point on the robot is probed while joint 1 alone turns, then while joint 2 alone turns. A
circle fitted to each sweep gives the joint's axis; the model's nominal geometry places the base
origin and x axis from them. The sweeps file has the columns joint (1 or 2), q1 (deg, joint 1's
reading), x, y, z (mm), in the order probed, at least 8 rows.
"""



def run_calibrate(args: argparse.Namespace) -> int:
    from screwcal.calibration.backlash import backlash_of_measurements
    from screwcal.calibration.base_alignment import base_from_sweeps, read_sweeps_csv
    from screwcal.calibration.identify import NoiseModel, identify
    from screwcal.calibration.measurements import read_measurements_csv
    from screwcal.calibration.residual_stage import learn_residual
    from screwcal.calibration.resultfile import result_document
    from screwcal.commands.payload import with_payload
    from screwcal.errors import DataFileError, IdentificationError
    from screwcal.kinematics.modelfile import resolve_model
    from screwcal.kinematics.readings import robot_convention
    from screwcal.tables import write_json_atomic

    check_outputs([args.out], [args.data, args.base_guess, args.robot, args.joints])
    nominal = with_payload(resolve_model(args.robot), args)
    convention = args.joint_convention or robot_convention(nominal.name)
    if args.joints:  # --data is then a point export (X, Y, Z[, U95]) of any instrument
        from screwcal.calibration.point_export import read_points_and_joints

        data = read_points_and_joints(args.data, args.joints, nominal,
                                      joint_unit=args.joint_unit,
                                      length_unit=args.length_unit, joint_convention=convention)
    else:
        data = read_measurements_csv(args.data, nominal, joint_unit=args.joint_unit,
                                     length_unit=args.length_unit, joint_convention=convention)
    if args.base_frame == "known":
        check_known_frame(nominal, data, args.data)
    weighting = "eq2.4" if args.weight_mm is not None else "statistical"
    noise = NoiseModel(position_mm=args.noise_mm, joint_deg=args.joint_noise_deg)
    base_guess = None
    if args.base_guess:
        base_guess = base_from_sweeps(nominal, *read_sweeps_csv(args.base_guess))
    try:
        result = identify(nominal, data, kind=args.error_model, residual=args.residual,
                          frames=args.base_frame, solver=args.solver, weighting=weighting,
                          weight_mm=args.weight_mm or 1.0, noise=noise, base_guess=base_guess,
                          outliers=args.outliers, compliance=args.compliance, lag=args.lag,
                          plausible=args.plausible or plausible_ranges(""))
    except IdentificationError as err:  # the data cannot give what was asked: say which data
        raise DataFileError(args.data, str(err)) from None
    settings = {"model": args.error_model, "solver": args.solver, "base_frame": args.base_frame,
                "residual": result.residual_kind, "weighting": weighting,
                "weight_mm": args.weight_mm, "noise_mm": args.noise_mm,
                "joint_noise_deg": args.joint_noise_deg, "data": str(args.data),
                "poses": len(data), "compliance": args.compliance, "lag": args.lag,
                "outliers": args.outliers, "joint_convention": convention,
                "residual_model": args.residual_model}
    doc = result_document(result, nominal.name, settings)
    residual = learn_residual(result, data, args.residual_model)  # the stage after identify
    doc["residual_model"] = residual.to_dict()
    doc["warnings"] += list(residual.warnings)
    backlash = backlash_of_measurements(result, data)
    if backlash is not None:
        doc["backlash"] = backlash
    write_json_atomic(args.out, doc)
    _print_findings(args, len(data), result, doc, backlash)
    return 0 if result.converged else 1


# With --base-frame known, measured points that sit this far (mm) or turned this much (deg)
# from the nominal flange at the same joints are in another frame: no robot is off by so much
OTHER_FRAME_MM = 150.0
OTHER_FRAME_DEG = 5.0


def check_known_frame(nominal: SerialModel, data: MeasurementSet, path: str) -> None:
    """Refuse --base-frame known for data that look like another frame: the rigid motion that
    best lays the nominal flange points on the measured ones moves them more than
    OTHER_FRAME_MM or turns them more than OTHER_FRAME_DEG (a fit in the wrong frame ends with
    a residual of hundreds of mm, blamed on everything but the frame)."""
    import numpy as np

    from screwcal.calibration.initial_frames import rigid_motion
    from screwcal.errors import DataFileError
    from screwcal.kinematics.forward import flange_kinematics

    if len(data) < 3:
        return
    flange = flange_kinematics(nominal, data.q)[:, :3, 3]
    R, t = rigid_motion(flange, data.positions_mm)
    moved = np.linalg.norm(flange @ R.T + t - flange, axis=1).max()
    turned = np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))
    if moved > OTHER_FRAME_MM or turned > OTHER_FRAME_DEG:
        raise DataFileError(path, f"--base-frame known says the points are the flange in the "
                            f"robot base frame, but they sit up to {moved:.0f} mm from where "
                            f"the nominal robot puts its flange (a frame turned {turned:.1f} "
                            "deg): they look like another frame (the measuring system's); "
                            "leave out --base-frame known and the frame is identified")


def _print_findings(args: argparse.Namespace, poses: int, result: CalibrationResult,
                    doc: dict, backlash: dict | None) -> None:
    """What calibrate says it found: the fit, the noise, the compliance, the lag, the prior,
    the backlash, the residual model and the warnings."""
    b, a = doc["residuals"]["summary_before"], doc["residuals"]["summary_after"]
    print(f"{args.error_model} model, {poses} poses, rank {result.rank}/"
          f"{result.n_candidates}: "
          f"residual mean {b['mean']:.3f} -> {a['mean']:.3f} mm, max {b['max']:.3f} -> "
          f"{a['max']:.3f} mm{'' if result.converged else ' (NOT converged)'} -> {args.out}")
    if result.noise is not None:
        print("noise levels: " + _noise_line(result.noise.to_dict())
              + f"; chi2/dof {result.chi2_reduced:.2f}")
    gravity = doc["compliance"]
    if gravity["joints"]:
        print("joint compliance: " + ", ".join(
            f"{j['name']} {j['compliance_deg_per_knm']:.3g} +- {j['std_error']:.2g} deg/kNm"
            + (f" ({100 * j['share_the_geometry_cannot_absorb']:.0f} % of its effect beyond "
               "what the geometry can imitate)"
               if j["share_the_geometry_cannot_absorb"] is not None else "")
            for j in gravity["joints"]) + (f"; {gravity['note']}" if gravity["note"] else ""))
    elif gravity["note"]:
        print(f"joint compliance {gravity['note']}")
    if result.reading_lag is not None:
        print(f"joint readings {result.lag_note}")
    if result.prior_note:
        print(f"prior scales {result.prior_note}")
    if result.held_by_prior:
        print("held at nominal, the data leave them (nearly) free: "
              + "; ".join(result.held_by_prior))
    if backlash is not None:
        print("lost motion (backlash, from pairs approached from both sides): " + (", ".join(
            f"{j['joint']} {j['backlash_deg']:.4f} +- {j['std_deg']:.4f} deg"
            for j in backlash["joints"] if j["identified"]) or "no joint separable")
            + f"; {backlash['compensation']}")
    rm = doc["residual_model"]
    print(f"residual model {rm['note']}" + (
        f"; predictive std {rm['predictive_std_mm']['mean_over_calibration_poses']:.4f} mm "
        "(per component, mean over the calibration poses)" if rm["used"] else ""))
    for warning in doc["warnings"]:
        print(f"warning: {warning}")
    if result.degenerate:
        print("warning: some requested parameters cannot be identified from these data; see "
              "removed_parameters in the result")


RANGE_KEYS = {"zero": "zero_deg", "tilt": "tilt_deg", "length": "length_mm",
              "frame-deg": "frame_rotation_deg", "frame-mm": "frame_position_mm",
              "compliance": "compliance_deg_per_knm"}


def plausible_ranges(text: str) -> PlausibleRanges:
    """--plausible zero=5,tilt=1: PlausibleRanges with those fields changed."""
    from screwcal.calibration.plausible import PlausibleRanges

    changes = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        key, _, value = item.partition("=")
        if key.strip() not in RANGE_KEYS:
            raise argparse.ArgumentTypeError(f"'{key.strip()}' is not one of "
                                             f"{', '.join(RANGE_KEYS)}")
        changes[RANGE_KEYS[key.strip()]] = positive_float(value.strip())
    return PlausibleRanges(**changes)


def _noise_line(noise: dict) -> str:
    parts = []
    for name in ("position", "orientation", "joint"):
        n = noise[name]
        if not n["measured"]:
            continue
        how = f"+- {n['std']:.2g} (estimated)" if n["estimated"] else "(fixed)"
        parts.append(f"{name} {n['value']:.4g} {n['unit']} {how}")
    return ", ".join(parts)


def run_align(args: argparse.Namespace) -> int:
    from screwcal.calibration.base_alignment import base_from_sweeps, fit_circle, read_sweeps_csv
    from screwcal.kinematics.modelfile import pose_document, resolve_model
    from screwcal.tables import write_json_atomic

    check_outputs([args.out], [args.sweeps, args.robot])
    nominal = resolve_model(args.robot)
    j1, j2, q1 = read_sweeps_csv(args.sweeps)
    base = base_from_sweeps(nominal, j1, j2, q1)
    c1, c2 = fit_circle(j1), fit_circle(j2)
    b = pose_document(base)
    doc = {"robot": nominal.name, "base": b,
           "meaning": "pose of the robot base frame in the measuring system's frame (mm, deg)",
           "j1_circle_rms_mm": c1.rms_mm, "j2_circle_rms_mm": c2.rms_mm}
    write_json_atomic(args.out, doc)
    print(f"robot base in the measuring frame: x {b['x']:.3f} y {b['y']:.3f} z {b['z']:.3f} mm, "
          f"rx {b['rx']:.4f} ry {b['ry']:.4f} rz {b['rz']:.4f} deg; circle fits RMS "
          f"{c1.rms_mm:.3f} / {c2.rms_mm:.3f} mm -> {args.out}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    _add_align(sub)
    _add_calibrate(sub)


def _add_align(sub: argparse._SubParsersAction) -> None:
    a = sub.add_parser("align", help="base frame from joint 1 and joint 2 sweeps (thesis 4.6)",
                       description=ALIGN_DOC,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    a.add_argument("--robot", required=True,
                   help="library robot (screwcal robot list) or robot / model "
                   "file")
    a.add_argument("--sweeps", required=True,
                   help="CSV: joint (1|2), q1 (deg), x, y, z (mm), in the order probed")
    a.add_argument("--out", required=True, help="JSON with the base pose")
    a.set_defaults(func=run_align)


def _add_calibrate(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("calibrate", help="identify the robot's geometric errors from a CSV",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robot", required=True,
                   help="library robot (screwcal robot list) or robot / model "
                   "file (screwcal robot import)")
    p.add_argument("--data", required=True, help="measurement CSV (q1..q6, x, y, z[, rx, ry, rz])")
    p.add_argument("--joints", metavar="JOINTS_CSV", default=None,
                   help="the joints file (q1..q6[, id]) of a point export: --data is then an "
                   "instrument software's export with X, Y, Z and optionally U95 (mm, k = 2) "
                   "columns, positions only, each point weighted by its U95 "
                   "(screwcal/calibration/point_export.py)")
    p.add_argument("--out", required=True, help="result JSON to write")
    p.add_argument("--joint-unit", choices=["deg", "rad"], default="deg",
                   help="unit of the file's q1..q6 (default deg; readings that look like "
                   "radians are refused)")
    p.add_argument("--length-unit", choices=["mm", "m", "in"], default="mm",
                   help="unit of the file's x, y, z (default mm; points that look like metres "
                   "or inches are refused)")
    p.add_argument("--error-model", "--model", dest="error_model", choices=ERROR_MODELS,
                   default="full", help="error model identified (default full; frames: the "
                   "nominal robot, only the frames fitted); --model is the offline contract's "
                   "spelling of it")
    p.add_argument("--solver", choices=["lm", "de"], default="lm",
                   help="Levenberg-Marquardt (default) or differential evolution then LM")
    p.add_argument("--weight-mm", type=positive_float, default=None,
                   help="W of Eq. 2.4 (selects that objective; default: statistical weighting)")
    p.add_argument("--base-frame", choices=["unknown", "known"], default="unknown",
                   help="unknown (default): the measuring frame and the measured point are "
                   "identified; known: the data are in the robot base frame, of the flange")
    p.add_argument("--residual", choices=["pose", "position", "distance"], default=None,
                   help="default: pose for full-pose data, position otherwise")
    p.add_argument("--base-guess", metavar="SWEEPS_CSV",
                   help="start the base frame from the thesis's joint 1/joint 2 sweeps (4.6)")
    p.add_argument("--plausible", type=plausible_ranges, default=None,
                   metavar="KEY=VALUE,...",
                   help="plausible ranges (+-): zero (deg), tilt (deg), length (mm), frame-deg, "
                   "frame-mm (of the alignment), compliance (deg/kNm); defaults 10, 2, 10, 10, "
                   "100, 10. Their halves scale the prior that keeps what the data leave free "
                   "at nominal; a parameter beyond its range is a warning")
    p.add_argument("--outliers", choices=["reject", "keep"], default="reject",
                   help="poses whose residual says they do not belong: left out of the fit "
                   "(default) or kept; listed either way")
    p.add_argument("--noise-mm", type=positive_float, default=None,
                   help="fix the measuring noise, 1 sigma (default: estimated from the data)")
    p.add_argument("--joint-noise-deg", type=non_negative_float, default=None,
                   help="fix the random joint error, uniform +- (0: none; default: "
                   "estimated)")
    p.add_argument("--compliance", choices=["auto", "none", "j23", "j23-free", "wrist"],
                   default="auto",
                   help="joint compliance under gravity, identified with the geometry: joints "
                   "2-3, joints 2-3 with a coefficient per arm mass, or 2-6 (default auto: "
                   "joints 2-3 when the data support them, per mass when rich data do)")
    p.add_argument("--lag", choices=["auto", "none"], default="auto",
                   help="joint readings that lag the motion (the diagnostics flag them): "
                   "estimate the lag from the residuals and correct the readings (default auto: "
                   "when flagged; rows are taken in the file's order)")
    p.add_argument("--residual-model", choices=["auto", "none", "gp"], default="auto",
                   help="after identification, learn what the physical model leaves over joint "
                   "space (a Gaussian process): auto (default) keeps it when cross-validation "
                   "shows it beats the physical model by more than its spread; gp keeps it; "
                   "none skips it")
    add_joint_convention(p, "how the file's q1..q6 count joint 3")
    add_payload_arguments(p)
    p.set_defaults(func=run_calibrate)
