"""Writes the small inputs of the README's offline block (docs/examples/irb1600/): what the
documented commands cannot make themselves. The measurements come from `screwcal simulate --out`
and the tool0 targets from `screwcal predict --robot`; these are the rest:

- sweeps.csv: a point probed while joint 1 alone turns, then joint 2 (`screwcal align`);
- performance.csv, performance_before.csv: ISO 9283 runs after and before a calibration
  (`screwcal evaluate`): 10 cycles of P1-P5, attained poses 0.05 mm and 3 mm off;
- PROGRAM.mod: a RAPID module of three targets (`screwcal compensate --rapid`);
- joints.csv: joint readings to predict poses from (`screwcal predict --joints`).

The commanded poses and targets are the nominal robot's tool0 at fixed joints.

    python docs/examples/irb1600/make.py        (from the repository's root)

The robot is the nominal IRB 1600 with the thesis's Table 11 errors, seen from a measuring
system 2 m in front of it; the numbers come from a fixed seed: the same files on every run.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.confdata import confdata
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.pose import pose_from_transform
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation

HERE = Path(__file__).parent
# joints (deg) of the five ISO 9283 points and of the program's three targets
POINTS_DEG = {"P1": (0, 10, 10, 0, 60, 0), "P2": (-10, 0, 20, 0, 60, 0),
              "P3": (10, 0, 20, 0, 60, 0), "P4": (10, 20, 0, 0, 60, 0),
              "P5": (-10, 20, 0, 0, 60, 0)}
TARGETS_DEG = {"p10": (0, 10, 10, 0, 60, 0), "p20": (-30, 20, 5, 20, 50, -10),
               "p30": (35, 5, 25, -15, 45, 30)}


def sweeps(rng: np.random.Generator) -> None:
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    q1 = np.zeros((9, 6))
    q1[:, 0] = np.radians(np.linspace(-60, 60, 9))
    q1[:, 1:3] = np.radians([20, -10])
    q2 = np.zeros((9, 6))
    q2[:, 1] = np.radians(np.linspace(-30, 60, 9))
    with (HERE / "sweeps.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["joint", "q1", "x", "y", "z"])
        for joint, q in ((1, q1), (2, q2)):
            points = forward_kinematics(truth, q)[:, :3, 3] + rng.normal(0, 0.013, (9, 3))
            for qk, p in zip(q, points, strict=True):
                w.writerow([joint, f"{np.degrees(qk[0]):.3f}", *(f"{v:.4f}" for v in p)])


def performance(name: str, off_mm: float, rng: np.random.Generator) -> None:
    q_deg = np.array(list(POINTS_DEG.values()), float)
    commanded = pose_from_transform(forward_kinematics(irb1600(), np.radians(q_deg)))
    bias = rng.normal(0, off_mm, (5, 3))
    with (HERE / name).open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["cycle", "point", "q1", "q2", "q3", "q4", "q5", "q6", "x_cmd", "y_cmd",
                    "z_cmd", "rx_cmd", "ry_cmd", "rz_cmd", "x", "y", "z", "rx", "ry", "rz"])
        for cycle in range(1, 11):
            for label, q, cmd, b in zip(POINTS_DEG, q_deg, commanded, bias, strict=True):
                attained = cmd[:3] + b + rng.normal(0, 0.01, 3)
                turned = cmd[3:] + rng.normal(0, 0.002, 3)
                w.writerow([cycle, label, *(f"{v:g}" for v in q), *(f"{v:.4f}" for v in cmd),
                            *(f"{v:.4f}" for v in attained), *(f"{v:.4f}" for v in turned)])


def program() -> str:
    """A RAPID module whose robtargets are the nominal tool0 poses of TARGETS_DEG."""
    robot = irb1600()
    q = np.radians(list(TARGETS_DEG.values()))
    T = forward_kinematics(robot, q)
    lines = ["MODULE PROGRAM"]
    for name, Tk, cf in zip(TARGETS_DEG, T, confdata(robot, q), strict=True):
        p = ",".join(f"{v:.2f}" for v in Tk[:3, 3])
        quat = ",".join(f"{v:.6f}" for v in quaternion_wxyz_from_rotation(Tk[:3, :3]))
        conf = ",".join(str(int(v)) for v in cf)
        lines.append(f"  CONST robtarget {name}:=[[{p}],[{quat}],[{conf}],"
                     "[9E9,9E9,9E9,9E9,9E9,9E9]];")
    lines += ["  PROC main()", "    MoveJ p10, v500, fine, tool0;",
              "    MoveL p20, v200, fine, tool0;", "    MoveL p30, v200, fine, tool0;",
              "  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)




def main() -> None:
    rng = np.random.default_rng(1600)
    sweeps(rng)
    performance("performance.csv", 0.05, rng)
    performance("performance_before.csv", 3.0, rng)
    (HERE / "PROGRAM.mod").write_text(program())
    with (HERE / "joints.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["id", "q1", "q2", "q3", "q4", "q5", "q6"])
        for name, q in {**POINTS_DEG, **TARGETS_DEG}.items():
            w.writerow([name, *q])


if __name__ == "__main__":
    main()
