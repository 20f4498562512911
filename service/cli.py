"""`screwcal serve` (the job service) and `screwcal job ...` (the operator's client).

    screwcal serve [--db screwcal.db | postgresql://...] [--host 127.0.0.1] [--port 8080]
                   [--token T]
    screwcal job robot-add --name N --controller HOST:PORT --arm URL [--robot irb1600]
                           (or --tracker HOST[:PORT] [--tracker-stand-mm X Y Z], or --external)
    screwcal job start --robot ID --kind procedure|calibration|performance [--mode STEP]
    screwcal job watch ID        # progress; in STEP mode asks before every move
    screwcal job measure ID --point-mm X Y Z [--u95-mm U] | --file F.json   # another instrument
    screwcal job abort ID
    screwcal job result ID       # the before/after table
    screwcal job report ID --out report.html

The client finds the service in --service or SCREWCAL_SERVICE (default http://127.0.0.1:8080)
and its token in --token or SCREWCAL_TOKEN.
"""

from __future__ import annotations

import argparse
import json
import os
import sqlite3
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from screwcal.arguments import (
    ERROR_MODELS,
    add_option,
    add_vector,
    bounded_float,
    bounded_int,
    check_outputs,
    non_negative_float,
    positive_int,
)
from service.errors import ServiceError
from service.job_state import JobState

if TYPE_CHECKING:  # imported where used: `screwcal --help` pays for neither

    from service.operator import Operator
    from service.settings import ServiceSettings


# -- the service --------------------------------------------------------------------------------
def serve(settings: ServiceSettings, announce: Callable[[str], None] = print) -> int:
    """Run the service until interrupted; announces its URL once bound (port 0: a free one).
    Exit code 1 when it stopped because its database was lost."""
    import asyncio

    from service.server import bind

    server = bind(settings)
    host, port = server.address
    scheme = "https" if settings.tls_cert is not None else "http"
    announce(f"screwcal service on {scheme}://{host}:{port} (database {server.store.label})")
    sys.stdout.flush()
    asyncio.run(server.serve())
    return 1 if server.fatal else 0


def run_serve(args: argparse.Namespace) -> int:
    from service.database import is_postgres_url

    db_key = "db_url" if is_postgres_url(args.db or "") else "db_path"
    if db_key == "db_path" and args.db:
        check_outputs([args.db], [])  # a folder, or a missing folder: refused before binding
        _check_sqlite_file(Path(args.db))
    overrides = {k: v for k, v in ((db_key, args.db), ("host", args.host),
                                   ("port", args.port), ("token", args.token),
                                   ("tls_cert", args.tls_cert), ("tls_key", args.tls_key),
                                   ("insecure_http", args.insecure_http or None))
                 if v is not None}
    from service.settings import ServiceSettings

    settings = ServiceSettings(**overrides)
    if args.admin:
        from service.people_cli import bootstrap_administrator

        bootstrap_administrator(settings, args.admin)
    if settings.token:
        print("warning: the shared token (--token or SCREWCAL_TOKEN) is deprecated: it acts as "
              "an administrator nobody is named as; give people users (`screwcal user add`)",
              file=sys.stderr)
    try:
        return serve(settings)
    except KeyboardInterrupt:
        return 0
    except sqlite3.DatabaseError as err:  # a file that is not a database, or cannot be one
        raise ServiceError(f"{settings.db_path}: cannot be the service's SQLite database "
                           f"({err}); --db names a new file or one `screwcal serve` "
                           "made") from None


def _check_sqlite_file(path: Path) -> None:
    """Refuse an existing file that is not an SQLite database before the service opens it
    (and leaves its lock file beside it): a new file, an empty one or a database is fine."""
    try:
        with path.open("rb") as f:
            head = f.read(16)
    except FileNotFoundError:
        return
    if head and head != b"SQLite format 3\x00":
        raise ServiceError(f"{path}: is not an SQLite database; --db names a new file or one "
                           "`screwcal serve` made")


def _model_argument(model: str) -> str | dict:
    """A built-in robot's name as it is; anything else is a file read on this side and sent as
    a document (the service never opens a path a client names)."""
    from screwcal.kinematics.modelfile import model_document, resolve_model
    from screwcal.kinematics.robots import BUILTIN_MODELS

    return model if model in BUILTIN_MODELS else model_document(resolve_model(model))


