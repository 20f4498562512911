"""`screwcal demo`: the whole calibration procedure on emulated hardware, in one command, and
what it achieved beside what could be achieved.

Starts the IRC5 and measuring-arm emulators (a process: the service never imports them), the job
service on a free local port with its own database, and runs the thesis's procedure in AUTO
(service/demo.py): ISO 9283 performance before, calibration poses (80; 40 for the ideal robot),
estimation of the full model with joint compliance and read-back lag, correction (by default
compensation), performance after. The emulated robot is `--realism typical` by default: besides
its geometric errors it bends under its own masses, has backlash, read-back lag, thermal drift and
repeatability error (simulators/realism.py); `--realism ideal` is the robot with its geometric
errors only. Prints the before/after table, what the robot carries and what was identified of
it, and the AP after of our route beside the geometric-only route on the same robot (a second
job) and the oracle floor (the true model compensated: what no model removes). Writes to a folder
(--out) the report (one HTML page, its charts inline), the calibrated model as `calibrate` writes
it (result.json: for predict, compensate, robot export), the calibration poses as measured
(measurements.csv: for calibrate --data) and the job's whole result (job.json); its closing
lines say which command takes which file. The same `--seed` prints the same table.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from screwcal.arguments import (
    ERROR_MODELS,
    add_option,
    add_vector,
    bounded_int,
    non_negative_float,
)
from screwcal.commands.options import make_output_folder
from screwcal.instrument import TRACKER_STAND_MM


def run(args: argparse.Namespace) -> int:
    # the service and the emulators: imported by this command only, never by the face itself
    from service.demo import DEFAULT_POSES, DEFAULT_POSES_REAL, run_jobs
    from service.result_text import result_table
    from simulators.realism import PRESETS

    started = time.perf_counter()
    make_output_folder(args.out)  # before the emulators start: a bad --out is refused now
    realism = PRESETS[args.realism]
    poses = args.poses or (DEFAULT_POSES if realism.is_ideal else DEFAULT_POSES_REAL)
    tracker = None
    if args.instrument == "tracker":  # the same job service, the robot measured by a tracker
        from service.demo import TrackerStand

        tracker = TrackerStand(tuple(args.stand_mm), args.stand_yaw_deg, args.smrs)
    emulation = ["geometric errors " + ("of the thesis's Table 11" if args.seed is None else
                                        f"drawn from seed {args.seed}")
                 + f"; realism {realism.name}", *realism.describe()]
    done = run_jobs(args, poses, geometric_too=not realism.is_ideal, emulation=emulation,
                    tracker=tracker)
    print(result_table(done.result, times=False))
    geometric = None if done.geometric is None else done.geometric.model_dump(mode="json")
    result = done.result.model_dump(mode="json")
    for line in instrument_lines(result):
        print(line)
    floor = oracle_floor(args.seed, args.realism, done.options,
                         None if tracker is None else tracker.setup())
    for line in honest_lines(args.seed, args.realism, done.options, result, geometric, floor):
        print(line)
    routes_on_the_report(Path(args.out) / "report.html", _ap_after(result),
                         None if geometric is None else _ap_after(geometric), floor,
                         bool(done.options.get("take_up_lost_motion")))
    for line in closing_lines(Path(args.out)):
        print(line)
    print(f"  done in {time.perf_counter() - started:.1f} s")
    return 0 if done.state == "done" else 1


def instrument_lines(result: dict) -> list[str]:
    """The instrument, its uncertainty and the air it measured in, as the job's result states
    them; a tracker's noise along and across its beam; the lost motion taken up."""
    conditions = result.get("test_conditions") or {}
    lines = [f"  {key}: {conditions[key]}" for key in (  # (its address: on the first line)
        "instrument uncertainty", "air (the instrument's weather)") if key in conditions]
    noise = (result.get("estimation") or {}).get("noise") or {}
    if "along_beam" in noise:
        along, across = noise["along_beam"], noise["across_beam"]
        lines.append(f"  noise along the beam {along['value'] * 1000:.1f} um, across it "
                     f"{across['value'] * 1000:.1f} um per direction (the fit's residuals, the "
                     f"robot's misfit included); beyond the tracker's stated covariances "
                     f"{along['excess_mm'] * 1000:.1f} um and {across['excess_mm'] * 1000:.1f} "
                     "um, added to each point's weight")
    lost = (result.get("correction") or {}).get("lost_motion_taken_up_deg")
    if lost:
        lines.append("  lost motion taken up on each target's approach side (half of it, "
                     "deg): " + ", ".join(f"J{k + 1} {v:.4f}" for k, v in enumerate(lost) if v))
    return lines


