"""The peer's way to calibrate from a measurement file: a pybotics script (its documented
calibration recipe), run as a whole process by `benchmarks/process.py` beside `screwcal
calibrate` on the same file.

    python benchmarks/peer_calibrate.py ROBOT.json MEASUREMENTS.csv RESULT.json [METHOD]

ROBOT.json holds the robot's modified DH table and flange offset (written by process.py from
screwcal's IRB 1600, so this script imports nothing of screwcal). Every DH parameter (24), the
measured point's position on the flange (3) and the measuring frame (6), 33 parameters, are
fitted to one residual per pose (the distance between measured and predicted position, as
pybotics's `optimize_accuracy` returns it) by scipy's `least_squares` with finite differences
(pybotics gives no Jacobian). METHOD is scipy's: "trf" (its default, which pybotics's example
keeps) unless given; "lm" took 40x longer on 40 poses (issue 29).
"""

from __future__ import annotations

import csv
import json
import sys

import numpy as np
from pybotics.kinematic_chain import MDHKinematicChain
from pybotics.optimization import OptimizationHandler, compute_absolute_errors, optimize_accuracy
from pybotics.robot import Robot
from pybotics.tool import Tool
from scipy.optimize import least_squares


def main() -> None:
    robot_path, data_path, out_path = sys.argv[1:4]
    method = sys.argv[4] if len(sys.argv) > 4 else "trf"
    with open(robot_path) as f:
        spec = json.load(f)
    with open(data_path, newline="") as f:
        rows = list(csv.DictReader(f))
    qs = np.radians([[float(r[f"q{i}"]) for i in range(1, 7)] for r in rows])
    positions = np.array([[float(r[k]) for k in "xyz"] for r in rows])
    robot = Robot(MDHKinematicChain(np.array(spec["mdh"])),
                  tool=Tool(matrix=np.array(spec["flange"])))
    handler = OptimizationHandler(robot=robot, kinematic_chain_mask=True,
                                  tool_mask=[True] * 3 + [False] * 3, world_mask=True)
    before = compute_absolute_errors(qs, positions, handler.robot)
    fit = least_squares(optimize_accuracy, handler.generate_optimization_vector(),
                        args=(handler, qs, positions), method=method)
    handler.apply_optimization_vector(fit.x)
    after = compute_absolute_errors(qs, positions, handler.robot)
    with open(out_path, "w") as f:
        json.dump({"parameters": fit.x.tolist(), "method": method, "status": int(fit.status),
                   "evaluations": int(fit.nfev), "mean_error_before_mm": float(np.mean(before)),
                   "mean_error_after_mm": float(np.mean(after))}, f)
    print(f"mean position error {np.mean(before):.3f} -> {np.mean(after):.3f} mm")


if __name__ == "__main__":
    main()
