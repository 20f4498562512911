"""The service side of `screwcal demo` (screwcal/commands/demo.py): the whole calibration
procedure on emulated hardware.

Starts the IRC5 and measuring-arm emulators (a process: the service never imports them), the job
service on a free local port with its own database, and runs the thesis's procedure in AUTO:
ISO 9283 performance before, 40 calibration poses, estimation of the full model, correction
(by default compensation: the performance list after is sent as the joint targets that make the
calibrated robot reach the nominal targets), performance after. Prints the before/after table and
writes the report (one HTML page, its charts inline) to a folder. The same `--seed` prints the
same table.
"""

from __future__ import annotations

import argparse
import contextlib
import re
import secrets
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from screwcal.instrument import STAND_MM, TRACKER_STAND_MM
from service.errors import ServiceError

if TYPE_CHECKING:
    from service.operator import Operator
    from service.robot_record import TrackerSetup
    from service.schemas import JobResult
    from service.settings import ServiceSettings

ARM_POSITION_MM = STAND_MM  # the emulator's default arm stand (robot frame)
NOISE_SEED = 2018  # the arm's noise when no --seed is given (Table 11's errors)
DEFAULT_POSES = 40  # calibration poses of the ideal robot (the thesis's)
DEFAULT_POSES_REAL = 80  # ... and of a robot that also bends and lags: compliance and lag
# identified with the geometry need more (40 leave 0.03 mm more after on the typical robot)


@dataclass(frozen=True)
class TrackerStand:
    """The emulated laser tracker of a demo cell: where it stands (robot frame, mm), turned
    how far about the vertical, how many SMRs the flange carries, and its injected faults
    (`emulator irc5 --tracker-faults`)."""

    stand_mm: tuple[float, ...] = TRACKER_STAND_MM
    yaw_deg: float = 0.0
    smrs: int = 1
    faults: str = ""

    def arguments(self) -> list[str]:
        args = ["--tracker-port", "0", "--stand-mm", *(f"{v:g}" for v in self.stand_mm),
                "--smrs", str(self.smrs), "--stand-yaw-deg", f"{self.yaw_deg:g}"]
        return args + (["--tracker-faults", self.faults] if self.faults else [])

    def setup(self, host: str = "127.0.0.1", port: int = 700) -> TrackerSetup:
        """The robot record's instrument: this tracker at host:port."""
        from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM, THREE_SMRS_MM
        from service.robot_record import TrackerSetup

        smrs = THREE_SMRS_MM if self.smrs == 3 else (DEFAULT_SMR_MM,)
        return TrackerSetup(host=host, port=port, smrs_mm=[list(p) for p in smrs],
                            stand_mm=list(self.stand_mm), yaw_deg=self.yaw_deg)


