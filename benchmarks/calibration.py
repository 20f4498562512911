"""Benchmark: calibration in-process and as a whole `screwcal calibrate` process, LM and DE.

    .venv/bin/python benchmarks/calibration.py [--repeat 7]

The median of `repeat` runs with the fastest and slowest (not the best run: issue 29), BLAS
threads as shipped. In-process rows name what they estimate; "as the command" is what
`screwcal calibrate` runs by default (compliance and lag auto: each fitted, kept if it pays).
Targets (issue 3): LM on 40 poses <= 20 ms in-process, 1,000 poses <= 0.5 s, DE on 40 poses
<= 10 s (one run).
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from measured_robot import table11_robot_in_a_cell  # the benchmarks' own robot
from timing import median_of  # the benchmarks' own helper

from screwcal.calibration.identify import identify
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.posesets import random_configurations
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation
from screwcal.kinematics.robots import irb1600
from screwcal.runtime.policy import for_worker
from screwcal.studies.simulated_measurements import simulate_measurements


def write_csv(path: Path, data: MeasurementSet) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "rx", "ry", "rz"])
        rxyz = euler_zyx_deg_from_rotation(data.rotations)
        for q, p, r in zip(np.degrees(data.q), data.positions_mm, rxyz, strict=True):
            w.writerow([f"{v:.8f}" for v in (*q, *p, *r)])


def main() -> None:
    for_worker()  # one BLAS thread, the heap kept: a one-threaded program's door
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--poses", type=int, default=1000, help="the large data set's size")
    parser.add_argument("--no-de", action="store_true", help="skip the DE row")
    args = parser.parse_args()
    if args.repeat < 3:
        parser.error("--repeat: at least 3 runs (a median with its spread)")
    rng = np.random.default_rng(0)
    truth = table11_robot_in_a_cell()
    d40 = simulate_measurements(truth, random_configurations(40, rng), rng)
    big = args.poses
    d1000 = simulate_measurements(truth, random_configurations(big, rng), rng)
    nominal = irb1600()
    rows: list[tuple[str, Callable[[], object], float | None]] = [
        ("LM thesis model, 40 poses, no comp./lag",
         lambda: identify(nominal, d40, kind="thesis"), None),
        ("LM full model, 40 poses, no comp./lag",
         lambda: identify(nominal, d40, kind="full"), None),
        ("LM full, 40 poses, as the command", lambda: identify(
            nominal, d40, kind="full", compliance="auto", lag="auto"), 0.020),
        (f"LM full, {big} poses, as the command", lambda: identify(
            nominal, d1000, kind="full", compliance="auto", lag="auto"), 0.5),
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for n, data in ((40, d40), (big, d1000)):
            path = Path(tmp) / f"m{n}.csv"
            write_csv(path, data)
            cmd = [sys.executable, "-m", "screwcal", "calibrate", "--robot", "irb1600",
                   "--data", str(path), "--out", str(Path(tmp) / "r.json")]
            rows.append((f"screwcal calibrate process, {n} poses",
                         lambda cmd=cmd: subprocess.run(cmd, check=True, capture_output=True),
                         None))
        print(f"{'benchmark':<42}{'median (min-max), ' + str(args.repeat) + ' runs':>30}"
              f"{'target':>10}")
        for label, fn, target in rows:
            t = median_of(args.repeat, fn)
            verdict = "" if target is None else f"{target * 1e3:>7.0f} ms " + (
                "ok" if t.median <= target else "MISSED")
            print(f"{label:<42}{t.ms():>30} {verdict}")
        if args.no_de:
            return
        start = time.perf_counter()
        identify(nominal, d40, kind="thesis", frames="unknown", solver="de")
        t = time.perf_counter() - start
        print(f"{'DE thesis model, 40 poses (one run)':<42}{t * 1e3:>27.1f} ms {10_000:>7.0f} ms "
              + ("ok" if t <= 10 else "MISSED"))


if __name__ == "__main__":
    main()