def _robots(op: Operator, args: argparse.Namespace) -> None:
    """robot-add and robot-list."""
    if args.action == "robot-add":
        host, _, port = args.controller.rpartition(":")
        if not host or not port.isdigit():
            raise ServiceError(f"--controller is HOST:PORT (e.g. 127.0.0.1:4012), not "
                               f"{args.controller!r}")
        robot = op.add_robot(name=args.name, controller_host=host,
                             controller_port=int(port), instrument=_instrument(args),
                             model=_model_argument(args.robot), serial=args.serial,
                             controller_software=args.controller_software,
                             tool=args.tool, payload_kg=args.payload_kg)
        print(f"robot {robot['id']}: {robot['name']}")
        return
    for r in op.robots():
        ins = r.get("instrument") or {"kind": "arm", "url": r["arm_url"]}
        where = ins.get("url") or (f"{ins['host']}:{ins['port']}" if "host" in ins
                                   else "measurements posted")
        print(f"{r['id']:>4}  {r['name']:<24} controller {r['controller_host']}:"
              f"{r['controller_port']}  {ins['kind']} {where}")


def _instrument(args: argparse.Namespace) -> dict[str, Any]:
    """The robot's instrument from robot-add's --arm, --tracker or --external."""
    if args.arm is not None:
        return {"kind": "arm", "url": args.arm}
    if args.external:
        return {"kind": "external"}
    host, _, port = args.tracker.rpartition(":") if args.tracker.count(":") == 1 else \
        (args.tracker, "", "")
    if port and not port.isdigit():
        raise ServiceError(f"--tracker is HOST[:PORT] (e.g. 10.0.0.5:700), not {args.tracker!r}")
    tracker: dict[str, Any] = {"kind": "tracker", "host": host}
    if port:
        tracker["port"] = int(port)
    if args.tracker_stand_mm:
        tracker["stand_mm"] = list(args.tracker_stand_mm)
    return tracker


def _write(path: str, text: str) -> None:
    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as err:
        raise ServiceError(f"cannot write {path}: {err.strerror}") from None


def _operator(args: argparse.Namespace) -> Operator:
    from service.operator import Operator

    token = args.token or os.environ.get("SCREWCAL_TOKEN", "")
    if not token:
        raise ServiceError("no token: pass --token or set SCREWCAL_TOKEN (the one the service "
                           "was started with)")
    if not token.isprintable() or any(c.isspace() for c in token):
        raise ServiceError("the token has spaces or control characters: check SCREWCAL_TOKEN")
    return Operator(args.service or os.environ.get("SCREWCAL_SERVICE", "http://127.0.0.1:8080"),
                    token)


# The exit status of `job start` (watching) and `job watch`, one meaning each, by where the job
# stands when the command ends (docs/service.md has the table); 2 is a refused command;
# "waiting": for the operator (a move declined in STEP, a ZERO to confirm)
JOB_EXIT_STATUS = {"done": 0, "failed": 1, "waiting": 3, "aborted": 4}
STILL_GOING = 5  # the command ended while the job goes on (paused, running)


def job_exit_status(state: str) -> int:
    return JOB_EXIT_STATUS.get(state, STILL_GOING)


def _watched(op: Operator, job_id: int) -> str:
    """Follow the job; the state it is in when the watch ends: a watch left at a prompt (the
    move declined, an abort asked for) ends with the job waiting or aborted, as the service
    says, not as the prompt left it."""
    state = op.watch(job_id)
    if state == "waiting":  # an abort asked for at the prompt may have ended it
        now = op.job(job_id)["state"]
        return now if JobState(now).finished else "waiting"
    return state


def run_job(args: argparse.Namespace) -> int:
    if args.action in ("model", "report"):
        check_outputs([args.out], [])  # before the service is asked
    with _operator(args) as op:
        return _run_job(op, args)


