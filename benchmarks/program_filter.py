"""Benchmark: `screwcal compensate --program` on a program of 10,000 targets of each language
(KUKA KRL, FANUC LS, URScript), as a whole process.

    .venv/bin/python benchmarks/program_filter.py [--targets 10000] [--repeat 5]

Target (issue 42): 10,000 targets of each language in <= 2 s, start-up included: the median of
`--repeat` runs after a warm-up, with the fastest and slowest, wall and CPU time. The targets
are random configurations of the KR 16, the LR Mate 200iD and the UR5e (a walk of small steps
for the UR, whose targets carry no flags) with their flags, in a tool and a frame; the
calibrated model is the nominal with 0.3 mm / 0.02 deg errors.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
from timing import cpu_seconds, median_of  # the benchmarks' own helper

from screwcal.calibration.program_filter import CONVENTIONS, world_frame
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.ik_branches import all_branches
from screwcal.kinematics.maker_configs import branch_index, fanuc_config, kuka_status_turn
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation
from screwcal.kinematics.robots import builtin_model
from screwcal.kinematics.se3 import invert_transform, rotvec_from_rotation

ROBOTS = {"krl": "kr16", "fanuc": "lrmate200id", "urscript": "ur5e"}


def _configurations(robot: str, n: int, rng: np.random.Generator) -> np.ndarray:
    nominal = builtin_model(robot)
    if robot == "ur5e":
        steps = rng.uniform(-0.05, 0.05, (n, 6))
        return np.radians([10.0, -100.0, 90.0, -80.0, -90.0, 20.0]) + np.cumsum(steps, 0) * 0.1
    lo, hi = nominal.limits[:, 0], nominal.limits[:, 1]
    q = rng.uniform(lo * 0.7, hi * 0.7, (n, 6))
    q[:, 4] = np.where(np.abs(q[:, 4]) < 0.3, 0.6, q[:, 4])  # away from the wrist singularity
    return q


def program(language: str, n: int, rng: np.random.Generator) -> dict[str, str]:
    """The files of a program of n targets."""
    nominal = builtin_model(ROBOTS[language])
    q = _configurations(ROBOTS[language], n, rng)
    conv = CONVENTIONS[language]
    T0 = flange_kinematics(nominal, q)
    T = invert_transform(world_frame(language, nominal)) @ T0 @ invert_transform(
        conv.flange_to_tool0)
    xyz = T[:, :3, 3] / conv.mm_per_unit
    branch = branch_index(all_branches(nominal, T0), q)
    if language == "urscript":
        rv = rotvec_from_rotation(T[:, :3, :3])
        moves = "".join(f"  movel(p[{x:.7f}, {y:.7f}, {z:.7f}, {a:.8f}, {b:.8f}, {c:.8f}])\n"
                        for (x, y, z), (a, b, c) in zip(xyz, rv, strict=True))
        return {"bench.script": f"def bench():\n{moves}end\n"}
    rxyz = euler_zyx_deg_from_rotation(T[:, :3, :3])
    if language == "krl":
        s, t = kuka_status_turn(q, branch)
        decl = "".join(f"DECL E6POS XP{k}={{X {x:.4f},Y {y:.4f},Z {z:.4f},A {rz:.5f},B {ry:.5f},"
                       f"C {rx:.5f},S {s[k]},T {t[k]},E1 0.0}}\n"
                       for k, ((x, y, z), (rx, ry, rz)) in enumerate(zip(xyz, rxyz, strict=True)))
        moves = "".join(f"PTP XP{k}\n" for k in range(n))
        return {"bench.dat": f"DEFDAT bench\n{decl}ENDDAT\n",
                "bench.src": f"DEF bench()\n{moves}END\n"}
    configs = fanuc_config(q, branch)
    pos = "".join(f"P[{k + 1}]{{\n   GP1:\n\tUF : 0, UT : 0,\t\tCONFIG : '{c.text()}',\n"
                  f"\tX = {x:.4f}  mm,\tY = {y:.4f}  mm,\tZ = {z:.4f}  mm,\n"
                  f"\tW = {rx:.5f} deg,\tP = {ry:.5f} deg,\tR = {rz:.5f} deg\n}};\n"
                  for k, ((x, y, z), (rx, ry, rz), c) in
                  enumerate(zip(xyz, rxyz, configs, strict=True)))
    mn = "".join(f"{k + 1:5d}:J P[{k + 1}] 100% FINE    ;\n" for k in range(n))
    return {"bench.ls": f"/PROG  BENCH\n/ATTR\n/MN\n{mn}/POS\n{pos}/END\n"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--targets", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    for language, robot in ROBOTS.items():
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            files = program(language, args.targets, rng)
            for name, text in files.items():
                (folder / name).write_text(text)
            nominal = builtin_model(robot)
            shifted = nominal.axis_points_mm + rng.normal(0, 0.3, (6, 3))  # axes 0.3 mm off
            save_model(replace(nominal, axis_points_mm=shifted), folder / "model.json")
            cmd = [sys.executable, "-m", "screwcal", "compensate", "--result",
                   str(folder / "model.json"), "--robot", robot, "--program",
                   *(str(folder / name) for name in files), "--out", str(folder / "out")]
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode not in (0, 3):
                raise SystemExit(f"compensate failed ({done.returncode}): {done.stderr}")
            cpu: list[float] = []
            wall = median_of(args.repeat, lambda cmd=cmd, cpu=cpu: cpu.append(cpu_seconds(cmd)))
        cpu = sorted(cpu[1:])  # the warm-up's left out, as median_of does
        first = done.stdout.split(": ", 1)[1].splitlines()[0]
        verdict = "ok" if wall.median <= 2.0 else "MISSED"
        print(f"{language:8s} {robot:12s} {first}\n    {args.targets} targets, {wall.runs} runs: "
              f"wall {wall.median:.2f} s ({wall.low:.2f}-{wall.high:.2f}), CPU "
              f"{statistics.median(cpu):.2f} s ({cpu[0]:.2f}-{cpu[-1]:.2f}) (target 2 s) "
              f"{verdict}")


if __name__ == "__main__":
    main()
