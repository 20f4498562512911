"""`screwcal robot`: the robot library, robot descriptions in, the calibrated robot out.

    screwcal robot list
    screwcal robot show NAME|FILE
    screwcal robot import FILE|NAME [--format json|dh|mdh|screws|urdf] [--base-link LINK]
                         [--tip-link LINK] --out robot.json
    screwcal robot export RESULT.json --format urdf|mdh|dh|screws|json --out FILE

`import` reads a model file in any representation (the templates of docs/robots.md: a DH or
modified DH table, the screw table) or a URDF, checks it, and writes the screwcal robot file
(screw table) that `calibrate --robot` takes. `export` writes a calibrated result's robot (or
any robot or model file's) as a URDF for ROS and offline programming, a (modified) DH table, or
the screw table; each export reads back to the same forward kinematics within 1e-6 mm.
These are offline commands on files; the job service's robot cells are `screwcal job`'s.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from screwcal.commands.joint_convention import add_joint_convention
from screwcal.errors import ModelError

if TYPE_CHECKING:
    from screwcal.kinematics.model import SerialModel
    from screwcal.kinematics.robots import RobotEntry

FORMATS = ("json", "screws", "dh", "mdh", "urdf")


def run_list(args: argparse.Namespace) -> int:
    from screwcal.kinematics.robots import ENTRIES, reach_mm

    print(f"{'name':<13}{'robot':<34}{'reach mm':>9}{'mass kg':>9}")
    for e in ENTRIES:
        print(f"{e.name:<13}{e.title:<34}{reach_mm(e.model()):>9.0f}{e.total_kg:>9.1f}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    import numpy as np

    from screwcal.kinematics.modelfile import resolve_model
    from screwcal.kinematics.pose import pose_from_transform
    from screwcal.kinematics.robots import LIBRARY, reach_mm

    model = resolve_model(args.robot)
    entry = LIBRARY.get(args.robot)
    print(f"{model.name}: {entry.title if entry else args.robot}")
    if entry:
        print(f"  source: {entry.source}")
        print(f"  checked against: {entry.check.text()}")
        if entry.note:
            print(f"  note: {entry.note}")
        print(f"  frames: {entry.frames_text()} (`robot import {entry.name} --base-link NAME`"
              " writes the robot in another)")
    if model.n_joints == 6 and model.is_revolute.all():
        print(f"  reach (wrist centre from axis 1): {reach_mm(model):.1f} mm")
    print("  joint  type  direction              point at home (mm)            limits (deg)"
          "        zero (deg)")
    lim, zero = model.limits_deg, model.joints_to_deg(model.joint_zero)
    for i in range(model.n_joints):
        d, p = model.axis_dirs[i], model.axis_points_mm[i]
        print(f"  {i + 1:>5}  {model.joint_types[i]:>4}  ({d[0]:+.4f}, {d[1]:+.4f}, {d[2]:+.4f})"
              f"  ({p[0]:9.3f}, {p[1]:9.3f}, {p[2]:9.3f})  [{lim[i, 0]:7.1f}, {lim[i, 1]:7.1f}]"
              f"  {zero[i]:+.4f}")
    if model.ratings:
        print("  joints as the description names them: "
              + "; ".join(_rating_text(model, i) for i in range(model.n_joints)))
    fl = pose_from_transform(model.home_flange) + 0.0  # no -0.000
    fl[np.abs(fl) < 5e-4] = 0.0
    print(f"  tool0 at home: x {fl[0]:.3f} y {fl[1]:.3f} z {fl[2]:.3f} mm, rx {fl[3]:.3f} "
          f"ry {fl[4]:.3f} rz {fl[5]:.3f} deg")
    if model.masses:
        print("  lumped masses: " + "; ".join(
            f"{m.kg:.2f} kg moving with joint {m.link + 1} at ({m.home_mm[0]:.0f}, "
            f"{m.home_mm[1]:.0f}, {m.home_mm[2]:.0f}) mm" for m in model.masses)
              + (f" (of the arm's {entry.total_kg:g} kg)" if entry else ""))
    return 0


def _rating_text(model: SerialModel, i: int) -> str:
    """Joint i's name, effort and speed as a description gave them, e.g. 'joint_a1 (150 N m,
    180 deg/s)'."""
    import math

    r, revolute = model.ratings[i], model.joint_types[i] == "R"
    parts = []
    if r.effort:
        parts.append(f"{r.effort:g} {'N m' if revolute else 'N'}")
    if r.velocity:
        parts.append(f"{math.degrees(r.velocity):.4g} deg/s" if revolute else
                     f"{r.velocity:.4g} mm/s")
    return f"{i + 1} {r.name or '-'}" + (f" ({', '.join(parts)})" if parts else "")


