"""`screwcal serve` (the job service) and `screwcal job ...` (the operator's client).

    screwcal serve [--db screwcal.db | postgresql://...] [--host 127.0.0.1] [--port 8080]
                   [--token T]
    screwcal job robot-add --name N --controller HOST:PORT --arm URL [--model irb1600]
    screwcal job start --robot ID --kind procedure|calibration|performance [--mode STEP]
    screwcal job watch ID        # progress; in STEP mode asks before every move
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
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from screwcal.commands.options import finite_float
from service.errors import ServiceError
from service.phases import PERF_PHASE_NAMES, ROUND_SUFFIXES
from service.summary import before_after

if TYPE_CHECKING:  # imported where used: `screwcal --help` pays for neither
    import httpx

    from service.document import CorrectionPlan, EstimationSummary
    from service.schemas import JobResult
    from service.settings import ServiceSettings


# -- the service --------------------------------------------------------------------------------
def serve(settings: ServiceSettings, announce: Callable[[str], None] = print) -> int:
    """Run the service until interrupted; announces its URL once bound (port 0: a free one).
    Exit code 1 when it stopped because its database was lost."""
    import asyncio

    from service.server import bind

    server = bind(settings)
    host, port = server.address
    announce(f"screwcal service on http://{host}:{port} (database {server.store.label})")
    sys.stdout.flush()
    asyncio.run(server.serve())
    return 1 if server.fatal else 0


def run_serve(args: argparse.Namespace) -> int:
    from service.database import is_postgres_url

    db_key = "db_url" if is_postgres_url(args.db or "") else "db_path"
    overrides = {k: v for k, v in ((db_key, args.db), ("host", args.host),
                                   ("port", args.port), ("token", args.token)) if v is not None}
    from service.settings import ServiceSettings

    settings = ServiceSettings(**overrides)
    if not settings.token:
        print("warning: no token (--token or SCREWCAL_TOKEN): every request that moves a robot "
              "or changes data will be refused", file=sys.stderr)
    try:
        return serve(settings)
    except KeyboardInterrupt:
        return 0


# -- the operator's client ---------------------------------------------------------------------
class Operator:
    """A thin httpx client of the REST API (a transport can be passed for tests)."""

    def __init__(self, base_url: str, token: str, transport: httpx.BaseTransport | None = None):
        import httpx

        self.http = httpx.Client(base_url=base_url, transport=transport, timeout=30.0,
                                 headers={"Authorization": f"Bearer {token}"})

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> Operator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check(self, r: httpx.Response) -> Any:
        if r.status_code >= 400:
            try:
                detail = r.json().get("detail")
            except ValueError:
                detail = r.text
            if isinstance(detail, list):  # a validation error: the field, the value, the rule
                detail = "; ".join(_invalid(e) for e in detail if isinstance(e, dict))
            raise ServiceError(f"{r.request.method} {r.request.url.path}: {r.status_code} "
                               f"{detail}")
        return r.json() if r.content else None

    def add_robot(self, **body: Any) -> dict:
        return self._check(self.http.post("/robots", json=body))

    def start(self, **body: Any) -> dict:
        return self._check(self.http.post("/jobs", json=body))

    def robots(self) -> list[dict]:
        return self._check(self.http.get("/robots"))

    def jobs(self) -> list[dict]:
        return self._check(self.http.get("/jobs"))

    def robot_id(self, name_or_id: str) -> int:
        """A robot named by its id or its (unique) name."""
        robots = self.robots()
        for r in robots:
            if r["name"] == name_or_id:
                return int(r["id"])
        if name_or_id.isdigit() and any(r["id"] == int(name_or_id) for r in robots):
            return int(name_or_id)
        known = ", ".join(f"{r['id']} ({r['name']})" for r in robots) or "none yet"
        raise ServiceError(f"no robot {name_or_id!r} on the service; robots: {known} "
                           "(screwcal job robot-add)")

    def job(self, job_id: int) -> dict:
        return self._check(self.http.get(f"/jobs/{job_id}"))

    def go(self, job_id: int, index: int) -> None:
        self._check(self.http.post(f"/jobs/{job_id}/go", json={"index": index}))

    def abort(self, job_id: int) -> None:
        self._check(self.http.post(f"/jobs/{job_id}/abort"))

    def result(self, job_id: int) -> JobResult:
        from service.schemas import JobResult

        return JobResult.model_validate(self._check(self.http.get(f"/jobs/{job_id}/result")))

    def model(self, job_id: int, round_: int = 1) -> dict:
        return self._check(self.http.get(f"/jobs/{job_id}/model", params={"round": round_}))

    def report(self, job_id: int) -> str:
        r = self.http.get(f"/jobs/{job_id}/report")
        if r.status_code >= 400:
            self._check(r)
        return r.text

    def watch(self, job_id: int, ask: Callable[[str], str] = input,
              out: Callable[[str], None] = print) -> str:
        """Follow the job's events to its end; in STEP mode ask before every move. Returns the
        final state (or 'waiting' when the operator declined a move: the job waits)."""
        asked: set[tuple[str, int]] = set()

        def ask_for(waiting: dict, joints: list | None, note: str = "") -> bool:
            """Prompt for the pose the job waits for now; False when the operator declines."""
            key = (waiting["phase"], waiting["index"])
            if key in asked:
                return True
            asked.add(key)
            where = f" (joints {joints})" if joints is not None else ""
            prompt = (f"{note + '. ' if note else ''}robot will move to {key[0]} pose "
                      f"{key[1]}{where}: go? [y/N] ")
            try:
                answer = ask(prompt)
            except EOFError:  # no one to answer: the robot does not move
                return False
            except KeyboardInterrupt:
                out("")
                try:
                    stop = ask(f"abort job {job_id}? [y/N] ")
                except (EOFError, KeyboardInterrupt):
                    stop = "n"
                if stop.strip().lower() == "y":
                    self.abort(job_id)
                    out(f"job {job_id}: abort requested")
                return False
            if answer.strip().lower() != "y":
                return False
            self.go(job_id, key[1])
            return True

        with self.http.stream("GET", f"/jobs/{job_id}/events", timeout=None) as r:
            for line in r.iter_lines():
                if not line.startswith("data: "):
                    continue
                event = json.loads(line[len("data: "):])
                kind = event["kind"]
                if kind == "state":  # where the job stands when we attach
                    out(f"job {job_id}: {event['state']} {event.get('reason', '')}".rstrip())
                    waiting = event.get("waiting_for")
                    if waiting and not ask_for(waiting, None):
                        out(f"not moving; job {job_id} waits (screwcal job abort {job_id})")
                        return "waiting"
                elif kind == "measured":
                    bar = "#" * int(30 * event["done"] / event["total"])
                    out(f"{event['phase']:<12} [{bar:<30}] pose {event['done']} of "
                        f"{event['total']}")
                elif kind == "waiting":
                    waiting = {"phase": event["phase"], "index": event["index"]}
                    if self.job(job_id)["waiting_for"] != waiting:
                        continue  # history: the job has gone past this pose
                    if not ask_for(waiting, event["joints_deg"], event.get("note", "")):
                        out(f"not moving; job {job_id} waits (screwcal job abort {job_id})")
                        return "waiting"
                elif kind in ("phase", "paused", "resumed", "corrected", "failed", "warning",
                              "discarded", "stale"):
                    out(f"{kind}: " + ", ".join(f"{k}={v}" for k, v in event.items()
                                               if k not in ("kind", "seq", "time")))
                elif kind == "end":
                    return event["state"]
        return self.job(job_id)["state"]


def result_table(result: JobResult, times: bool = True) -> str:
    """The before/after table a person reads (`times`: the seconds each phase took)."""
    lines = [f"job {result.id}: {result.state} {result.reason}".rstrip()]
    phases, rows = before_after(result.performance or {})
    if rows:
        lines.append(f"  {'ISO 9283':<36}" + "".join(f"{PERF_PHASE_NAMES[p]:>12}" for p in phases)
                     + (f"{'factor':>9}" if len(phases) > 1 else ""))
        for r in rows:
            cells = "".join(f"{v:>9.3f} {r.unit:<2}" if v is not None else f"{'-':>12}"
                            for v in r.values)
            factor = f"{r.factor:>8.1f}x" if r.factor is not None else ""
            lines.append(f"  {r.label:<36}{cells}{factor}")
    if result.estimation is not None:
        lines += _estimation_lines(result.estimation)
    if result.frame_note:
        lines.append(f"  frame: {result.frame_note}")
    home = result.home_check
    for when, measured in (("before", home and home.before), ("after", home and home.after)):
        if measured:
            e = measured.error_mm
            lines.append(f"  home position error {when} (Table 14): x {e[0]:+.3f}, y {e[1]:+.3f}, "
                         f"z {e[2]:+.3f} mm, |e| {measured.distance_mm:.3f} mm")
    for suffix in ROUND_SUFFIXES:
        lines += _route_lines(result.correction_of(suffix), suffix)
    for warning in result.warnings or []:
        lines.append(f"  WARNING: {warning}")
    if result.phases and times:
        lines.append("  time per phase (s): " + ", ".join(
            f"{k} {v.seconds:.2f}" for k, v in result.phases.items()))
    return "\n".join(lines)


def _estimation_lines(est: EstimationSummary) -> list[str]:
    """The joints' identified parameters, the noise levels measured, what was not separable."""
    lines = [f"  identified ({est.rank} parameters, chi2/dof {est.chi2_reduced:.2f}):"]
    for p in est.parameters:
        if p.name.startswith("J"):
            lines.append(f"    {p.name:<8}{p.value:>10.4f} {p.unit:<3} ± {p.std_error:.4f}")
    if est.noise:
        lines.append("    noise levels: " + ", ".join(
            f"{k} {v['value']:.4g} {v['unit']}" + (f" ± {v['std']:.2g}" if v["std"] else "")
            for k, v in est.noise.items() if isinstance(v, dict) and v["measured"]))
    if est.removed:
        lines.append("    not separable from these data (not corrected): " + ", ".join(
            r.name for r in est.removed))
    return lines