def closing_lines(out_dir: Path) -> list[str]:
    """Which file the demo wrote is for what, and the command that takes it."""
    from service.demo import OUTPUTS

    written = [name for name in OUTPUTS if (out_dir / name).is_file()]
    width = max(map(len, written), default=0)
    return [f"  files in {out_dir}:"] + [
        f"    {name:<{width}}  {OUTPUTS[name].format(out=out_dir)}" for name in written]


def honest_lines(seed: int | None, realism_name: str, options: dict, result: dict,
                 geometric: dict | None, floor: float) -> list[str]:
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
        lines.append("  identified: joint compliance " + (", ".join(
            f"{j['name'].rstrip('c')} {j['compliance_deg_per_knm']:.3f} ± {j['std_error']:.3f}"
            for j in compliance) + " deg/kNm" if compliance else "none") + " (imposed: " + (
            ", ".join(f"J{k + 1} {v:g}" for k, v in enumerate(realism.compliance_deg_per_knm)
                      if v) or "none") + ")")
        lag = (est.get("reading_lag") or {}).get("per_joint")
        lines.append("  identified: read-back lag " + (", ".join(
            f"J{k + 1} {v:.5f}" for k, v in enumerate(lag) if abs(v) >= 1e-5)
            if lag else "none") + " (imposed: " + (", ".join(
                f"J{k + 1} {v:g}" for k, v in enumerate(realism.lag) if v) or "none") + ")")
        lost = (est.get("reading_lag") or {}).get("lost_motion_deg")
        if lost:
            lines.append("  identified with it: lost motion " + (", ".join(
                f"J{k + 1} {v:.4f}" for k, v in enumerate(lost) if v) or "none")
                + " deg (imposed backlash: " + (", ".join(
                    f"J{k + 1} {v:g}" for k, v in enumerate(realism.backlash_deg) if v)
                    or "none") + ")")
    ours = _ap_after(result)
    lines.append("  AP mean after, on the same robot (mm):")
    if ours is not None:
        label = (f"ours (geometry{' + compliance' if compliance else ''}"
                 f"{' + lag' if (est.get('reading_lag') or {}).get('per_joint') else ''})")
        lines.append(f"    {label:<44}{ours:>8.3f} mm")
    geo = None if geometric is None else _ap_after(geometric)
    if geo is not None:
        lines.append(f"    {'geometric only (compliance none, lag none)':<44}{geo:>8.3f} mm"
                     + (f"   {geo / ours:.1f}x ours" if ours else ""))
    lines.append(f"    {'oracle floor':<44}{floor:>8.3f} mm"
                 + (f"   ours {ours / floor:.2f}x the floor" if ours else ""))
    lines.append(f"    (the oracle {floor_note(bool(options.get('take_up_lost_motion')))})")
    return lines


def floor_note(lost_motion_taken_up: bool) -> str:
    """What the oracle floor is (the demo knows the emulated robot's truth): the true robot as
    it is when the performance list runs (warm) compensated exactly, and the true backlash
    taken up too when our route takes up the lost motion it found (the tracker demo)."""
    taken_up = ", the true backlash taken up as ours takes up the lost motion it found"
    return ("floor: the true geometry (as warm as the robot then is) and compliance compensated "
            f"exactly{taken_up if lost_motion_taken_up else ''}; what no model removes stays: "
            f"{'' if lost_motion_taken_up else 'backlash, '}the drift during the test, "
            "repeatability, the arm's noise")


def routes_on_the_report(page: Path, ours: float | None, geometric: float | None,
                         floor: float, lost_motion_taken_up: bool = False) -> None:
    """Put on the report's first screen, under its verdict, what only the demo knows: our
    route's AP mean after beside the geometric-only route's on the same robot and the floor."""
    from service.report.markup import esc, table

    if ours is None or not page.is_file():
        return
    rows: list[list[Any]] = [["ours (the job above)", ours, 1.0]]
    if geometric is not None:
        rows.append(["geometric errors only (no compliance, no lag)", geometric,
                     geometric / ours])
    rows.append(["the floor: no model does better", floor, floor / ours])
    block = table(["route", "AP mean after (mm)", "x ours"], rows, digits=3,
                  caption="On the same emulated robot, after correction") + \
        f"<p>The {esc(floor_note(lost_motion_taken_up))}.</p>"
    html = page.read_text(encoding="utf-8")
    mark = html.find("<p class='verdict'>")
    at = html.find("</p>", mark) + 4 if mark >= 0 else html.find("</header>") + 9
    page.write_text(html[:at] + block + html[at:], encoding="utf-8")