def run_import(args: argparse.Namespace) -> int:
    import json

    from screwcal.kinematics.describe import read_description
    from screwcal.kinematics.modelfile import model_document, parse_model
    from screwcal.kinematics.robots import LIBRARY
    from screwcal.tables import write_text_atomic

    notes: list[str] = []
    entry = LIBRARY.get(args.file)
    if entry is not None and not Path(args.file).exists():
        if args.tip_link not in (None, "tool0"):
            raise ModelError(f"robot '{entry.name}': the library's chain ends at tool0; "
                             f"--tip-link {args.tip_link} is for URDF files")
        model, form = entry.model_in(args.base_link or entry.frame), "library"
        if args.name:
            model = replace(model, name=args.name)
        notes.append(f"in frame '{args.base_link or entry.frame}'"
                     f"{'' if args.base_link else ' (default; --base-link)'} of the frames "
                     f"{', '.join(n for n, _ in entry.frames)}")
    else:
        model, form = read_description(args.file, args.format, name=args.name,
                                       base_link=args.base_link, tip_link=args.tip_link,
                                       notes=notes)
    text = json.dumps(model_document(model, "screws"), indent=2) + "\n"
    parse_model(json.loads(text), str(args.out))  # what the next command reads: written if valid
    write_text_atomic(args.out, text.encode("utf-8"))
    for note in notes:
        print(f"note: {note}")
    print(f"imported {form} description of '{model.name}' ({model.n_joints} joints"
          f"{', ' + str(len(model.masses)) + ' masses' if model.masses else ''}) -> {args.out}")
    return 0


def _library_robot(given: str, document: object) -> RobotEntry | None:
    """The library robot an export is of: named, or the nominal a result was calibrated
    against when that is the library's own geometry (a robot file named like one is not)."""
    import numpy as np

    from screwcal.kinematics.modelfile import parse_model
    from screwcal.kinematics.robots import LIBRARY

    if given in LIBRARY:
        return LIBRARY[given]
    if not isinstance(document, dict) or document.get("robot") not in LIBRARY or \
            not isinstance(document.get("nominal_model"), dict):
        return None
    entry = LIBRARY[document["robot"]]
    nominal, library = parse_model(document["nominal_model"]), entry.model()
    same = nominal.n_joints == library.n_joints and all(
        np.allclose(getattr(nominal, a), getattr(library, a), atol=1e-9)
        for a in ("axis_dirs", "axis_points_mm", "home_flange"))
    return entry if same else None


def run_export(args: argparse.Namespace) -> int:
    from screwcal.commands.joint_convention import joint_convention
    from screwcal.kinematics.describe import description_text
    from screwcal.kinematics.modelfile import read_model_document, resolve_model
    from screwcal.kinematics.robots import LIBRARY
    from screwcal.tables import write_text_atomic

    model = resolve_model(args.result)
    document = None if args.result in LIBRARY else read_model_document(args.result)
    text, said = description_text(model, args.format, joint_convention(args, document, model),
                                  _library_robot(args.result, document))
    write_text_atomic(args.out, text.encode("utf-8"))
    from screwcal.calibration.residual_model import dropped_by_export

    dropped = dropped_by_export(document, args.format)
    for line in [*said, *([f"note: {dropped}"] if dropped else [])]:
        print(line, file=sys.stderr if line.startswith("warning") else sys.stdout)
    print(f"exported '{model.name}' as {args.format} -> {args.out}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("robot", help="the robot library; robot descriptions in and out",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    a = actions.add_parser("list", help="the library's robots")
    a.set_defaults(func=run_list)
    a = actions.add_parser("show", help="a robot's geometry, limits, masses and sources")
    a.add_argument("robot", metavar="NAME|FILE",
                   help="a library robot, or a robot, model or result file")
    a.set_defaults(func=run_show)
    a = actions.add_parser("import", help="a DH / MDH / screw table or URDF -> robot file")
    a.add_argument("file", metavar="FILE", help="the description (JSON per docs/robots.md, or "
                   "a URDF), or a library robot's name (to write it in another frame)")
    a.add_argument("--format", choices=["json", "dh", "mdh", "screws", "urdf"], default=None,
                   help="what FILE is (default: from its content); dh, mdh and screws are the "
                   "JSON templates of docs/robots.md and are checked to be that representation")
    a.add_argument("--name", default=None, help="the robot's name (default: the file's)")
    a.add_argument("--base-link", default=None, metavar="LINK",
                   help="the frame the robot file is written in: a URDF link (default base_link, "
                   "else the root; 'base' is ROS-Industrial's controller frame: FANUC's World, "
                   "UR's base) or, for a library robot, one of the frames `robot show` lists")
    a.add_argument("--tip-link", default=None, metavar="LINK",
                   help="the URDF link the chain ends at: the flange (default tool0, else "
                   "flange, else the end of the chain with the most moving joints)")
    a.add_argument("--out", required=True, help="the robot file (JSON, screw table) to write")
    a.set_defaults(func=run_import)
    a = actions.add_parser("export", help="a calibrated result's robot as URDF or a table")
    a.add_argument("result", metavar="RESULT", help="a calibration result, or a robot or model "
                   "file, or a library robot")
    a.add_argument("--format", choices=FORMATS, required=True,
                   help="urdf (ROS-Industrial link names, calibrated joint origins), mdh "
                   "(modified DH, Hayati beta for parallel axes), dh (standard DH; refused when "
                   "parallel axes would need huge offsets), screws or json (screwcal's robot "
                   "file)")
    a.add_argument("--out", required=True, help="the file to write")
    add_joint_convention(a, "how the robot's controller reports J3 (fanuc: the URDF carries "
                         "the J2/J3 coupling so that its joint values are the controller's)")
    a.set_defaults(func=run_export)
