"""`screwcal job measure`: another instrument's measurement of the pose a job waits for, sent
to the service (POST /jobs/ID/measurement) from a JSON file or from arguments.

    screwcal job measure 12 --point-mm 812.41 -20.07 633.90 --u95-mm 0.03
    screwcal job measure 12 --file pose.json      # {"phase", "index", "points_mm", ...}
    screwcal job measure 12 --export pose.csv [--names P1 P2 P3] [--length-unit m]

Without --phase and --index the pose is the one the job waits for now (its measurement_for);
without --time-s the measurement is stamped now. A JSON file holds the route's body: phase,
index, points_mm, covariance_mm2 or u95_mm, time_s, conditions (what a SpatialAnalyzer,
PolyWorks or FARO/API SDK script writes). An --export is a point export as `screwcal calibrate
--data` reads one (X, Y, Z, optionally U95 and a name column; SpatialAnalyzer's, PolyWorks'):
its points in their order, or those --names names, in that order.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from screwcal.arguments import add_vector, positive_int
from service.errors import ServiceError

if TYPE_CHECKING:
    from service.operator import Operator


def add_measure_parser(actions: argparse._SubParsersAction,
                       common: argparse.ArgumentParser) -> None:
    m = actions.add_parser("measure", parents=[common], description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter,
                           help="post the measurement of the pose a job waits for (another "
                           "instrument's)")
    m.add_argument("id", type=positive_int, help="the job's id (screwcal job list)")
    m.add_argument("--file", help="a JSON file with the measurement ('-': standard input)")
    m.add_argument("--export", help="a point export (X, Y, Z[, U95], a name column) as "
                   "screwcal calibrate --data reads it")
    m.add_argument("--names", nargs="+", metavar="NAME",
                   help="with --export: the points to send, in the robot record's order")
    m.add_argument("--length-unit", choices=["mm", "m", "in"], default="mm",
                   help="with --export: the unit of its X, Y, Z and U95 (default mm)")
    m.add_argument("--phase", help="the pose's list (default: the pose the job waits for)")
    m.add_argument("--index", type=int, help="the pose's index (default: as --phase)")
    for k, which in enumerate(("first", "second", "third")):
        add_vector(m, f"--point{k + 1 if k else ''}-mm", help=f"the {which} target measured, "
                   "mm (the robot record's targets, in their order)")
    m.add_argument("--u95-mm", action="append", type=float, metavar="U",
                   help="a target's expanded uncertainty at 95 %% (k = 2), mm, once per point")
    m.add_argument("--time-s", type=float, help="when it was measured (Unix s; default now)")


def measurement_body(args: argparse.Namespace, op: Operator) -> dict[str, Any]:
    """The route's body from the file or the arguments; the pose the job waits for filled in
    when not named."""
    body: dict[str, Any] = {}
    if args.file is not None:
        try:
            text = sys.stdin.read() if args.file == "-" else \
                Path(args.file).read_text(encoding="utf-8")
            body = json.loads(text)
        except OSError as err:
            raise ServiceError(f"cannot read {args.file}: {err.strerror}") from None
        except json.JSONDecodeError as err:
            raise ServiceError(f"{args.file}: not JSON (line {err.lineno}: {err.msg})") \
                from None
        if not isinstance(body, dict):
            raise ServiceError(f"{args.file}: a JSON object with phase, index, points_mm, ...")
    if args.export is not None:
        body |= _from_export(args.export, args.names, args.length_unit)
    points = [p for p in (args.point_mm, args.point2_mm, args.point3_mm) if p is not None]
    if points:
        body["points_mm"] = [list(p) for p in points]
    if args.u95_mm:
        body["u95_mm"] = list(args.u95_mm)
    if "points_mm" not in body:
        raise ServiceError("no points: give --point-mm X Y Z (and --point2-mm, --point3-mm for "
                           "three targets), --file or --export")
    if args.phase is not None:
        body["phase"] = args.phase
    if args.index is not None:
        body["index"] = args.index
    if "phase" not in body or "index" not in body:
        wanted = op.job(args.id).get("measurement_for")
        if wanted is None:
            raise ServiceError(f"job {args.id} waits for no measurement now: name the pose "
                               "with --phase and --index")
        body.setdefault("phase", wanted["phase"])
        body.setdefault("index", wanted["index"])
    body.setdefault("time_s", time.time() if args.time_s is None else args.time_s)
    return body


def _from_export(path: str, names: list[str] | None, length_unit: str) -> dict[str, Any]:
    """points_mm (and u95_mm) from a point export, in its order or in the order of `names`."""
    from screwcal.calibration.point_export import read_point_export

    export = read_point_export(path, length_unit)
    rows = list(range(len(export.names)))
    if names:
        missing = [n for n in names if n not in export.names]
        if missing:
            raise ServiceError(f"{path}: no point named {', '.join(missing)} (its points: "
                               f"{', '.join(export.names[:12])})")
        rows = [export.names.index(n) for n in names]
    out: dict[str, Any] = {"points_mm": export.points_mm[rows].tolist()}
    if export.u95_mm is not None:
        out["u95_mm"] = export.u95_mm[rows].tolist()
    return out