def _ap_after(result: dict) -> float | None:
    return ((result.get("performance") or {}).get("perf_after") or {}).get(
        "overall", {}).get("ap_mm_mean")


def oracle_floor(seed: int | None, realism_name: str, options: dict[str, Any],
                 instrument: Any = None) -> float:
    """AP mean (mm) of the performance list sent compensated by the emulated robot's true model
    (simulators.oracle), after the lists the procedure runs before it (the lists planned for
    the robot record's `instrument`: a tracker's are those its beam sees)."""
    import numpy as np

    from service.analysis import list_payload, performance_figures
    from service.demo import NOISE_SEED
    from service.document import JobOptions
    from service.plans import plan_for
    from simulators.oracle import oracle_attained
    from simulators.realism import PRESETS
    from simulators.truth import make_world

    job_options = JobOptions(**options)
    world = make_world(None, seed, realism=PRESETS[realism_name])
    cal = plan_for(world.nominal, "cal", job_options, instrument)
    perf = plan_for(world.nominal, "perf", job_options, instrument)
    home = [(0.0,) * world.nominal.n_joints]
    before = home + [p.joints_deg for p in perf] + [p.joints_deg for p in cal] + home
    attained = oracle_attained(world, before, np.array([p.joints_deg for p in perf]),
                               list_payload(job_options, "perf"),
                               NOISE_SEED if seed is None else seed,
                               PRESETS[realism_name].backlash_deg
                               if job_options.take_up_lost_motion else None)
    from screwcal.kinematics.pose import pose_from_transform

    rows = [{"idx": p.idx, "flange_pose": pose.tolist()}
            for p, pose in zip(perf, pose_from_transform(attained), strict=True)]
    section = performance_figures(rows, {p.idx: p for p in perf}, np.eye(4))
    assert section.overall is not None
    return float(section.overall["ap_mm_mean"])


def add_parser(sub: argparse._SubParsersAction) -> None:
    from service.demo import DEFAULT_POSES, DEFAULT_POSES_REAL

    p = sub.add_parser("demo", help="the whole procedure on emulated hardware, before/after",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=None,
                   help="random true errors (default: the thesis's Table 11)")
    p.add_argument("--out", default="demo-output", help="folder for the report (default "
                   "./demo-output)")
    p.add_argument("--cycles", type=bounded_int(2, 60), default=30,
                   help="ISO 9283 cycles (30)")
    p.add_argument("--poses", type=bounded_int(10, 400), default=None,
                   help=f"calibration poses (default {DEFAULT_POSES} for the ideal robot, "
                   f"{DEFAULT_POSES_REAL} otherwise)")
    p.add_argument("--correction", choices=["compensate", "zero", "zero+compensate"],
                   default="compensate", help="correction route (default compensate)")
    add_option(p, "--error-model", renamed=["--model"], choices=ERROR_MODELS, default="full",
               help="error model identified (default full)")
    p.add_argument("--time-scale", type=non_negative_float, default=0.002,
                   help="motion time factor of the emulated robot")
    p.add_argument("--realism", choices=["ideal", "typical", "harsh"], default="typical",
                   help="what the emulated robot has beyond its geometry (default typical)")
    p.add_argument("--instrument", choices=["arm", "tracker"], default="arm",
                   help="the measuring instrument, through the job service: the measuring arm "
                   "(default), or a laser tracker over emScon (the robot record's instrument)")
    p.add_argument("--stand-yaw-deg", type=float, default=0.0,
                   help="the emulated tracker's frame turned about the vertical (default 0; "
                   "the robot record states it, to point the beam at SMRs 2 and 3)")
    p.add_argument("--smrs", type=int, choices=[1, 3], default=1,
                   help="SMRs on the flange with --instrument tracker: 1 (positions, default) "
                   "or 3 (full pose)")
    add_vector(p, "--stand-mm", default=TRACKER_STAND_MM,
               help="where the tracker stands, mm in the robot frame (--instrument tracker; "
               "default " + " ".join(f"{v:g}" for v in TRACKER_STAND_MM) + ")")
    p.set_defaults(func=run)
