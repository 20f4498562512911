"""`screwcal compensate` (COMPENSATE_DOC is its --help): targets and RAPID programs made to take
the calibrated robot where they ask; docs/formats.md."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from screwcal.arguments import add_option, add_payload_arguments, check_outputs
from screwcal.commands.compensate_program import add_program_arguments
from screwcal.commands.joint_convention import add_joint_convention, joint_convention
from screwcal.commands.payload import with_payload

if TYPE_CHECKING:
    from screwcal.calibration.correction import Compensation
    from screwcal.calibration.residual_model import ResidualModel
    from screwcal.commands.target_branches import BranchChoice
    from screwcal.kinematics.model import SerialModel
    from screwcal.kinematics.se3 import Array
    from screwcal.tables import NumericTable

PARTIAL_EXIT = 3  # some targets refused (listed), the others written

COMPENSATE_DOC = """`screwcal compensate`: make the calibrated robot reach what is asked of it.

    screwcal compensate --result result.json --rapid IN.mod --out OUT.mod [--tool T] [--wobj W]
    screwcal compensate --result result.json --rapid TASK1/ --out OUT_FOLDER
    screwcal compensate --result result.json --program prog.src prog.dat \
        --config '$config.dat' --out compensated/
    screwcal compensate --result result.json --program cell.ls --frames frames.csv --out out.ls
    screwcal compensate --result result.json --program cell.script --out out.script
    screwcal compensate --result result.json --targets base.csv --out compensated.csv
    screwcal compensate --result result.json --measuring-targets meas.csv \
        --out compensated.csv