def _route_lines(corr: CorrectionPlan | None, suffix: str) -> list[str]:
    """What the correction route did, compensated, or left in the robot."""
    if corr is None:
        return []
    head = f"  correction{' (round 2)' if suffix else ''}: {corr.route}"
    lines = []
    if corr.route == "none":
        return [f"{head} ({corr.note or ''})"]
    if corr.zero_command_deg is not None:
        sent = "sent" if corr.sent else "planned, not sent"
        lines.append(f"{head}; ZERO {sent} (deg): "
                     + " ".join(f"{v:.4f}" for v in corr.zero_command_deg))
    else:
        lines.append(head)
    if corr.compensated_lists:
        lines.append(f"    compensated joint targets for {', '.join(corr.compensated_lists)} "
                     f"(largest joint change {corr.max_joint_change_deg or 0:.3f} deg)")
    predicted = corr.predicted_position_error_mm
    if predicted is not None:
        lines.append(f"    model-predicted flange error on the ISO targets: "
                     f"{predicted.before:.3f} -> {predicted.after:.3f} mm")
    if corr.left_in_robot:
        lines.append("    left in the robot (not corrected by this route): " + ", ".join(
            f"{p.name} {p.value:+.3f} {p.unit}" for p in corr.left_in_robot))
    elif corr.left_in_robot is not None:
        lines.append("    left in the robot: nothing the model identified")
    if corr.not_identified:
        lines.append("    not identified from these data (nothing corrects them): "
                     + ", ".join(corr.not_identified))
    return lines


