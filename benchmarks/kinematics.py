"""Benchmark: FK of 100,000 configurations, closed-form IK and numerical IK of 10,000 poses.

    .venv/bin/python benchmarks/kinematics.py [--repeat 5]

Prints the best of `repeat` runs. Targets (issue 2):
FK >= 1,000,000 poses/s, closed-form IK >= 50,000 poses/s; one pose per call (issue 14): FK
<= 10 us, closed-form IK (all eight branches) <= 60 us.
"""

from __future__ import annotations

import argparse

import numpy as np
from timing import best_of  # the benchmarks' own helper

from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.forward import forward_kinematics, parameter_jacobian
from screwcal.kinematics.ik import closed_form_ik, numerical_ik
from screwcal.kinematics.robots import irb1600


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    model = irb1600()
    q_fk = rng.uniform(model.limits[:, 0], model.limits[:, 1], (100_000, 6))
    q_ik = q_fk[:10_000]
    T_ik = forward_kinematics(model, q_ik)
    calibrated = apply_virtual_joints(model, THESIS_TABLE11)
    T_cal = forward_kinematics(calibrated, q_ik[:1000])

    rows = [
        ("FK, 100,000 configurations", 100_000, lambda: forward_kinematics(model, q_fk), 1e6),
        ("parameter Jacobian, 10,000", 10_000, lambda: parameter_jacobian(model, q_ik), None),
        ("closed-form IK (8 branches), 10,000", 10_000, lambda: closed_form_ik(model, T_ik),
         5e4),
        ("numerical IK (8 branches), 1,000", 1000, lambda: numerical_ik(calibrated, T_cal),
         None),
    ]
    q1, T1 = q_fk[:1], forward_kinematics(model, q_fk[:1])
    calls = 2000
    single = [
        ("FK, one pose per call", lambda: [forward_kinematics(model, q1) for _ in range(calls)],
         10e-6),
        ("closed-form IK, one pose per call", lambda: [closed_form_ik(model, T1)
                                                       for _ in range(calls // 10)], 60e-6),
    ]
    print(f"{'benchmark':<40}{'time':>10}{'poses/s':>14}{'target':>12}")
    for label, n, fn, target in rows:
        t = best_of(args.repeat, fn)
        rate = n / t
        verdict = "" if target is None else (f"{target:>10,.0f} " + ("ok" if rate >= target
                                                                     else "MISSED"))
        print(f"{label:<40}{t * 1e3:>8.1f} ms{rate:>14,.0f}  {verdict}")
    for (label, fn, target), n in zip(single, (calls, calls // 10), strict=True):
        per_call = best_of(args.repeat, fn) / n
        verdict = "ok" if per_call <= target else "MISSED"
        print(f"{label:<40}{per_call * 1e6:>8.1f} us{1 / per_call:>14,.0f}  "
              f"{target * 1e6:>8.0f} us {verdict}")


if __name__ == "__main__":
    main()
