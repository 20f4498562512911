"""`screwcal demo`: the whole calibration procedure on emulated hardware, in one command.

Starts the IRC5 and measuring-arm emulators (a process: the service never imports them), the job
service on a free local port with its own database, and runs the thesis's procedure in AUTO:
ISO 9283 performance before, 40 calibration poses, estimation of the full model, correction
(by default compensation: the performance list after is sent as the joint targets that make the
calibrated robot reach the nominal targets), performance after. Prints the before/after table and
writes the report (HTML and PNG) to a folder. The same `--seed` prints the same table.
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
from pathlib import Path
from typing import TYPE_CHECKING

from screwcal.instrument import STAND_MM
from service.errors import ServiceError

if TYPE_CHECKING:
    from service.settings import ServiceSettings

ARM_POSITION_MM = STAND_MM  # the emulator's default arm stand (robot frame)
NOISE_SEED = 2018  # the arm's noise when no --seed is given (Table 11's errors)


@contextlib.contextmanager
def emulators(time_scale: float, seed: int | None, world: Path, realism: str = "ideal"
              ) -> Iterator[tuple[str, int, str]]:
    cmd = [sys.executable, "-m", "screwcal", "emulator", "irc5", "--port", "0",
           "--time-scale", str(time_scale), "--arm-port", "0", "--world", str(world),
           "--realism", realism]
    if seed is not None:
        cmd += ["--seed", str(seed)]
    # The arm's noise is seeded too: two runs with the same seed print the same table.
    cmd += ["--noise-seed", str(NOISE_SEED if seed is None else seed)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        m = re.match(r"irc5 emulator on ([\d.]+):(\d+); measuring arm on (\S+)", line)
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


def run(args: argparse.Namespace) -> int:
    from screwcal.calibration.virtual_joints import THESIS_TABLE11
    from service.operator import Operator
    from service.report import report_figures
    from service.result_text import result_table
    from service.settings import ServiceSettings

    started = time.perf_counter()
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        token = secrets.token_urlsafe(16)
        settings = ServiceSettings(db_path=Path(tmp) / "screwcal.db", token=token,
                                   port=0, reconnect_interval_s=0.2)
        with emulators(args.time_scale, args.seed, Path(tmp) / "world.json",
                       args.realism) as (host, port, arm):
            with service(settings) as url, Operator(url, token) as op:
                robot = op.add_robot(name="ABB IRB 1600 (emulated)", controller_host=host,
                                     controller_port=port, arm_url=arm, model="irb1600")
                job = op.start(robot_id=robot["id"], kind="procedure", mode="AUTO",
                               options={"cycles": args.cycles, "calibration_poses": args.poses,
                                        "arm_position_mm": list(ARM_POSITION_MM),
                                        "correction": args.correction, "model": args.model})
                print(f"screwcal demo: emulated IRB 1600 at {host}:{port}, arm {arm}, service "
                      f"{url}; job {job['id']}: performance, calibration, correction, "
                      "performance")
                state = op.watch(job["id"], out=_quiet_progress())
                result = op.result(job["id"])
                (out_dir / "report.html").write_text(op.report(job["id"]), encoding="utf-8")
                for name, png in report_figures(result).items():
                    (out_dir / name).write_bytes(png)
    print(result_table(result, times=False))
    if args.seed is None:
        print("  imposed on the emulated robot (thesis Table 11): " + ", ".join(
            f"{k} {v:g}" for k, v in THESIS_TABLE11.items()))
    print(f"  report: {out_dir / 'report.html'} (and PNG figures) · done in "
          f"{time.perf_counter() - started:.1f} s")
    return 0 if state == "done" else 1


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


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the whole procedure on emulated hardware, before/after",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=None,
                   help="random true errors (default: the thesis's Table 11)")
    p.add_argument("--out", default="demo-output", help="folder for the report (default "
                   "./demo-output)")
    p.add_argument("--cycles", type=int, default=30, help="ISO 9283 cycles (30)")
    p.add_argument("--poses", type=int, default=40, help="calibration poses (40)")
    p.add_argument("--correction", choices=["compensate", "zero", "zero+compensate"],
                   default="compensate", help="correction route (default compensate)")
    p.add_argument("--model", choices=["full", "thesis"], default="full",
                   help="error model identified (default full)")
    p.add_argument("--time-scale", type=float, default=0.002,
                   help="motion time factor of the emulated robot")
    p.add_argument("--realism", choices=["ideal", "typical", "harsh"], default="typical",
                   help="what the emulated robot has beyond its geometry (default typical)")
    p.set_defaults(func=run)