def _invalid(error: dict) -> str:
    """One pydantic error as a person reads it: `options.cycles = 1: must be >= 2`."""
    loc = ".".join(str(p) for p in error.get("loc", ()) if p != "body")
    value = f" = {error['input']!r}" if "input" in error and not isinstance(
        error["input"], dict) else ""
    rule = str(error.get("msg", "invalid")).removeprefix("Value error, ")
    return f"{loc}{value}: {rule}"


def _model_argument(model: str) -> str | dict:
    """A built-in robot's name as it is; anything else is a file read on this side and sent as
    a document (the service never opens a path a client names)."""
    from screwcal.kinematics.modelfile import model_document, resolve_model
    from screwcal.kinematics.robots import BUILTIN_MODELS

    return model if model in BUILTIN_MODELS else model_document(resolve_model(model))


def _write(path: str, text: str) -> None:
    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as err:
        raise ServiceError(f"cannot write {path}: {err.strerror}") from None


def _operator(args: argparse.Namespace) -> Operator:
    token = args.token or os.environ.get("SCREWCAL_TOKEN", "")
    if not token:
        raise ServiceError("no token: pass --token or set SCREWCAL_TOKEN (the one the service "
                           "was started with)")
    if not token.isprintable() or any(c.isspace() for c in token):
        raise ServiceError("the token has spaces or control characters: check SCREWCAL_TOKEN")
    return Operator(args.service or os.environ.get("SCREWCAL_SERVICE", "http://127.0.0.1:8080"),
                    token)


def run_job(args: argparse.Namespace) -> int:
    with _operator(args) as op:
        return _run_job(op, args)