--rapid rewrites every robtarget (declared alone, in arrays, in RECORD data and arrays of
records) so that the nominal controller drives the joints to where the
calibrated robot reaches the original target (confdata recomputed), keeps the rest of the file
byte for byte (a controller's %%% header too), and lists what a static filter cannot compensate
(Offs, RelTool, CRobT, inline targets, stationary tools, moving work objects, a [0,0,0,0]
placeholder orientation) with its line. Each target is solved in the tool and work object of the
instructions that move to it: the Move, Trigg, Search, Arc, Cap, Spot, Paint and Disp families
(MoveC's and the circular ones' two points). --program does the same for KUKA KRL, FANUC LS
and URScript programs (docs/formats.md: each maker's conventions). --targets takes tool0 poses in
the robot base frame (what a program commands); --measuring-targets poses of the measured point
in the measuring system's frame (what the measuring system will see). A pose file carries no
arm configuration: each target is solved on the nominal robot's branch nearest the joints of
the target before it (the first: nearest home), and the command says which branch each took and
where and why it changed.

Exit status: 0 every target compensated; 3 some refused or not compensated statically (each
listed with its line and why; the others are written); 2 nothing written: no target could be
compensated, the input is not a program, --out names an input, or the model is
position-only (calibrated from positions of a point on joint 6's axis: it does not know the
orientation).
A target at the wrist singularity is solved with joints 4 and 6 kept nearest the nominal
solution.

A result that carries a residual model (`calibrate --residual-model`) compensates for it too:
each target is moved back by the residual's correction where the robot will be; the targets'
CSV gains the columns dx, dy, dz (the correction, mm, in the targets' frame), std_mm (its
predictive standard deviation per component) and note (a target beyond the residual model's
reach in joint space gets no correction), and --rapid says the corrections' size.
"""


def run_compensate(args: argparse.Namespace) -> int:
    from screwcal.commands.compensate_program import is_rapid, run_program
    from screwcal.kinematics.modelfile import parse_model, read_model_document

    if args.program and is_rapid(args.program):
        args.rapid, args.program = list(args.program), None
    source = args.targets or args.measuring_targets
    if args.rapid:
        args.rapid_outputs = _rapid_outputs(args.rapid, args.out)
        check_outputs(args.rapid_outputs.values(), [args.result, *args.rapid_outputs])
    elif not args.program:  # a program's outputs are checked file by file (run_program)
        check_outputs([args.out], [args.result, source])
    document = read_model_document(args.result)
    calibrated = with_payload(parse_model(document, args.result), args)  # a payload other than
    # the result's
    nominal = nominal_of(document, args.result, args.robot) or calibrated
    _refuse_position_only(document, args.result)
    residual = _residual_of(document, args.result)
    if args.rapid:
        return _compensate_rapid(args, calibrated, nominal, residual)
    if args.program:
        return run_program(args, calibrated, nominal, residual)
    from screwcal.commands.target_branches import branch_note, choose_branches
    from screwcal.errors import DataFileError
    from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
    from screwcal.tables import (
        counted,
        fixed_texts,
        joint_columns,
        read_numeric_csv,
        write_csv_atomic,
    )

    frame: Literal["base", "measuring"] = "base" if args.targets else "measuring"
    table = read_numeric_csv(source, ["x", "y", "z", "rx", "ry", "rz"])
    check_target_units(table, nominal, frame)
    T = transform_from_pose(table.take(["x", "y", "z", "rx", "ry", "rz"]))
    choice = choose_branches(nominal, T if frame == "base" else flange_targets(calibrated, T))
    comp = compensate_on(calibrated, nominal, T, choice, frame=frame, residual=residual)
    ok = comp.ok
    for k, why in comp.refused:
        print(f"refused: {table.path}, line {table.lines[k]} (id {table.ids[k]}): {why}",
              file=sys.stderr)
    if not ok.any():
        raise DataFileError(table.path, f"no target compensated ({len(comp.refused)} refused, "
                            f"listed above); {args.out} not written")
    from screwcal.kinematics.readings import readings_from_serial

    convention = joint_convention(args, document, nominal)
    q_deg = readings_from_serial(calibrated.joints_to_deg(comp.q_rad), convention)
    poses = pose_from_transform(comp.nominal_tool0)
    header = ["id", *joint_columns(calibrated.n_joints), "x", "y", "z", "rx", "ry", "rz"]
    rows = [[i, *fixed_texts(q, 4), *fixed_texts(p, 4)]
            for i, q, p in zip(table.ids, q_deg, poses, strict=True)]
    seen = comp.residual
    if seen is not None:
        shift = seen.correction_mm if frame == "measuring" else \
            seen.correction_mm @ calibrated.base[:3, :3]
        header += ["dx", "dy", "dz", "std_mm", "note"]
        for k, row in enumerate(rows):
            row += [*fixed_texts([*shift[k], seen.std_mm[k]], 4), seen.note(k)]
    write_csv_atomic(args.out, header, (row for row, good in zip(rows, ok, strict=True)
                                        if good))
    where = "tool0 in the robot base frame" if frame == "base" else \
        "measured point in the measuring frame"
    print(f"compensated {int(ok.sum())} of {len(ok)} targets ({where}) -> {args.out}: joint "
          f"targets, and the nominal tool0 poses of model '{nominal.name}' to program; largest "
          f"joint change from the nominal robot's solution {comp.max_change_deg:.3f} deg"
          + ("; joint 3 as FANUC counts it (to the horizontal)" if convention == "fanuc"
             else "") + ("" if seen is None else f"; {seen.summary()}"))
    print(branch_note(choice, table.ids, table.lines, comp.q_rad, ok))
    if comp.refused:
        print(f"{counted(len(comp.refused), 'target')} refused (listed on stderr), not in "
              f"{args.out}")
        return PARTIAL_EXIT
    return 0


NEAR_MM = 5.0  # measuring targets (3 or more) all this close together: the numbers are metres


def check_target_units(table: NumericTable, nominal: SerialModel,
                       frame: Literal["base", "measuring"]) -> None:
    """Refuse (DataFileError naming the file and columns, with the fix) target poses whose
    numbers look like another unit than mm and degrees, as calibrate's reader does: angles
    rx, ry, rz that all lie within +-RADIAN_LOOKING_DEG (radians; two rows or more, not all
    equal); positions x, y, z that look like metres or inches: in the robot base frame, every
    target nearer the base than a fifteenth of the farthest the nominal flange gets from it
    (its reach, the wrist's offset and axis 1's: inside the robot's own base), and another
    unit bringing them within that; in the
    measuring frame, three or more targets within NEAR_MM of one another."""
    import numpy as np

    from screwcal.errors import DataFileError
    from screwcal.tables import LENGTH_UNITS_MM, RADIAN_LOOKING_DEG

    angles = table.take(["rx", "ry", "rz"])
    if len(angles) >= 2 and np.ptp(angles, axis=0).max() > 0 and \
            np.abs(angles).max() < RADIAN_LOOKING_DEG:
        raise DataFileError(table.path, f"every angle in columns rx, ry, rz lies within "
                            f"+-{RADIAN_LOOKING_DEG:g} deg: they look like radians; convert "
                            "them to degrees")
    p = table.take(["x", "y", "z"])
    if frame == "measuring":
        spread = float(np.linalg.norm(p - p.mean(axis=0), axis=1).max())
        if len(p) >= 3 and 0 < spread < NEAR_MM:
            raise DataFileError(table.path, f"every target in columns x, y, z lies within "
                                f"{spread:.3g} mm of their centre as read (mm): they look like "
                                "metres; convert them to mm")
        return
    from screwcal.kinematics.robots import reach_mm

    wrist = nominal.axis_points_mm[min(4, nominal.n_joints - 1)]
    bound = reach_mm(nominal) + float(np.linalg.norm(nominal.home_flange[:3, 3] - wrist) +
                                      np.linalg.norm(nominal.axis_points_mm[0]))
    farthest = float(np.linalg.norm(p, axis=1).max())
    if farthest >= bound / 15.0:
        return
    fits = [u for u in ("m", "in") if farthest * LENGTH_UNITS_MM[u] <= bound]
    if fits:
        raise DataFileError(table.path, f"every target in columns x, y, z lies within "
                            f"{farthest:.3g} mm of the robot's base as read (mm), inside the "
                            f"robot (the flange of robot '{nominal.name}' reaches up to "
                            f"{bound:.0f} mm from it): "
                            f"they look like {'metres' if fits[0] == 'm' else 'inches'}; "
                            "convert them to mm")


def flange_targets(calibrated: SerialModel, T_measuring: Array) -> Array:
    """Measured-point poses in the measuring frame as flange poses in the robot base frame,
    through the calibrated robot's frames: near enough the nominal robot's to tell its branch."""
    import numpy as np

    return np.linalg.inv(calibrated.base) @ np.asarray(T_measuring, float) @ \
        np.linalg.inv(calibrated.tool)


def compensate_on(calibrated: SerialModel, nominal: SerialModel, T: Array,
                  choice: BranchChoice, *, frame: Literal["base", "measuring"],
                  residual: ResidualModel | None) -> Compensation:
    """Every target with a nominal solution compensated next to it (on its branch and turn);
    the targets without one refused with why (their rows: zeros), never raised."""
    import numpy as np

    from screwcal.calibration.correction import Compensation, compensate
    from screwcal.calibration.residual_model import ResidualPrediction

    idx = np.flatnonzero(choice.found)
    n, N = calibrated.n_joints, len(T)
    refused = [(int(k), choice.why_none[k]) for k in np.flatnonzero(~choice.found)]
    q, tool0, change = np.zeros((N, n)), np.tile(np.eye(4), (N, 1, 1)), np.zeros((N, n))
    seen = None
    if idx.size:
        ref = choice.q_rad[idx]
        if frame == "measuring":  # the calibrated robot's solution on that branch: where the
            # residual model is asked (it moves the targets by what it predicts there)
            from screwcal.kinematics.ik import local_ik

            near, met = local_ik(calibrated, T[idx], ref)
            ref = np.where(met[:, None], near, ref)
        part = compensate(calibrated, nominal, T[idx], ref, frame=frame, strict=False,
                          residual=residual)
        q[idx], tool0[idx] = part.q_rad, part.nominal_tool0
        change[idx] = calibrated.joints_to_deg(part.q_rad - choice.q_rad[idx])
        refused += [(int(idx[k]), why) for k, why in part.refused]
        if part.residual is not None:
            p = part.residual
            correction, std, nearest = np.zeros((N, 3)), np.zeros(N), np.zeros(N)
            correction[idx], std[idx], nearest[idx] = p.correction_mm, p.std_mm, \
                p.nearest_lengths
            seen = ResidualPrediction(correction, std, nearest, p.reach_lengths)
    bad = [k for k, _ in refused]
    q[bad], tool0[bad], change[bad] = 0.0, np.eye(4), 0.0
    return Compensation(q, tool0, change, tuple(sorted(refused)), seen)


def _residual_of(document: object, path: str) -> ResidualModel | None:
    """The residual model the result carries and uses (`residual_from_document`); its module
    (and the Gaussian process's) loaded only for a result with a `residual_model` member."""
    if not (isinstance(document, dict) and isinstance(document.get("residual_model"), dict)):
        return None  # as residual_from_document says of it
    from screwcal.calibration.residual_model import residual_from_document

    return residual_from_document(document, path)


def _refuse_position_only(document: object, path: str) -> None:
    """A model that predicts positions but not the orientation cannot compensate targets that
    carry one (every robtarget and target row does)."""
    from screwcal.errors import DataFileError

    predicts = document.get("predicts") if isinstance(document, dict) else None
    why = predicts.get("orientation_unknown") if isinstance(predicts, dict) else None
    if why:
        raise DataFileError(path, f"the model is position-only ({why}): it cannot compensate "
                            "targets with an orientation; calibrate with full-pose data or a "
                            "measured point off joint 6's axis")


def nominal_of(doc: object, result_path: str, robot: str | None) -> SerialModel | None:
    """The nominal robot a result was calibrated against: `--robot` when given, else the
    result's own `nominal_model`, else (older results) its robot's library name; None for a
    model file that names none."""
    from screwcal.errors import ModelError
    from screwcal.kinematics.modelfile import parse_model, resolve_model
    from screwcal.kinematics.robots import BUILTIN_MODELS, accepted_robots

    if robot:
        given = resolve_model(robot)
        own = nominal_of(doc, result_path, None)
        if own is not None and not _same_robot(own, given):
            raise ModelError(f"{result_path} was calibrated against robot '{own.name}', and "
                             f"--robot {robot} is another robot ('{given.name}'): leave out "
                             "--robot (the result holds the robot it was calibrated against)")
        return given
    if not isinstance(doc, dict):
        return None
    if isinstance(doc.get("nominal_model"), dict):
        return parse_model(doc["nominal_model"], f"{result_path}, nominal_model")
    name = doc.get("robot")
    if not name:
        return None
    if name not in BUILTIN_MODELS:
        raise ModelError(f"{result_path} was calibrated against robot '{name}', which is not in "
                         "the library, and (written before results carried their robot) does "
                         "not hold its nominal model: give --robot FILE, the robot file it was "
                         f"calibrated with; --robot takes {accepted_robots()}")
    return resolve_model(name)


def _same_robot(a: SerialModel, b: SerialModel) -> bool:
    """Whether two nominal robots are one robot: as many joints, and their flanges within
    1 mm at three joint sets (names aside: an imported robot may be named otherwise)."""
    import numpy as np

    from screwcal.kinematics.forward import flange_kinematics

    if a.n_joints != b.n_joints:
        return False
    q = np.array([np.zeros(a.n_joints), np.full(a.n_joints, 0.3), np.full(a.n_joints, -0.2)])
    return bool(np.abs(flange_kinematics(a, q)[:, :3, 3] -
                       flange_kinematics(b, q)[:, :3, 3]).max() < 1.0)


def _rapid_outputs(given: list[str], out: str) -> dict[str, Path]:
    """The modules of the task `--rapid` names (files, or a folder of one task's modules: a
    backup's TASKn, a program folder) and where each compensated one goes: --out itself for
    one module, else the folder --out (made if missing) under each module's own name."""
    from screwcal.commands.compensate_program import outputs
    from screwcal.errors import DataFileError
    from screwcal.rapid.tasks import tasks_in

    files: list[str] = []
    for name in given:
        if Path(name).is_dir():
            tasks = tasks_in(Path(name))
            if len(tasks) != 1:
                raise DataFileError(name, f"holds {len(tasks)} RAPID tasks ("
                                    f"{', '.join(t.name for t in tasks) or 'no module'}): "
                                    "give the folder of one task, or its modules")
            files += [str(m) for m in tasks[0].modules]
        else:
            files.append(name)
    if len(files) == 1:
        return {files[0]: Path(out)}  # a file: checked as every output file is
    if not Path(out).exists():
        Path(out).mkdir()
    return outputs(files, out)


def _compensate_rapid(args: argparse.Namespace, calibrated: SerialModel,
                      nominal: SerialModel, residual: ResidualModel | None = None) -> int:
    """The modules of one task compensated together (a target declared in one module may be
    moved to from another, with a tool a third declares); each written to its output."""
    from screwcal.calibration.rapid_filter import filter_rapid
    from screwcal.calibration.rapid_task import read_rapid_task
    from screwcal.errors import DataFileError
    from screwcal.runtime.policy import collection_paused
    from screwcal.tables import write_text_atomic

    outs: dict[str, Path] = args.rapid_outputs
    sources = []
    for name in outs:
        try:
            raw = Path(name).read_bytes()
        except OSError as err:
            raise DataFileError(name, f"cannot read the RAPID module ({err.strerror})") \
                from None
        sources.append((name, raw.decode("latin-1")))  # RAPID files are 8-bit: every byte
        # round-trips
    with collection_paused():  # the modules' trees live through the filter: no cycle
        modules = read_rapid_task(sources)  # in them, nothing for passes over them
        results = [filter_rapid(m, calibrated, nominal, tool=args.tool, wobj=args.wobj,
                                residual=residual, task=modules) for m in modules]
        unreadable = [(m.path, m.unreadable) for m in modules if m.unreadable]
        del modules  # freed here, not gone through once more by the collector it resumes
    if len(unreadable) == len(outs):  # nothing but encrypted modules: one line says so
        raise DataFileError(*unreadable[0])
    if sum(report.compensated for _, report in results) == 0:
        for _, report in results:
            print(report.summary(), file=sys.stderr)
        raise DataFileError(", ".join(outs), "no robtarget compensated; "
                            f"{args.out} not written")
    partial = False
    for (name, target), (out_text, report) in zip(outs.items(), results, strict=True):
        write_text_atomic(target, out_text.encode("latin-1"))
        print(report.summary().replace(f"{name}:", f"{name} -> {target}:", 1))
        partial |= bool(report.refused or report.not_static)
    return PARTIAL_EXIT if partial else 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    c = sub.add_parser(
        "compensate", help="targets and RAPID programs compensated for the calibrated robot",
        description=COMPENSATE_DOC, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_option(c, "--result", renamed=["--model"], required=True,
               help="calibration result (screwcal calibrate), or a calibrated model file "
               "(screwcal job model)")
    what = c.add_mutually_exclusive_group(required=True)
    what.add_argument("--rapid", metavar="IN.mod", nargs="+", help="RAPID modules of one "
                      "task (files, or the task's folder): every robtarget rewritten in its "
                      "tool and work object; several modules: --out is a folder")
    what.add_argument("--program", metavar="FILE", nargs="+", help="a robot program of any "
                      "maker, by extension and content: RAPID (.mod/.prg/.sys, as --rapid), "
                      "KUKA KRL (.src and .dat; --config), FANUC LS (.ls; --frames), URScript "
                      "(.script); several files of one program: --out is a folder")
    what.add_argument("--targets", metavar="CSV", help="desired tool0 poses in the robot base "
                      "frame: id, x, y, z, rx, ry, rz (mm, deg)")
    what.add_argument("--measuring-targets", metavar="CSV", help="desired poses of the "
                      "measured point in the measuring system's frame: id, x, y, z, rx, ry, rz")
    c.add_argument("--out", required=True, help="the compensated module (--rapid), or a CSV: "
                   "id, q1..q6, x..rz (the nominal tool0 pose to program)")
    c.add_argument("--tool", default="tool0", help="--rapid: the tooldata for targets no motion "
                   "instruction of the module uses (default tool0)")
    c.add_argument("--wobj", default="wobj0", help="--rapid: the wobjdata for those targets "
                   "(default wobj0)")
    c.add_argument("--robot", help="the nominal robot (library name or robot file); default: "
                   "the one the result holds")
    add_program_arguments(c)
    add_joint_convention(c, "how the written joint targets count joint 3")
    add_payload_arguments(c)
    c.set_defaults(func=run_compensate)
