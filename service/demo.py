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
import json
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
DEFAULT_POSES = 40  # calibration poses of the ideal robot (the thesis's)
DEFAULT_POSES_REAL = 80  # ... and of a robot that also bends and lags: compliance and lag
# identified with the geometry need more (40 leave 0.03 mm more after on the typical robot)


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
    from service.operator import Operator
    from service.report import report_figures
    from service.result_text import result_table
    from service.settings import ServiceSettings
    from simulators.realism import PRESETS

    started = time.perf_counter()
    realism = PRESETS[args.realism]
    poses = args.poses or (DEFAULT_POSES if realism.is_ideal else DEFAULT_POSES_REAL)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    options = {"cycles": args.cycles, "calibration_poses": poses,
               "arm_position_mm": list(ARM_POSITION_MM), "correction": args.correction,
               "model": args.model}
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
                               options=options)
                print(f"screwcal demo: emulated IRB 1600 (realism {realism.name}) at "
                      f"{host}:{port}, arm {arm}, service {url}; job {job['id']}: performance, "
                      "calibration, correction, performance")
                state = op.watch(job["id"], out=_quiet_progress())
                result = op.result(job["id"])
                document = result.model_dump(mode="json")
                (out_dir / "report.html").write_text(op.report(job["id"]), encoding="utf-8")
                (out_dir / "result.json").write_text(json.dumps(document, indent=1),
                                                     encoding="utf-8")
                for name, png in report_figures(result).items():
                    (out_dir / name).write_bytes(png)
                geometric = None
                if not realism.is_ideal:  # the same robot, the geometric-only route
                    geo = op.start(robot_id=robot["id"], kind="procedure", mode="AUTO",
                                   options={**options, "compliance": "none", "lag": "none"})
                    print(f"  job {geo['id']}: the same procedure, geometric-only model "
                          "(compliance none, lag none)", flush=True)
                    geo_state = op.watch(geo["id"], out=lambda _: None)
                    geometric = op.result(geo["id"]).model_dump(mode="json") \
                        if geo_state == "done" else None
    print(result_table(result, times=False))
    for line in honest_lines(args.seed, args.realism, options, document, geometric):
        print(line)
    print(f"  report: {out_dir / 'report.html'} (and PNG figures, result.json) · done in "
          f"{time.perf_counter() - started:.1f} s")
    return 0 if state == "done" else 1


def honest_lines(seed: int | None, realism_name: str, options: dict, result: dict,
                 geometric: dict | None) -> list[str]:
    """What the emulated robot carries, what the calibration identified of it (the names of the
    realism file), and the AP mean after of our route beside the geometric-only route on the
    same robot and the oracle floor."""
    from screwcal.calibration.virtual_joints import THESIS_TABLE11
    from simulators.realism import PRESETS

    realism = PRESETS[realism_name]
    lines = ["  the emulated robot: geometric errors " + (
        "of the thesis's Table 11: " + ", ".join(f"{k} {v:g}" for k, v in
                                                 THESIS_TABLE11.items())
        if seed is None else f"drawn from seed {seed}") + f"; realism {realism.name}:"]
    lines += [f"    {line}" for line in realism.describe()]
    est = result.get("estimation") or {}
    compliance = (est.get("compliance") or {}).get("joints") or []
    if compliance or not realism.is_ideal:
        lines.append("  identified: compliance_deg_per_knm " + (", ".join(
            f"{j['name'].rstrip('c')} {j['compliance_deg_per_knm']:.3f} ± {j['std_error']:.3f}"
            for j in compliance) + " deg/kNm" if compliance else "none") + " (imposed: " + (
            ", ".join(f"J{k + 1} {v:g}" for k, v in enumerate(realism.compliance_deg_per_knm)
                      if v) or "none") + ")")
        lag = (est.get("reading_lag") or {}).get("per_joint")
        lines.append("  identified: lag " + (", ".join(
            f"J{k + 1} {v:.5f}" for k, v in enumerate(lag) if abs(v) >= 1e-5)
            if lag else "none") + " (imposed: " + (", ".join(
                f"J{k + 1} {v:g}" for k, v in enumerate(realism.lag) if v) or "none") + ")")
    ours = _ap_after(result)
    floor = oracle_floor(seed, realism_name, options)
    lines.append("  AP mean after, on the same robot (mm):")
    if ours is not None:
        label = (f"ours (geometry{' + compliance' if compliance else ''}"
                 f"{' + lag' if (est.get('reading_lag') or {}).get('per_joint') else ''})")
        lines.append(f"    {label:<44}{ours:>8.3f} mm")
    if geometric is not None and (geo := _ap_after(geometric)) is not None:
        lines.append(f"    {'geometric only (compliance none, lag none)':<44}{geo:>8.3f} mm"
                     + (f"   {geo / ours:.1f}x ours" if ours else ""))
    lines.append(f"    {'oracle floor':<44}{floor:>8.3f} mm"
                 + (f"   ours {ours / floor:.2f}x the floor" if ours else ""))
    lines.append("    (the oracle floor: the true geometry and compliance compensated exactly; "
                 "what no model removes stays: backlash, drift, repeatability, arm noise)")
    return lines


def _ap_after(result: dict) -> float | None:
    return ((result.get("performance") or {}).get("perf_after") or {}).get(
        "overall", {}).get("ap_mm_mean")


def oracle_floor(seed: int | None, realism_name: str, options: dict) -> float:
    """AP mean (mm) of the performance list sent compensated by the emulated robot's true model
    (simulators.oracle), after the lists the procedure runs before it."""
    import numpy as np

    from service.analysis import list_payload, performance_figures
    from service.document import JobOptions
    from service.plans import plan_for
    from simulators.oracle import oracle_attained
    from simulators.realism import PRESETS
    from simulators.truth import make_world

    job_options = JobOptions(**options)
    world = make_world(None, seed, realism=PRESETS[realism_name])
    cal = plan_for(world.nominal, "cal", job_options)
    perf = plan_for(world.nominal, "perf", job_options)
    home = [(0.0,) * world.nominal.n_joints]
    before = home + [p.joints_deg for p in perf] + [p.joints_deg for p in cal] + home
    attained = oracle_attained(world, before, np.array([p.joints_deg for p in perf]),
                               list_payload(job_options, "perf"),
                               NOISE_SEED if seed is None else seed)
    from screwcal.kinematics.pose import pose_from_transform

    rows = [{"idx": p.idx, "flange_pose": pose.tolist()}
            for p, pose in zip(perf, pose_from_transform(attained), strict=True)]
    section = performance_figures(rows, {p.idx: p for p in perf}, np.eye(4))
    assert section.overall is not None
    return float(section.overall["ap_mm_mean"])


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
    p.add_argument("--poses", type=int, default=None,
                   help=f"calibration poses (default {DEFAULT_POSES} for the ideal robot, "
                   f"{DEFAULT_POSES_REAL} otherwise)")
    p.add_argument("--correction", choices=["compensate", "zero", "zero+compensate"],
                   default="compensate", help="correction route (default compensate)")
    p.add_argument("--model", choices=["full", "thesis"], default="full",
                   help="error model identified (default full)")
    p.add_argument("--time-scale", type=float, default=0.002,
                   help="motion time factor of the emulated robot")
    p.add_argument("--realism", choices=["ideal", "typical", "harsh"], default="typical",
                   help="what the emulated robot has beyond its geometry (default typical)")
    p.set_defaults(func=run)