def _run_job(op: Operator, args: argparse.Namespace) -> int:
    import httpx

    try:
        if args.action == "robot-add":
            host, _, port = args.controller.rpartition(":")
            if not host or not port.isdigit():
                raise ServiceError(f"--controller is HOST:PORT (e.g. 127.0.0.1:4012), not "
                                   f"{args.controller!r}")
            robot = op.add_robot(name=args.name, controller_host=host,
                                 controller_port=int(port), arm_url=args.arm,
                                 model=_model_argument(args.model))
            print(f"robot {robot['id']}: {robot['name']}")
        elif args.action == "robot-list":
            for r in op.robots():
                print(f"{r['id']:>4}  {r['name']:<24} controller {r['controller_host']}:"
                      f"{r['controller_port']}  arm {r['arm_url']}")
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
                                       "calibration_poses": args.poses, "model": args.model,
                                       "correction": args.correction}
            if args.arm_position:
                options["arm_position_mm"] = args.arm_position
            if args.frame_from_job:
                options["frame_from_job"] = args.frame_from_job
            job = op.start(robot_id=op.robot_id(args.robot), kind=args.kind, mode=args.mode,
                           options=options)
            print(f"job {job['id']} started ({job['kind']}, {job['mode']})")
            if not args.no_watch:
                state = op.watch(job["id"])
                print(result_table(op.result(job["id"])))
                return 0 if state in ("done", "waiting") else 1
        elif args.action == "watch":
            if op.job(args.id)["state"] in ("done", "failed", "aborted"):
                print(result_table(op.result(args.id)))  # finished: its summary, no replay
                return 0 if op.job(args.id)["state"] == "done" else 1
            state = op.watch(args.id)
            return 0 if state in ("done", "waiting") else 1
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
        raise ServiceError(f"cannot reach the service: {err}") from None
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser("serve", help="run the job service (REST; SQLite or PostgreSQL)",
                       description=__doc__,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    s.add_argument("--db", default=None, help="SQLite file (default screwcal.db), or a "
                   "postgresql://user@host/name URL: several services may share a PostgreSQL "
                   "database, each job held by one of them (SCREWCAL_LEASE_S)")
    s.add_argument("--host", default=None, help="bind address (default 127.0.0.1)")
    s.add_argument("--port", type=int, default=None, help="port (default 8080; 0: free one)")
    s.add_argument("--token", default=None, help="bearer token (or SCREWCAL_TOKEN)")
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
    r = actions.add_parser("robot-add", parents=[common], help="register a robot cell")
    r.add_argument("--name", required=True)
    r.add_argument("--controller", required=True, help="HOST:PORT of the controller")
    r.add_argument("--arm", required=True, help="pyserial URL of the measuring arm")
    r.add_argument("--model", default="irb1600", help="built-in robot, or a model file read "
                   "here (relative to this directory) and sent to the service")
    st = actions.add_parser("start", parents=[common], help="start a job and watch it")
    st.add_argument("--robot", required=True, help="the robot's name or id")
    st.add_argument("--kind", choices=["procedure", "calibration", "performance"],
                    default="procedure")
    st.add_argument("--mode", choices=["AUTO", "STEP"], default="AUTO")
    st.add_argument("--cycles", type=int, default=30, help="ISO 9283 cycles")
    st.add_argument("--poses", type=int, default=40, help="calibration poses")
    st.add_argument("--model", choices=["thesis", "full", "joints"], default="full",
                    help="error model (default full)")
    st.add_argument("--correction", choices=["compensate", "zero", "zero+compensate"],
                    default="compensate", help="procedure's correction route (default "
                    "compensate: the later lists' joint targets; zero: ZERO, thesis 4.5)")
    st.add_argument("--arm-position", type=finite_float, nargs=3, metavar=("X", "Y", "Z"))
    st.add_argument("--frame-from-job", type=int, metavar="JOB",
                    help="performance: measure in the base frame an earlier job identified")
    st.add_argument("--no-watch", action="store_true")
    for name, text in (("watch", "follow a job (STEP: answer the prompts)"),
                       ("abort", "abort a job"), ("result", "print a job's result table")):
        a = actions.add_parser(name, parents=[common], help=text)
        a.add_argument("id", type=int)
    mod = actions.add_parser("model", parents=[common],
                             help="save a job's calibrated model (result document)")
    mod.add_argument("id", type=int)
    mod.add_argument("--out", required=True, help="JSON file to write")
    mod.add_argument("--round", type=int, choices=[1, 2], default=1,
                     help="the second calibration round's model (procedure with rounds 2)")
    rep = actions.add_parser("report", parents=[common], help="save a job's report page")
    rep.add_argument("id", type=int)
    rep.add_argument("--out", required=True)
    for a in actions.choices.values():
        a.set_defaults(func=run_job)