@contextlib.contextmanager
def emulators(time_scale: float, seed: int | None, world: Path, realism: str = "ideal",
              tracker: TrackerStand | None = None) -> Iterator[tuple[str, int, str]]:
    """The demo's cell, `screwcal emulator irc5` as a process: the controller and its
    instrument, the measuring arm or (`tracker`) a laser tracker. Yields the controller's host
    and port and the instrument's address (socket://... or emscon://...)."""
    cmd = [sys.executable, "-m", "screwcal", "emulator", "irc5", "--port", "0",
           "--time-scale", str(time_scale), "--world", str(world), "--realism", realism,
           *(["--arm-port", "0"] if tracker is None else tracker.arguments())]
    if seed is not None:
        cmd += ["--seed", str(seed)]
    # The instrument's noise is seeded too: two runs with the same seed print the same table.
    cmd += ["--noise-seed", str(NOISE_SEED if seed is None else seed)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        m = re.match(r"irc5 emulator on ([\d.]+):(\d+); (?:measuring arm|laser tracker) on "
                     r"(\S+)", line)
        if not m:
            raise ServiceError(f"the emulators did not start: {line}"
                               f"{proc.stderr.read() if proc.stderr else ''}")
        yield m.group(1), int(m.group(2)), m.group(3)
    finally:
        proc.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.communicate(timeout=10)


@contextlib.contextmanager
def service(settings: ServiceSettings) -> Iterator[str]:
    """The service in a thread of this process, on a free port; yields its URL."""
    import asyncio

    from service.server import bind  # here, not at import: every command would pay for uvicorn

    bound = bind(settings, port=0)
    host, port = bound.address
    server = bound.uvicorn
    thread = threading.Thread(target=lambda: asyncio.run(bound.serve()), daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not server.started and thread.is_alive() and time.monotonic() < deadline:
        time.sleep(0.02)
    if not server.started:
        raise ServiceError("the service did not start")
    try:
        yield f"http://{host}:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=10)
        bound.sock.close()


@dataclass
class DemoRun:
    """What the demo's jobs found: our route's result (and its state), the geometric-only
    route's on the same robot (None for the ideal robot or when it failed), and the options."""

    state: str
    result: JobResult
    geometric: JobResult | None
    options: dict[str, Any]


def run_jobs(args: argparse.Namespace, poses: int, geometric_too: bool,
             emulation: list[str], tracker: TrackerStand | None = None) -> DemoRun:
    """The emulators (a process) and the service (a thread), the procedure in AUTO, its report
    in `args.out`; with `geometric_too` the same procedure with a geometric-only model after
    it, on the same robot. `emulation`: what the emulated robot carries, as its robot record
    (and so the report) states it. `tracker`: the cell's instrument is an emulated laser
    tracker (the robot record names it), not the arm; its compensated lists take up the lost
    motion the calibration finds (`take_up_lost_motion`)."""
    from service.operator import Operator
    from service.settings import ServiceSettings

    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    options = {"cycles": args.cycles, "calibration_poses": poses,
               "arm_position_mm": list(ARM_POSITION_MM), "correction": args.correction,
               "model": args.error_model}
    if tracker is not None:  # as the tracker demo's own procedure did (c37eeb8)
        options["take_up_lost_motion"] = True
    with tempfile.TemporaryDirectory() as tmp:
        token = secrets.token_urlsafe(16)
        settings = ServiceSettings(db_path=Path(tmp) / "screwcal.db", token=token,
                                   port=0, reconnect_interval_s=0.2)
        with emulators(args.time_scale, args.seed, Path(tmp) / "world.json",
                       args.realism, tracker) as (host, port, address):
            with service(settings) as url, Operator(url, token) as op:
                robot = op.add_robot(name="ABB IRB 1600 (emulated)", controller_host=host,
                                     controller_port=port, model="irb1600",
                                     instrument=_instrument(address, tracker),
                                     emulation=emulation)
                job = op.start(robot_id=robot["id"], kind="procedure", mode="AUTO",
                               options=options)
                what = "arm" if tracker is None else "laser tracker"
                print(f"screwcal demo: emulated IRB 1600 (realism {args.realism}) at "
                      f"{host}:{port}, {what} {address}, service {url}; job {job['id']}: "
                      "performance, calibration, correction, performance", flush=True)
                state = op.watch(job["id"], out=_quiet_progress())
                result = op.result(job["id"])
                write_outputs(op, job["id"], result, out_dir)
                geometric = None
                if geometric_too:
                    geo = op.start(robot_id=robot["id"], kind="procedure", mode="AUTO",
                                   options={**options, "compliance": "none", "lag": "none"})
                    print(f"  job {geo['id']}: the same procedure, geometric-only model "
                          "(compliance none, lag none)", flush=True)
                    if op.watch(geo["id"], out=lambda _: None) == "done":
                        geometric = op.result(geo["id"])
    return DemoRun(state, result, geometric, options)


def _instrument(address: str, tracker: TrackerStand | None) -> dict[str, Any]:
    """The robot record's instrument: the emulated one at `address`."""
    if tracker is None:
        return {"kind": "arm", "url": address}
    from protocol.tracker import parse_tracker_url

    return tracker.setup(*parse_tracker_url(address)).model_dump()


# What the demo writes in its folder, each file with what it is and the command that takes it
# (the demo's closing lines print them: screwcal/commands/demo.py)
OUTPUTS = {
    "report.html": "the report: open it in a browser",
    "result.json": "the calibrated model, as `screwcal calibrate` writes it: screwcal predict "
                   "--result {out}/result.json --joints joints.csv --out predicted.csv; screwcal "
                   "compensate --result {out}/result.json --rapid IN.mod --out OUT.mod; screwcal "
                   "robot export {out}/result.json --format urdf --out robot.urdf",
    "measurements.csv": "the calibration poses as measured: screwcal calibrate --robot irb1600 "
                        "--data {out}/measurements.csv --out result.json",
    "job.json": "the job's whole result (before and after, each phase), for your own scripts: "
                "no command reads it",
}


def write_outputs(op: Operator, job_id: int, result: JobResult, out_dir: Path) -> None:
    """The files of OUTPUTS: the report, the calibrated model document (GET /jobs/ID/model,
    format screwcal-calibration), the calibration list's measurements as the measurement file
    and the job's result. Without a calibration (the job failed before it) the model and the
    measurements are not written."""
    from screwcal.calibration.measurements import write_measurements_csv
    from screwcal.kinematics.robots import irb1600
    from screwcal.tables import write_json_atomic, write_text_atomic
    from service.analysis import measurement_set

    write_text_atomic(out_dir / "report.html", op.report(job_id).encode("utf-8"))
    write_json_atomic(out_dir / "job.json", result.model_dump(mode="json"))
    for name in ("result.json", "measurements.csv"):
        (out_dir / name).unlink(missing_ok=True)  # an earlier run's: never beside this one's
    if result.estimation is None:  # no calibration: GET /jobs/ID/model would be 404
        return
    write_json_atomic(out_dir / "result.json", op.model(job_id))
    rows = op.measurements(job_id, "cal")
    if rows:
        write_measurements_csv(out_dir / "measurements.csv", measurement_set(rows), irb1600())


def _quiet_progress() -> Callable[[str], None]:
    """Print phase changes and a progress line per quarter of a list, not every pose."""
    last: dict[str, int] = {}

    def out(line: str) -> None:
        m = re.match(r"(\S+)\s+\[.*\] pose (\d+) of (\d+)", line)
        if m:
            phase, done, total = m.group(1), int(m.group(2)), int(m.group(3))
            step = max(1, total // 4)
            if done == total or done - last.get(phase, 0) >= step:
                last[phase] = done
                print(f"  {line}", flush=True)
        else:
            print(f"  {line}", flush=True)

    return out