def _run_job(op: Operator, args: argparse.Namespace) -> int:
    import httpx

    from service.result_text import result_table

    try:
        if args.action in ("robot-add", "robot-list"):
            _robots(op, args)
        elif args.action == "list":
            for j in op.jobs():
                print(f"{j['id']:>4}  robot {j['robot_id']:<4} {j['kind']:<12} {j['mode']:<5} "
                      f"{j['state']:<8} {j.get('reason') or ''}".rstrip())
        elif args.action == "start":
            if args.mode == "STEP" and not args.no_watch and not sys.stdin.isatty():
                raise ServiceError("a STEP job asks before every move, and there is no terminal "
                                   "to answer: run it from a terminal, or start it with "
                                   "--no-watch and answer with `screwcal job watch ID` there")
            options: dict[str, Any] = {"cycles": args.cycles,
                                       "calibration_poses": args.poses,
                                       "cube_edge_mm": args.cube_edge_mm,
                                       "model": args.error_model,
                                       "correction": args.correction}
            if args.arm_position_mm:
                options["arm_position_mm"] = list(args.arm_position_mm)
            if args.frame_from_job:
                options["frame_from_job"] = args.frame_from_job
            options |= _model_options(args)
            job = op.start(robot_id=op.robot_id(args.robot), kind=args.kind, mode=args.mode,
                           options=options)
            print(f"job {job['id']} started ({job['kind']}, {job['mode']})")
            if not args.no_watch:
                state = _watched(op, job["id"])
                print(result_table(op.result(job["id"])))
                return job_exit_status(state)
        elif args.action == "watch":
            if JobState(op.job(args.id)["state"]).finished:
                print(result_table(op.result(args.id)))  # finished: its summary, no replay
                return job_exit_status(op.job(args.id)["state"])
            return job_exit_status(_watched(op, args.id))
        elif args.action == "history":
            from service.history import RobotHistory, history_text

            history = RobotHistory.model_validate(op.history(op.robot_id(args.robot)))
            print(history_text(history))
            return 2 if history.alarm is not None else 0
        elif args.action == "measure":
            from service.measure_cli import measurement_body

            body = measurement_body(args, op)
            answer = op.measure(args.id, body)
            print(f"job {args.id}: {answer['phase']} pose {answer['index']}: "
                  f"{answer['outcome']}")
        elif args.action == "abort":
            op.abort(args.id)
            print(f"job {args.id}: abort requested")
        elif args.action == "result":
            print(result_table(op.result(args.id)))
        elif args.action == "model":
            doc = op.model(args.id, args.round)
            _write(args.out, json.dumps(doc, indent=2) + "\n")
            print(f"job {args.id}: calibrated model -> {args.out} ({doc.get('model_note', '')}; "
                  "read by screwcal predict, compensate and compensate --rapid)")
        elif args.action == "report":
            _write(args.out, op.report(args.id))
            print(f"report -> {args.out}")
    except httpx.HTTPError as err:
        raise ServiceError(f"cannot reach the service at {op.http.base_url} ({err}): start it "
                           "with `screwcal serve`, or name where it runs with --service or "
                           "SCREWCAL_SERVICE") from None
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser("serve", help="run the job service (REST; SQLite or PostgreSQL)",
                       description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_serve_arguments(s)
    s.set_defaults(func=run_serve)

    j = sub.add_parser("job", help="operate jobs on a running service", description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    j.add_argument("--service", default=None, help="service URL (or SCREWCAL_SERVICE)")
    j.add_argument("--token", default=None, help="bearer token (or SCREWCAL_TOKEN)")
    actions = j.add_subparsers(dest="action", metavar="ACTION", required=True)
    common = argparse.ArgumentParser(add_help=False)  # also after the action
    common.add_argument("--service", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    common.add_argument("--token", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    actions.add_parser("robot-list", parents=[common], help="the robots the service knows")
    actions.add_parser("list", parents=[common], help="the jobs, newest last")
    _add_robot_parser(actions, common)
    h = actions.add_parser("history", parents=[common], help="a robot's jobs and models with "
                           "their provenance, its accuracy trend and drift alarm (exit 2 when "
                           "the alarm is on)")
    h.add_argument("robot", help="the robot's name or id")
    st = actions.add_parser("start", parents=[common], help="start a job and watch it")
    st.add_argument("--robot", required=True, help="the robot's name or id")
    st.add_argument("--kind", choices=["procedure", "calibration", "performance", "verify"],
                    default="procedure", help="verify: a short ISO 9283 test with the robot's "
                    "newest model (10 cycles unless --cycles), no estimation")
    st.add_argument("--mode", choices=["AUTO", "STEP"], default="AUTO",
                    help="AUTO (default) runs through; STEP asks before every move")
    st.add_argument("--cycles", type=bounded_int(2, 60), default=30,
                    help="ISO 9283 cycles (default 30)")
    st.add_argument("--poses", type=bounded_int(10, 400), default=40,
                    help="calibration poses (default 40)")
    st.add_argument("--cube-edge-mm", type=bounded_float(0.0, 2000.0), default=300.0,
                    help="edge of the ISO 9283 test cube (mm, default 300; a smaller one where "
                    "300 mm does not fit the robot's workspace)")
    add_option(st, "--error-model", renamed=["--model"], choices=ERROR_MODELS, default="full",
               help="error model identified (default full)")
    st.add_argument("--correction", choices=["compensate", "zero", "zero+compensate"],
                    default="compensate", help="procedure's correction route (default "
                    "compensate: the later lists' joint targets; zero: ZERO, thesis 4.5)")
    add_vector(st, "--arm-position-mm", renamed=["--arm-position"],
               help="the measuring arm's base in the robot base frame (default: the plan's)")
    st.add_argument("--frame-from-job", type=positive_int, metavar="JOB",
                    help="performance: measure in the base frame an earlier job identified")
    _add_model_options(st)
    st.add_argument("--no-watch", action="store_true",
                    help="start the job and return (follow it with screwcal job watch ID)")
    for name, text in (("watch", "follow a job (STEP: answer the prompts)"),
                       ("abort", "abort a job"), ("result", "print a job's result table")):
        a = actions.add_parser(name, parents=[common], help=text)
        a.add_argument("id", type=positive_int, help="the job's id (screwcal job list)")
    mod = actions.add_parser("model", parents=[common],
                             help="save a job's calibrated model (result document)")
    mod.add_argument("id", type=positive_int, help="the job's id (screwcal job list)")
    mod.add_argument("--out", required=True, help="JSON file to write")
    mod.add_argument("--round", type=int, choices=[1, 2], default=1,
                     help="the second calibration round's model (procedure with rounds 2)")
    rep = actions.add_parser("report", parents=[common], help="save a job's report page")
    rep.add_argument("id", type=positive_int, help="the job's id (screwcal job list)")
    rep.add_argument("--out", required=True, help="HTML file to write")
    from service.measure_cli import add_measure_parser

    add_measure_parser(actions, common)
    for a in actions.choices.values():
        a.set_defaults(func=run_job)


def _add_robot_parser(actions: argparse._SubParsersAction,
                      common: argparse.ArgumentParser) -> None:
    r = actions.add_parser("robot-add", parents=[common], help="register a robot cell")
    r.add_argument("--name", required=True, help="the cell's name (unique on the service)")
    r.add_argument("--controller", required=True, help="HOST:PORT of the controller")
    which = r.add_mutually_exclusive_group(required=True)
    which.add_argument("--arm", help="pyserial URL of the measuring arm")
    which.add_argument("--tracker", metavar="HOST[:PORT]",
                       help="a laser tracker's emScon TPI (port 700 by default), one SMR")
    which.add_argument("--external", action="store_true", help="another instrument, whose "
                       "software posts each pose's measurement (screwcal job measure)")
    add_vector(r, "--tracker-stand-mm", help="where the tracker stands, roughly, in the robot "
               "base frame (mm; the job's poses are planned for its beam)")
    add_option(r, "--robot", renamed=["--model"], default="irb1600",
               help="library robot (screwcal robot list), or a robot or calibrated model file "
               "read here (relative to this directory) and sent to the service")
    r.add_argument("--serial", default="", help="the robot's serial number")
    r.add_argument("--controller-software", default="", help="e.g. 'RobotWare 6.15'")
    r.add_argument("--tool", default="", help="the tool mounted")
    r.add_argument("--payload-kg", type=non_negative_float, default=None,
                   help="the mass the robot usually carries on its flange")


def _add_serve_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument("--db", default=None, help="SQLite file (default screwcal.db), or a "
                   "postgresql://user@host/name URL: several services may share a PostgreSQL "
                   "database, each job held by one of them (SCREWCAL_LEASE_S)")
    s.add_argument("--host", default=None, help="bind address (default 127.0.0.1)")
    s.add_argument("--port", type=bounded_int(0, 65535), default=None,
                   help="TCP port (default 8080; 0: a free one)")
    s.add_argument("--token", default=None, help="deprecated: a shared administrator token "
                   "(or SCREWCAL_TOKEN); give people users instead")
    s.add_argument("--admin", default=None, metavar="NAME", help="the first administrator, "
                   "made when the database has no user yet (password from "
                   "SCREWCAL_ADMIN_PASSWORD or asked for)")
    s.add_argument("--tls-cert", default=None, help="certificate (PEM): serve HTTPS")
    s.add_argument("--tls-key", default=None, help="its private key (PEM)")
    s.add_argument("--insecure-http", action="store_true", help="listen beyond loopback "
                   "without TLS (refused otherwise)")


def _add_model_options(p: argparse.ArgumentParser) -> None:
    """`job start`'s options of what the calibration identifies, what the robot carries, and
    the warm-up."""
    p.add_argument("--warmup-cycles", type=bounded_int(0, 60), default=0,
                   help="ISO 9283 warm-up: test cycles run unmeasured before the first "
                   "performance list (default 0)")
    p.add_argument("--compliance", choices=["auto", "none", "j23", "j23-free", "wrist"],
                    default="auto", help="joint compliance identified with the geometry "
                    "(default auto: joints 2-3 when the data support them; none: geometric "
                    "only)")
    p.add_argument("--lag", choices=["auto", "none"], default="auto",
                    help="joint readings that trail the motion: estimated and corrected when "
                    "flagged (default auto)")
    p.add_argument("--payload-kg", type=non_negative_float, default=0.0,
                    help="mass on the flange during the performance lists, and the calibration "
                    "list unless --calibration-payload-kg (kg, default 0)")
    add_vector(p, "--payload-cog-mm", default=(0.0, 0.0, 0.0),
               help="its centre of gravity in the flange (tool0) frame (default 0 0 0)")
    p.add_argument("--calibration-payload-kg", type=non_negative_float, default=None,
                    help="mass on the flange during the calibration list (kg)")
    add_vector(p, "--calibration-payload-cog-mm", default=(0.0, 0.0, 0.0),
               help="its centre of gravity in the flange frame (default 0 0 0)")
    p.add_argument("--backlash-poses", type=bounded_int(0, 20), default=0, metavar="N",
                   help="calibration: N calibration poses measured again approached from 1 deg "
                   "below and 1 deg above on every joint, to identify each joint's lost motion "
                   "(deg; default 0: none)")
    p.add_argument("--drift-poses", type=bounded_int(0, 5), default=0, metavar="N",
                   help="ISO 9283 drift: N reference poses (the cube's P1, P2, P4, P3, P5) "
                   "re-measured during the job (default 0: none)")
    p.add_argument("--drift-period-poses", type=bounded_int(5, 1000), default=40, metavar="N",
                   help="drift: re-measure them every N measured poses (count, default 40)")
    p.add_argument("--drift-period-s", type=non_negative_float, default=None, metavar="S",
                   help="drift: re-measure them every S seconds of the job instead (s)")


def _model_options(args: argparse.Namespace) -> dict[str, Any]:
    options = {"compliance": args.compliance, "lag": args.lag, "payload_kg": args.payload_kg,
               "payload_cog_mm": args.payload_cog_mm, "warmup_cycles": args.warmup_cycles,
               "backlash_poses": args.backlash_poses, "drift_poses": args.drift_poses,
               "drift_period_poses": args.drift_period_poses}
    if args.drift_period_s is not None:
        options["drift_period_s"] = args.drift_period_s
    if args.calibration_payload_kg is not None:
        options |= {"calibration_payload_kg": args.calibration_payload_kg,
                    "calibration_payload_cog_mm": args.calibration_payload_cog_mm}
    return options
