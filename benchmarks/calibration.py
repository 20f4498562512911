"""Benchmark: calibration in-process and as a whole `screwcal calibrate` process, LM and DE.

    .venv/bin/python benchmarks/calibration.py [--repeat 7]

Best of `repeat` runs, BLAS threads as shipped. Targets (issue 3): LM on 40 poses <= 20 ms
in-process, 1,000 poses <= 0.5 s, DE on 40 poses <= 10 s.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from timing import best_of  # the benchmarks' own helper

from screwcal.calibration.identify import identify
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist
from screwcal.studies.simulate import simulate_measurements


def write_csv(path: Path, data: MeasurementSet) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "rx", "ry", "rz"])
        rxyz = euler_zyx_deg_from_rotation(data.rotations)
        for q, p, r in zip(np.degrees(data.q), data.positions_mm, rxyz, strict=True):
            w.writerow([f"{v:.8f}" for v in (*q, *p, *r)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11).with_frames(
        exp_twist([0.1, -0.2, 0.3, 1500, -300, 200]), exp_twist([0, 0, 0, 30, -20, 80]))
    d40 = simulate_measurements(truth, random_configurations(40, rng), rng)
    d1000 = simulate_measurements(truth, random_configurations(1000, rng), rng)
    nominal = irb1600()
    rows: list[tuple[str, Callable[[], object], float | None]] = [
        ("LM thesis model, 40 poses", lambda: identify(nominal, d40, kind="thesis"), 0.020),
        ("LM full model, 40 poses", lambda: identify(nominal, d40, kind="full"), 0.020),
        ("LM full model, 1000 poses", lambda: identify(nominal, d1000, kind="full"), 0.5),
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for n, data in ((40, d40), (1000, d1000)):
            path = Path(tmp) / f"m{n}.csv"
            write_csv(path, data)
            cmd = [sys.executable, "-m", "screwcal", "calibrate", "--robot", "irb1600",
                   "--data", str(path), "--out", str(Path(tmp) / "r.json")]
            rows.append((f"screwcal calibrate process, {n} poses",
                         lambda cmd=cmd: subprocess.run(cmd, check=True, capture_output=True),
                         None))
        print(f"{'benchmark':<42}{'best':>12}{'target':>10}")
        for label, fn, target in rows:
            t = best_of(args.repeat, fn)
            verdict = "" if target is None else f"{target * 1e3:>7.0f} ms " + (
                "ok" if t <= target else "MISSED")
            print(f"{label:<42}{t * 1e3:>9.1f} ms {verdict}")
        t = best_of(1, lambda: identify(nominal, d40, kind="thesis", frames="unknown",
                                        solver="de"))
        print(f"{'DE thesis model, 40 poses':<42}{t * 1e3:>9.1f} ms {10_000:>7.0f} ms "
              + ("ok" if t <= 10 else "MISSED"))


if __name__ == "__main__":
    main()
