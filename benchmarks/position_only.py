"""Benchmark: `screwcal calibrate` on 60 position-only poses of a point on joint 6's axis, as a
whole process (issue 26: converged, in at most 1 s).

    .venv/bin/python benchmarks/position_only.py [--runs 5]

A true IRB 1600 with random errors (`screwcal.studies.position_only.random_truth`), the flange
centre measured at 60 random poses (0.013 mm, joints +-0.05 deg). Each run is a fresh process
with the command line's defaults; the median wall time and every run's verdict are printed.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from screwcal.calibration.posesets import random_configurations
from screwcal.studies.position_only import random_truth
from screwcal.studies.simulated_measurements import simulate_measurements


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--poses", type=int, default=60)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    data = simulate_measurements(random_truth(rng, on_axis=True),
                                 random_configurations(args.poses, rng), rng, full_pose=False)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.csv"
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"])
            for q, p in zip(np.degrees(data.q), data.positions_mm, strict=True):
                w.writerow([f"{v:.8f}" for v in (*q, *p)])
        out = Path(tmp) / "r.json"
        times = []
        for _ in range(args.runs):
            start = time.perf_counter()
            run = subprocess.run([sys.executable, "-m", "screwcal", "calibrate", "--robot",
                                  "irb1600", "--data", str(path), "--out", str(out)],
                                 capture_output=True, text=True)
            times.append(time.perf_counter() - start)
            doc = json.loads(out.read_text())
            print(f"exit {run.returncode}, {times[-1]:.2f} s, converged "
                  f"{doc['convergence']['converged']}, chi2/dof "
                  f"{doc['convergence']['chi2_reduced']:.2f}")
    print(f"{args.poses} position-only poses, point on joint 6's axis: median "
          f"{statistics.median(times):.2f} s over {args.runs} processes (target <= 1 s)")


if __name__ == "__main__":
    main()
