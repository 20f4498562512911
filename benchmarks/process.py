"""Benchmark: whole processes side by side, screwcal's command line and the peer's script.

    pip install -e '.[peers]'          # pybotics (optional extra), for the calibrate pair
    .venv/bin/python benchmarks/process.py [--runs 7]

Each command is started as a fresh process; the pairs run in turn (ours, the peer's, ours, ...)
so that a drifting host slows both alike, and each run's wall time and peak memory (the
child's own maximum resident set, from wait4) are kept; medians with min and max and the ratio
of the medians ours / peer's are printed (a side run once is printed as one run). Pairs:
- `screwcal calibrate` on 40 simulated poses of an IRB 1600, as a user runs it (its defaults:
  the full model, 3 residuals per pose, the measuring frame and the measured point estimated,
  compliance and lag each tried, outliers rejected) beside `benchmarks/peer_calibrate.py` on
  the same file (pybotics's calibration recipe: 24 DH parameters, the tool position and the
  measuring frame, 33 in all, against one distance residual per pose, by scipy's
  `least_squares` at its default method `trf` with finite differences); the peer's result is
  checked before it is timed (its mean error after the fit below its error before);
- `screwcal --help` beside `python -c pass` (the interpreter alone: start-up's floor).
Both calibrations need scipy.optimize, whose import alone is most of their time: the line
`python -c "import scipy.optimize"` is printed as the floor they share.
Targets (issue 14): `screwcal calibrate` no slower than the peer's script and at most 80 MiB;
`screwcal --help` within 0.15 s.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.dh import dh_from_model
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist
from screwcal.studies.simulated_measurements import simulate_measurements

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from calibration import write_csv  # noqa: E402  (the benchmarks' own helper)

TIME = Path("/usr/bin/time")  # GNU time: the child's own peak, measured from a small process
# As a user runs them: with the bytecode cache written and read (some shells set
# PYTHONDONTWRITEBYTECODE, and every run would then compile our modules afresh, ~40 ms).
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def run_once(cmd: list[str]) -> tuple[float, float]:
    """Wall seconds and peak resident memory (MiB) of one process. The peak is read by GNU
    time, whose child is forked from a small process: a child forked from this interpreter
    would carry its pages (numpy, screwcal) in its own high-water mark. NaN without it."""
    with tempfile.NamedTemporaryFile("r") as report:
        wrapped = [str(TIME), "-f", "%M", "-o", report.name, *cmd] if TIME.exists() else cmd
        start = time.perf_counter()
        proc = subprocess.run(wrapped, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              env=CHILD_ENV)
        wall = time.perf_counter() - start
        if proc.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n"
                             f"{proc.stderr.decode()}")
        peak_kb = float(report.read().split()[-1]) if TIME.exists() else float("nan")
    return wall, peak_kb / 1024.0


def summary(runs: list[tuple[float, float]]) -> tuple[float, float, str]:
    """Median wall seconds, median peak MiB, and the wall time's spread as text."""
    walls = [w for w, _ in runs]
    t, m = statistics.median(walls), statistics.median(m for _, m in runs)
    spread = "one run" if len(runs) == 1 else f"{min(walls):.3f}-{max(walls):.3f}"
    return t, m, spread


def pair(label: str, ours: list[str], peer: list[str], runs: int, peer_runs: int) -> None:
    """`runs` of ours and `peer_runs` of the peer's, in turn while both last."""
    run_once(ours)  # warm the file cache
    a, b = [], []
    for k in range(max(runs, peer_runs)):
        if k < runs:
            a.append(run_once(ours))
        if k < peer_runs:
            b.append(run_once(peer))
    (ta, ma, sa), (tb, mb, sb) = summary(a), summary(b)
    print(f"{label:<34}{ta:>8.3f} s {ma:>6.1f} MiB {tb:>8.3f} s {mb:>6.1f} MiB"
          f"{ta / tb:>8.2f}x {ma / mb:>6.2f}x")
    print(f"{'  wall min-max':<34}{sa:>21}{sb:>21}")


def check_peer(cmd: list[str], out: Path) -> None:
    """The peer's fit must improve on the nominal robot before its time counts."""
    run_once(cmd)
    result = json.loads(out.read_text())
    if not result["mean_error_after_mm"] < result["mean_error_before_mm"]:
        raise SystemExit(f"the peer's calibration did not converge: {result}")
    print(f"peer check: mean error {result['mean_error_before_mm']:.3f} -> "
          f"{result['mean_error_after_mm']:.3f} mm, {result['evaluations']} evaluations "
          f"({result['method']})")


def alone(label: str, cmd: list[str], runs: int) -> None:
    run_once(cmd)
    t, m = (statistics.median(x) for x in zip(*(run_once(cmd) for _ in range(runs)),
                                               strict=True))
    print(f"{label:<34}{t:>8.3f} s {m:>6.1f} MiB   (the floor both calibrations share)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--peer-runs", type=int, default=None,
                        help="runs of the peer's calibration (default: as --runs)")
    args = parser.parse_args()
    args.peer_runs = args.runs if args.peer_runs is None else args.peer_runs
    if args.runs < 1 or args.peer_runs < 1:
        parser.error("--runs and --peer-runs must be at least 1")
    screwcal = shutil.which("screwcal", path=str(Path(sys.executable).parent)) or "screwcal"
    py = sys.executable
    rng = np.random.default_rng(0)
    model = irb1600()
    truth = apply_virtual_joints(model, THESIS_TABLE11).with_frames(
        exp_twist([0.01, -0.02, 0.03, 5, -3, 2]), exp_twist([0, 0, 0, 30, -20, 80]))
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    print(f"{'medians: ours ' + str(args.runs) + ', peer ' + str(args.peer_runs) + ' runs':<34}"
          f"{'ours':>17}{'peer':>19}{'ours / peer':>16}")
    with tempfile.TemporaryDirectory() as tmp:
        csv_path, robot_path = Path(tmp) / "m40.csv", Path(tmp) / "robot.json"
        write_csv(csv_path, data)
        mdh = dh_from_model(model, "mdh")
        if not np.allclose(mdh.dh_base, np.eye(4)):
            raise SystemExit("the peer's chain starts at the robot base: dh_base must be I")
        robot_path.write_text(json.dumps({
            "mdh": [[r.alpha, r.a_mm, r.theta, r.d_mm] for r in mdh.rows],
            "flange": mdh.dh_flange.tolist()}))
        ours = [screwcal, "calibrate", "--robot", "irb1600", "--data", str(csv_path),
                "--out", str(Path(tmp) / "ours.json")]
        try:
            import pybotics  # noqa: F401
        except ImportError:
            print("calibrate: pybotics not installed, pair skipped (pip install -e '.[peers]')")
        else:
            peer = [py, str(HERE / "peer_calibrate.py"), str(robot_path), str(csv_path),
                    str(Path(tmp) / "peer.json")]
            check_peer(peer, Path(tmp) / "peer.json")
            pair("calibrate, 40 poses", ours, peer, args.runs, args.peer_runs)
        alone("python -c 'import scipy.optimize'", [py, "-c", "import scipy.optimize"],
              args.runs)
        pair("screwcal --help vs python", [screwcal, "--help"], [py, "-c", "pass"], args.runs,
             args.runs)


if __name__ == "__main__":
    main()
