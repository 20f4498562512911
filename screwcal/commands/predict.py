"""`screwcal predict`: the pose of the measured point that a model gives for joint readings.

    screwcal predict --result result.json --joints joints.csv --out predicted.csv
    screwcal predict --robot irb1600 --joints joints.csv --out predicted.csv

--result (a calibration result, or a calibrated model file) predicts the measured point in the
measuring system's frame; --robot (a library robot or a robot file) the nominal flange (tool0)
pose in the robot base frame. --model, the offline contract's spelling, takes either.

A result that carries a residual model (`calibrate --residual-model`) adds its correction to each
position, and the file gains the columns dx, dy, dz (the correction, mm), std_mm (its predictive
standard deviation per component, 1 sigma) and note (joints beyond the residual model's reach:
no correction there).
"""

from __future__ import annotations

import argparse
import sys

OUTPUT_COLUMNS = ("id", "x", "y", "z", "rx", "ry", "rz")
RESIDUAL_COLUMNS = ("dx", "dy", "dz", "std_mm", "note")  # with a residual model only


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from screwcal.arguments import check_outputs
    from screwcal.calibration.measurements import check_joint_units
    from screwcal.calibration.residual_model import residual_from_document
    from screwcal.commands.joint_convention import joint_convention
    from screwcal.commands.payload import with_payload
    from screwcal.kinematics.forward import forward_kinematics
    from screwcal.kinematics.modelfile import parse_model, read_model_document, resolve_model
    from screwcal.kinematics.pose import pose_from_transform
    from screwcal.kinematics.readings import serial_from_readings
    from screwcal.tables import (
        counted,
        fixed_texts,
        joint_columns,
        read_numeric_csv,
        write_csv_atomic,
    )

    given = args.result or args.robot or args.model
    check_outputs([args.out], [args.joints, given])
    document = read_model_document(args.result) if args.result else _document(given)
    model = with_payload(resolve_model(given) if document is None else
                         parse_model(document, given), args)
    table = read_numeric_csv(args.joints, joint_columns(model.n_joints))
    q_read = np.where(model.is_revolute, np.degrees(table.values), table.values) \
        if args.joint_unit == "rad" else table.values
    check_joint_units(table.path, model, q_read, args.joint_unit)
    q_deg = serial_from_readings(q_read, joint_convention(args, document, model))
    outside = np.logical_not(model.within_limits(model.joints_from_deg(q_deg)))
    for k in np.flatnonzero(outside)[:5]:
        print(f"warning: {table.path}, line {table.lines[k]}: joints outside the limits of model "
              f"'{model.name}' (predicted anyway)", file=sys.stderr)
    q_rad = model.joints_from_deg(q_deg)
    poses = pose_from_transform(forward_kinematics(model, q_rad))
    residual = residual_from_document(document, str(given)) if args.result or args.model \
        else None
    if residual is None:
        write_csv_atomic(args.out, OUTPUT_COLUMNS, (
            [pid, *fixed_texts(pose, 6)] for pid, pose in zip(table.ids, poses, strict=True)))
        print(f"predicted {counted(len(poses), 'pose')} with model '{model.name}' -> {args.out}")
        return 0
    seen = residual.predict(q_rad)
    poses[:, :3] += seen.correction_mm
    for k in np.flatnonzero(~seen.within_reach)[:5]:
        print(f"note: {table.path}, line {table.lines[k]}: {seen.note(int(k))}", file=sys.stderr)
    write_csv_atomic(args.out, OUTPUT_COLUMNS + RESIDUAL_COLUMNS, (
        [pid, *fixed_texts([*pose, *d, s], 6), seen.note(k)]
        for k, (pid, pose, d, s) in enumerate(zip(table.ids, poses, seen.correction_mm,
                                                  seen.std_mm, strict=True))))
    print(f"predicted {counted(len(poses), 'pose')} with model '{model.name}' and its "
          f"{seen.summary()} -> {args.out}")
    return 0


def _document(given: str) -> object:
    """The JSON document of a robot, model or result file; None for a library robot's name
    (or what is neither: `resolve_model` says so)."""
    from pathlib import Path

    from screwcal.kinematics.modelfile import read_model_document
    from screwcal.kinematics.robots import BUILTIN_MODELS

    if given in BUILTIN_MODELS or not Path(given).is_file():
        return None
    return read_model_document(given)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("predict", help="predict measured-point poses from joint readings",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--result", metavar="FILE",
                       help="calibration result, or calibrated model file: the measured point "
                       "in the measuring frame")
    which.add_argument("--robot", metavar="NAME|FILE",
                       help="library robot (screwcal robot list) or robot file: the nominal "
                       "flange in the robot base frame")
    which.add_argument("--model", metavar="NAME|FILE",
                       help="the offline contract's spelling: a result or model file, or a "
                       "library robot's name")
    p.add_argument("--joints", required=True, help="CSV with q1..q6 in degrees, optional id")
    p.add_argument("--joint-unit", choices=["deg", "rad"], default="deg",
                   help="unit of the file's q1..q6 (default deg; readings that look like "
                   "radians are refused), as calibrate's")
    p.add_argument("--out", required=True, help="CSV to write: id, x, y, z (mm), rx, ry, rz (deg)")
    from screwcal.arguments import add_payload_arguments
    from screwcal.commands.joint_convention import add_joint_convention

    add_joint_convention(p, "how the file's q1..q6 count joint 3")
    add_payload_arguments(p)
    p.set_defaults(func=run)
