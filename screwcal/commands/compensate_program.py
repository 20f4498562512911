"""`screwcal compensate --program FILE...`: a robot program of any maker compensated, the
language chosen by extension and content (RAPID .mod/.prg/.sys as `--rapid`; KUKA .src/.dat
with `--config $config.dat`; FANUC .ls with `--frames FILE`; URScript .script)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from screwcal.calibration.residual_model import ResidualModel
    from screwcal.kinematics.model import SerialModel

PARTIAL_EXIT = 3  # as compensate's: some targets not compensated (listed), the others written
RAPID_SUFFIXES = (".mod", ".prg", ".sys", ".modx", ".sysx")


def _read(path: str, what: str) -> str:
    from screwcal.errors import DataFileError

    p = Path(path)
    if p.is_dir():
        raise DataFileError(path, f"is a folder; give the {what} file")
    try:
        raw = p.read_bytes()
    except OSError as err:
        raise DataFileError(path, f"cannot read the {what} ({err.strerror})") from None
    return raw.decode("latin-1")  # 8-bit program files: every byte round-trips


def is_rapid(paths: list[str]) -> bool:
    """Whether `--program` names RAPID: modules (.mod, .prg, .sys...) or a task's folder (the
    RAPID filter takes them all together, as `--rapid`)."""
    return all(Path(p).is_dir() or Path(p).suffix.lower() in RAPID_SUFFIXES for p in paths)


def outputs(paths: list[str], out: str) -> dict[str, Path]:
    """Where each compensated file goes: --out itself for one file, else --out is a folder
    (made if missing) receiving each file under its own name."""
    from screwcal.errors import DataFileError

    target = Path(out)
    if len(paths) == 1 and not target.is_dir():
        return {paths[0]: target}
    names = [Path(p).name for p in paths]
    if len(set(names)) != len(names):
        raise DataFileError(out, "two programs have the same file name: compensate them apart")
    if target.exists() and not target.is_dir():
        raise DataFileError(out, f"{len(paths)} files are compensated: --out must be a folder")
    return {p: target / Path(p).name for p in paths}


def run_program(args: argparse.Namespace, calibrated: SerialModel, nominal: SerialModel,
                residual: ResidualModel | None) -> int:
    """Compensate the files of `--program` and write them; the exit status of compensate."""
    from screwcal.arguments import check_outputs
    from screwcal.calibration.program_filter import filter_program
    from screwcal.errors import DataFileError
    from screwcal.programs import ProgramSyntaxError, read_program
    from screwcal.runtime.policy import collection_paused
    from screwcal.tables import write_text_atomic

    paths = list(args.program)
    where = outputs(paths, args.out)
    if len(where) > 1 or Path(args.out).is_dir():
        Path(args.out).mkdir(parents=True, exist_ok=True)
    check_outputs(where.values(), [args.result, *paths, args.config, args.frames])
    texts = {p: _read(p, "program") for p in paths}
    config = (args.config, _read(args.config, "$config.dat")) if args.config else None
    frames = (args.frames, _read(args.frames, "frames")) if args.frames else None
    with collection_paused():  # the program's tree lives through the filter: no cycle in it,
        try:  # nothing for the collector's passes over it (10,000 targets: ~70 ms of them)
            program = read_program(texts, config=config, frames=frames)
        except ProgramSyntaxError as err:
            raise DataFileError(err.path, f"line {err.line}: {str(err).split(': ', 1)[1]}") \
                from None
        out, report = filter_program(program, calibrated, nominal,
                                     start_deg=args.start_joints, residual=residual)
        del program  # freed here, not gone through once more by the collector it resumes
    if report.compensated == 0:
        print(report.summary(), file=sys.stderr)
        raise DataFileError(paths[0], "no target compensated; nothing written")
    for p, dest in where.items():
        write_text_atomic(str(dest), out[p].encode("latin-1"))
    print(f"{', '.join(paths)} -> {', '.join(str(d) for d in where.values())}: "
          f"{report.summary()}")
    return 0 if report.complete else PARTIAL_EXIT


def add_program_arguments(c: argparse.ArgumentParser) -> None:
    c.add_argument("--config", metavar="$config.dat", help="--program, KUKA: the controller's "
                   "$config.dat (TOOL_DATA[n], BASE_DATA[n])")
    c.add_argument("--frames", metavar="FILE", help="--program, FANUC: user and tool frames, "
                   "lines 'UF,n,x,y,z,w,p,r' and 'UT,n,x,y,z,w,p,r' (mm, deg)")
    c.add_argument("--start-joints", metavar="J1,...,J6", type=_joints, default=None,
                   help="--program: the joints (deg) the robot stands at when the program "
                   "starts; a target without configuration flags (URScript, KUKA FRAME) takes "
                   "the solution nearest the one before it, the first nearest these "
                   "(default all zeros)")


def _joints(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"six numbers (deg) separated by commas, got "
                                         f"{text!r}") from None
    if len(values) != 6:
        raise argparse.ArgumentTypeError(f"six joints (deg), got {len(values)}")
    return values
