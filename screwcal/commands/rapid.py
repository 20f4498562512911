"""`screwcal rapid check`: RAPID modules checked before they go on a controller.

    screwcal rapid check MainModule.mod Common.sys [--known g_GripIn,g_GripOut]

The files are checked together as the modules of one task (a routine of one may be called from
another). Each finding is a line `file:line:col: kind: reason`, kind one of syntax, unknown,
argument, type, string; the exit status is 0 only when no file has a finding (1 when some have,
2 when a file cannot be read).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def run_check(args: argparse.Namespace) -> int:
    from screwcal.errors import DataFileError
    from screwcal.rapid.check import check_modules

    sources = []
    for name in args.files:
        try:
            raw = Path(name).read_bytes()
        except OSError as err:
            raise DataFileError(name, f"cannot read the RAPID module ({err.strerror})") from None
        sources.append((name, raw.decode("latin-1")))  # RAPID files are 8-bit
    known = [k.strip() for k in ",".join(args.known).split(",") if k.strip()]
    findings = check_modules(sources, known)
    for f in findings:
        print(f)
    files = {f.path for f in findings}
    print(f"{len(sources)} module{'s' if len(sources) != 1 else ''} checked: "
          + (f"{len(findings)} finding{'s' if len(findings) != 1 else ''} in {len(files)}"
             if findings else "no findings"), file=sys.stderr)
    return 1 if findings else 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("rapid", help="check RAPID modules (.mod, .sys)", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    rapid = p.add_subparsers(dest="rapid_command", metavar="ACTION", required=True)
    c = rapid.add_parser("check", help="syntax, unknown names, arguments, types, long strings",
                         description=__doc__,
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    c.add_argument("files", nargs="+", metavar="FILE", help="RAPID modules (.mod, .sys)")
    c.add_argument("--known", action="append", default=[], metavar="NAMES",
                   help="comma-separated routines defined elsewhere (other modules of the "
                   "task, options such as a gripper's): not reported as unknown")
    c.set_defaults(func=run_check)
