"""Benchmark: FK of 100,000 configurations, closed-form IK and numerical IK of 10,000 poses,
and one pose per call.

    .venv/bin/python benchmarks/kinematics.py [--rounds 5]

Interleaved rounds (every case once per round, so a noisy host slows all alike); each case's
median with min and max over the rounds. Every IK result is checked (the residual of each
reachable branch, and the configuration the target came from among the branches) before it is
timed. Targets (issue 2): FK >= 1,000,000 poses/s, closed-form IK >= 50,000 poses/s; one pose
per call (issue 14): FK <= 10 us, closed-form IK (all eight branches) <= 60 us. The comparison
with other libraries is benchmarks/peers.py.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from screwcal.calibration.error_parameters import ErrorModel, candidate_params
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.ik import closed_form_ik, numerical_ik
from screwcal.kinematics.ik_solutions import IKSolutions
from screwcal.kinematics.robots import irb1600


def checked(sol: IKSolutions, q: np.ndarray, label: str) -> None:
    """Every reachable branch on target (1e-6 mm) and the source configuration among them."""
    worst = np.nanmax(np.where(sol.reachable, sol.residual_mm, 0.0))
    turn = np.abs((sol.q - q[:, None, :] + np.pi) % (2 * np.pi) - np.pi).max(axis=2)
    found = (turn < 1e-6).any(axis=1).mean()
    if worst > 1e-6 or found < 1.0:
        raise SystemExit(f"{label}: wrong result (worst residual {worst:.3g} mm, source "
                         f"configuration among the branches for {found:.1%} of targets)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--poses", type=int, default=100_000, help="FK batch size")
    args = parser.parse_args()
    if args.rounds < 3:
        parser.error("--rounds: a median with a spread needs at least 3")
    rng = np.random.default_rng(0)
    model = irb1600()
    lo, hi = 0.9 * model.limits[:, 0], 0.9 * model.limits[:, 1]
    q_fk = rng.uniform(lo, hi, (args.poses, 6))
    n_ik = min(10_000, args.poses)
    q_ik = q_fk[:n_ik]
    T_ik = forward_kinematics(model, q_ik)
    calibrated = apply_virtual_joints(model, THESIS_TABLE11)
    n_num = min(1000, n_ik)
    T_cal = forward_kinematics(calibrated, q_ik[:n_num])
    q1, T1 = q_fk[:1], T_ik[:1]
    checked(closed_form_ik(model, T_ik), q_ik, "closed-form IK")
    checked(closed_form_ik(model, T1), q1, "closed-form IK, one pose")
    checked(numerical_ik(calibrated, T_cal), q_ik[:n_num], "numerical IK")
    calls = 2000
    full = ErrorModel(model, tuple(candidate_params(model, "full", base=True, tool_rotation=True,
                                                    tool_position=True)))
    x0 = np.zeros(len(full.params))
    # label, poses per run, run, target (poses/s; None: none), per-call unit
    cases: list[tuple[str, int, Callable[[], object], float | None]] = [
        (f"FK, {args.poses:,} configurations", args.poses,
         lambda: forward_kinematics(model, q_fk), 1e6),
        (f"parameter Jacobian (full model), {n_ik:,}", n_ik,
         lambda: full.linearisation(x0, q_ik), None),
        (f"closed-form IK (8 branches), {n_ik:,}", n_ik, lambda: closed_form_ik(model, T_ik),
         5e4),
        (f"numerical IK (8 branches), {n_num:,}", n_num,
         lambda: numerical_ik(calibrated, T_cal), None),
        ("FK, one pose per call", calls,
         lambda: [forward_kinematics(model, q1) for _ in range(calls)], 1 / 10e-6),
        ("closed-form IK, one pose per call", calls // 10,
         lambda: [closed_form_ik(model, T1) for _ in range(calls // 10)], 1 / 60e-6),
    ]
    for _, _, fn, _ in cases:  # warm-up: imports, caches
        fn()
    times: list[list[float]] = [[] for _ in cases]
    for _ in range(args.rounds):
        for k, (_, n, fn, _) in enumerate(cases):
            start = time.perf_counter()
            fn()
            times[k].append((time.perf_counter() - start) / n)
    print(f"{'benchmark':<40}{'median per pose (min-max)':>32}{'poses/s':>13}   target")
    for (label, _, _, target), t in zip(cases, times, strict=True):
        med = statistics.median(t)
        if med >= 1e-6 or "one pose" in label:
            cell = f"{med * 1e6:.2f} us ({min(t) * 1e6:.2f}-{max(t) * 1e6:.2f})"
        else:
            cell = f"{med * 1e9:.0f} ns ({min(t) * 1e9:.0f}-{max(t) * 1e9:.0f})"
        verdict = "" if target is None else (f"{target:,.0f}/s " + ("ok" if 1 / med >= target
                                                                    else "MISSED"))
        print(f"{label:<40}{cell:>32}{1 / med:>13,.0f}   {verdict}")
    print(f"(medians of {args.rounds} interleaved rounds; every IK result checked first)")


if __name__ == "__main__":
    main()
