"""Benchmark: identification's own cost (issue 29, point 4) against one numpy least-squares
solve of the same size.

    .venv/bin/python benchmarks/identify_cost.py [--poses 1000] [--rounds 5]

1000 full poses of a true IRB 1600 with the thesis's link offsets and errors (as
`benchmarks/calibration.py`), identified as `screwcal calibrate` does by default (full model,
noise levels estimated, outliers tested, compliance and lag auto: here two fits, with and
without the joint-2/3 compliance).
The yardstick is `numpy.linalg.lstsq` of a random matrix with the identification's rows (6 per
pose) and its identified parameters' count, once with one BLAS thread (as the identification
runs under the doors' policy: `screwcal.runtime.policy`) and once with the threads as shipped.
All three alternate for `--rounds` rounds; medians with min and max, and the ratios of the
medians (target <= 40 against the one-thread solve); then the identification and the one-thread
solve again in CPU time (`time.process_time`), which a busy host's other work does not inflate.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from measured_robot import table11_robot_in_a_cell  # the benchmarks' own robot
from threadpoolctl import ThreadpoolController
from timing import interleaved  # the benchmarks' own helper

from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.kinematics.robots import irb1600
from screwcal.runtime.heap import keep_freed_memory
from screwcal.studies.simulated_measurements import simulate_measurements


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--poses", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (>= 5)")
    args = parser.parse_args()
    if args.rounds < 5:
        parser.error("--rounds: at least 5 (interleaved medians with their spread)")
    rng = np.random.default_rng(0)
    truth = table11_robot_in_a_cell()
    data = simulate_measurements(truth, random_configurations(args.poses, rng), rng)
    nominal = irb1600()

    keep_freed_memory()  # the heap as the doors keep it (screwcal.runtime.policy)
    blas = ThreadpoolController()  # found once: its lookup is not the solve's cost

    def run() -> object:  # one BLAS thread, as the doors set it (screwcal.runtime.policy)
        with blas.limit(limits=1, user_api="blas"):
            return identify(nominal, data, compliance="auto", lag="auto")

    result = identify(nominal, data, compliance="auto", lag="auto")
    m, p = 6 * len(data), result.rank
    A, b = rng.normal(size=(m, p)), rng.normal(size=m)

    def solve_one_thread() -> object:
        with blas.limit(limits=1, user_api="blas"):
            return np.linalg.lstsq(A, b, rcond=None)

    def solve_as_shipped() -> object:
        return np.linalg.lstsq(A, b, rcond=None)

    t_id, t_one, t_shipped = interleaved(args.rounds, [run, solve_one_thread,
                                                       solve_as_shipped])
    c_id, c_one = interleaved(args.rounds, [run, solve_one_thread], time.process_time)
    ratio = t_id.median / t_one.median
    print(f"{args.poses} full poses as the command (compliance {result.compliance}, "
          f"{result.rank} parameters, {m} residuals), {args.rounds} interleaved rounds:")
    print(f"  identification               {t_id.ms()}")
    print(f"  lstsq ({m} x {p}), 1 thread   {t_one.ms()}")
    print(f"  lstsq, BLAS threads as shipped {t_shipped.ms()}")
    print(f"  identification / lstsq: {ratio:.0f}x one thread (target <= 40) "
          + ("ok" if ratio <= 40 else "MISSED")
          + f", {t_id.median / t_shipped.median:.0f}x as shipped")
    print(f"  CPU time (one thread both): identification {c_id.ms()}, lstsq {c_one.ms()}: "
          f"{c_id.median / c_one.median:.0f}x")


if __name__ == "__main__":
    main()
