"""`screwcal rapid check`: RAPID modules checked before they go on a controller.

    screwcal rapid check MainModule.mod Common.sys [--known g_GripIn,g_GripOut]
    screwcal rapid check BACKUP_DIR [--options socket-messaging,arc,egm]

The files given are checked together as the modules of one task (a routine of one may be
called from another). A folder is searched for tasks: each TASKn folder of a backup (its
PROGMOD and SYSMOD modules together), or each folder of modules (with the system modules
elsewhere in a tree without TASKn folders, a controller's HOME: their routines known). Each
finding is a line `file:line:col: kind: reason`, kind one of syntax, unknown, option (a name a
RobotWare option not selected brings), argument, type, string, and the notes placeholder,
encrypted and unverified (a name only an encrypted module of the task may define). --options
names the controller's RobotWare options (default: those of a calibration cell:
socket-messaging, pc-interface, multitasking, collision-detection, world-zones; `--options
+arc,+egm` adds to them, `--options none` for the base system alone). The exit status is 0 when
no module has a finding other than a note (1 when some have, 2 when a file or folder cannot be
read).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _read(name: Path) -> tuple[str, str]:
    from screwcal.errors import DataFileError

    try:
        raw = name.read_bytes()
    except OSError as err:
        raise DataFileError(str(name), f"cannot read the RAPID module ({err.strerror})") \
            from None
    return str(name), raw.decode("latin-1")  # RAPID files are 8-bit


def _options(args: argparse.Namespace) -> list[str]:
    from screwcal.errors import InputError
    from screwcal.rapid.names import CALIBRATION_CELL, option_keys

    if not args.options:
        return list(CALIBRATION_CELL)
    keys = [k.strip().lower() for k in ",".join(args.options).split(",") if k.strip()]
    if keys == ["none"]:
        return []
    if all(k.startswith("+") for k in keys):  # added to a calibration cell's
        keys = [*CALIBRATION_CELL, *(k[1:] for k in keys)]
    unknown = [k for k in keys if k not in option_keys()]
    if unknown:
        raise InputError(f"--options: unknown RobotWare option '{unknown[0]}'; known: "
                         f"{', '.join(option_keys())}, or none")
    return keys


def run_check(args: argparse.Namespace) -> int:
    from screwcal.errors import DataFileError
    from screwcal.rapid.check import check_modules
    from screwcal.rapid.tasks import tasks_in

    options = _options(args)
    known = [k.strip() for k in ",".join(args.known).split(",") if k.strip()]
    groups: list[tuple[str, list[tuple[str, str]], list[tuple[str, str]]]] = []
    files: list[tuple[str, str]] = []
    for name in map(Path, args.files):
        if name.is_dir():
            tasks = tasks_in(name)
            if not tasks:
                raise DataFileError(str(name), "no RAPID module (.mod, .modx, .sys, .sysx) in "
                                    "this folder nor below it")
            groups += [(f"task {t.name}", [_read(m) for m in t.modules],
                        [_read(m) for m in t.context]) for t in tasks]
        else:
            files.append(_read(name))
    if files:
        groups.insert(0, ("the files given", files, []))
    failed, n_modules, n_findings, paths = False, 0, 0, set()
    for title, sources, context in groups:
        findings = check_modules(sources, known, options, context)
        for f in findings:
            print(f)
        errors = [f for f in findings if not f.is_note]
        failed |= bool(errors)
        n_modules += len(sources)
        n_findings += len(errors)
        paths |= {f.path for f in errors}
        if len(groups) > 1:
            print(f"{title}: {len(sources)} module{'s' if len(sources) != 1 else ''}, "
                  f"{len(errors)} finding{'s' if len(errors) != 1 else ''}"
                  + (f" and {len(findings) - len(errors)} notes" if len(findings) > len(errors)
                     else ""), file=sys.stderr)
    print(f"{n_modules} module{'s' if n_modules != 1 else ''} checked: "
          + (f"{n_findings} finding{'s' if n_findings != 1 else ''} in {len(paths)}"
             if n_findings else "no findings"), file=sys.stderr)
    return 1 if failed else 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("rapid", help="check RAPID modules (.mod, .sys)", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    rapid = p.add_subparsers(dest="rapid_command", metavar="ACTION", required=True)
    c = rapid.add_parser("check", help="syntax, unknown names, arguments, types, long strings",
                         description=__doc__,
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    c.add_argument("files", nargs="+", metavar="FILE|DIR",
                   help="RAPID modules (.mod, .sys) of one task, or folders (a backup, a "
                   "program) whose tasks are each checked")
    c.add_argument("--known", action="append", default=[], metavar="NAMES",
                   help="comma-separated routines and data types defined elsewhere (a "
                   "gripper's package): not reported as unknown")
    c.add_argument("--options", action="append", default=[], metavar="KEYS",
                   help="comma-separated RobotWare options of the controller (default: a "
                   "calibration cell's; '+arc': added to those; 'none': the base system "
                   "alone)")
    c.set_defaults(func=run_check)
