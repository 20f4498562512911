"""Writes the worked examples of docs/formats.md ("Programs of other makers"): for a KUKA KR 16,
a FANUC LR Mate 200iD and a UR5e, the measurements of a robot with errors (60 poses, flange
poses in the robot base frame, 0.01 mm / 0.001 deg noise) and a small program of each maker
taught on the nominal robot, with its tools and frames.

    python docs/examples/make.py        (from the repository's root; rewrites docs/examples/)

The "true" robots are the nominal ones with 0.3 mm / 0.02 deg axis errors and 0.05 deg zero
offsets, drawn from a fixed seed: the files are the same on every run.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from screwcal.calibration.program_filter import CONVENTIONS, matrices, world_frame
from screwcal.calibration.virtual_joints import perturbed_axes
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.ik_branches import all_branches
from screwcal.kinematics.maker_configs import branch_index, fanuc_config, kuka_status_turn
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, pose_from_transform
from screwcal.kinematics.readings import JointConvention, readings_from_serial
from screwcal.kinematics.robots import builtin_model
from screwcal.kinematics.se3 import invert_transform, rotvec_from_rotation

HERE = Path(__file__).parent


def _truth(nominal: SerialModel, rng: np.random.Generator) -> SerialModel:
    return perturbed_axes(nominal, rng, tilt_deg=0.02, shift_mm=0.3, zero_deg=0.05,
                          flange=False)


def _measurements(nominal: SerialModel, truth: SerialModel, rng: np.random.Generator,
                  convention: JointConvention) -> str:
    lo, hi = nominal.limits[:, 0], nominal.limits[:, 1]
    q = rng.uniform(np.maximum(lo, -2.6) * 0.7, np.minimum(hi, 2.6) * 0.7, (60, 6))
    pose = pose_from_transform(flange_kinematics(truth, q))
    pose[:, :3] += rng.normal(0, 0.01, (60, 3))
    pose[:, 3:] += rng.normal(0, 0.001, (60, 3))
    readings = np.degrees(readings_from_serial(q, convention))
    rows = ["id,q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz"]
    rows += [f"m{k},{','.join(f'{v:.5f}' for v in readings[k])},"
             f"{','.join(f'{v:.4f}' for v in pose[k])}" for k in range(60)]
    return "\n".join(rows) + "\n"


def _numbers(language: str, nominal: SerialModel, q: np.ndarray, frame: np.ndarray,
             tool: np.ndarray) -> np.ndarray:
    conv = CONVENTIONS[language]
    world = world_frame(language, nominal)
    T = invert_transform(world @ frame) @ flange_kinematics(nominal, q) @ \
        invert_transform(conv.flange_to_tool0) @ tool
    xyz = T[:, :3, 3] / conv.mm_per_unit
    if language == "urscript":
        return np.column_stack([xyz, rotvec_from_rotation(T[:, :3, :3])])
    rxyz = euler_zyx_deg_from_rotation(T[:, :3, :3])
    return np.column_stack([xyz, rxyz[:, ::-1] if language == "krl" else rxyz])


def kuka(rng: np.random.Generator) -> tuple[SerialModel, dict[str, str]]:
    nominal = builtin_model("kr16")
    q = np.radians([[0, -90, 90, 0, 45, 0], [20, -80, 100, 30, 60, -40],
                    [-30, -100, 80, -20, 70, 100], [10, -95, 95, 90, 30, -90]])
    conv = CONVENTIONS["krl"]
    tool = matrices(np.array([0, 0, 150.0, 0, 0, 0]), conv)[0]
    base = matrices(np.array([900, -250, 300.0, 15, 0, 0]), conv)[0]
    v = _numbers("krl", nominal, q, base, tool)
    s, t = kuka_status_turn(q, branch_index(all_branches(nominal, flange_kinematics(nominal, q)),
                                            q))
    dat = ["DEFDAT cell PUBLIC"]
    dat += [f"DECL E6POS XP{k + 1}={{X {a[0]:.3f},Y {a[1]:.3f},Z {a[2]:.3f},A {a[3]:.4f},"
            f"B {a[4]:.4f},C {a[5]:.4f},S {s[k]},T {t[k]},E1 0.0}}" for k, a in enumerate(v)]
    dat += [f"DECL FDAT FP{k + 1}={{TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}}" for k in range(4)]
    src = ["DEF cell( )", "BAS (#INITMOV,0 )"]
    for k in range(4):
        src += [f";FOLD PTP P{k + 1} Vel=100 % PDAT{k + 1} Tool[1] Base[1];%{{PE}}",
                f"FDAT_ACT=FP{k + 1}", "BAS(#PTP_PARAMS,100)", f"PTP XP{k + 1}", ";ENDFOLD"]
    config = ("DEFDAT $CONFIG PUBLIC\nTOOL_DATA[1]={X 0.0,Y 0.0,Z 150.0,A 0.0,B 0.0,C 0.0}\n"
              "BASE_DATA[1]={X 900.0,Y -250.0,Z 300.0,A 15.0,B 0.0,C 0.0}\nENDDAT\n")
    return nominal, {"cell.dat": "\n".join([*dat, "ENDDAT"]) + "\n",
                     "cell.src": "\n".join([*src, "END"]) + "\n", "config.dat": config}


def fanuc(rng: np.random.Generator) -> tuple[SerialModel, dict[str, str]]:
    nominal = builtin_model("lrmate200id")
    q = np.radians([[0, 10, 5, 0, -60, 0], [25, 20, 15, 40, -50, 200],
                    [-30, 5, 0, -20, 70, -30], [10, 30, 25, 60, -40, -250]])
    conv = CONVENTIONS["fanuc"]
    tool = matrices(np.array([0, 0, 120.0, 0, 0, 0]), conv)[0]
    frame = matrices(np.array([300, -100, 50.0, 0, 0, 30]), conv)[0]
    v = _numbers("fanuc", nominal, q, frame, tool)
    configs = fanuc_config(q, branch_index(all_branches(nominal, flange_kinematics(nominal, q)),
                                           q))
    mn = ["   1:  UFRAME_NUM=1 ;", "   2:  UTOOL_NUM=1 ;"]
    mn += [f"{k + 3:4d}:J P[{k + 1}] 100% FINE    ;" for k in range(4)]
    pos = [f"P[{k + 1}]{{\n   GP1:\n\tUF : 1, UT : 1,\t\tCONFIG : '{c.text()}',\n"
           f"\tX = {a[0]:9.3f}  mm,\tY = {a[1]:9.3f}  mm,\tZ = {a[2]:9.3f}  mm,\n"
           f"\tW = {a[3]:9.3f} deg,\tP = {a[4]:9.3f} deg,\tR = {a[5]:9.3f} deg\n}};"
           for k, (a, c) in enumerate(zip(v, configs, strict=True))]
    ls = "/PROG  CELL\n/ATTR\nOWNER\t\t= MNEDITOR;\nDEFAULT_GROUP\t= 1,*,*,*,*;\n/MN\n" + \
        "\n".join(mn) + "\n/POS\n" + "\n".join(pos) + "\n/END\n"
    frames = "# user and tool frames (mm, deg)\nUF,1,300.0,-100.0,50.0,0.0,0.0,30.0\n" \
        "UT,1,0.0,0.0,120.0,0.0,0.0,0.0\n"
    return nominal, {"cell.ls": ls, "frames.csv": frames}


def ur(rng: np.random.Generator) -> tuple[SerialModel, dict[str, str]]:
    nominal = builtin_model("ur5e")
    q = np.radians([[10, -100, 90, -80, -90, 20], [25, -95, 85, -75, -85, 30],
                    [40, -90, 80, -80, -90, 10], [30, -105, 100, -85, -90, 0]])
    tcp = [0.0, 0.0, 0.15, 0.0, 0.0, 0.0]
    tool = matrices(np.array(tcp), CONVENTIONS["urscript"])[0]
    v = _numbers("urscript", nominal, q, np.eye(4), tool)
    p = ["p[" + ", ".join(f"{x:.6f}" for x in row) + "]" for row in v]
    script = (f"def cell():\n  set_tcp(p[{', '.join(map(str, tcp))}])\n  approach = {p[0]}\n"
              "  movej(approach, a=1.2, v=0.5)\n"
              + "".join(f"  movel({pp}, a=1.2, v=0.25)\n" for pp in p[1:]) + "end\n")
    return nominal, {"cell.script": script}


def main() -> None:
    rng = np.random.default_rng(2018)
    makers: tuple[tuple[str, Callable[[np.random.Generator], tuple[SerialModel, dict[str, str]]],
                        JointConvention], ...] = (
        ("kuka", kuka, "serial"), ("fanuc", fanuc, "fanuc"), ("ur", ur, "serial"))
    for folder, make, convention in makers:
        nominal, files = make(rng)
        out = HERE / folder
        out.mkdir(exist_ok=True)
        files["measurements.csv"] = _measurements(nominal, _truth(nominal, rng), rng, convention)
        for name, text in files.items():
            (out / name).write_text(text)


if __name__ == "__main__":
    main()
