"""`screwcal testcube`: the ISO 9283 test cube that fits the robot, and its performance pose list.

    screwcal testcube --robot irb1600 --out perf.csv [--edge-mm 400] [--plot cube.png]

The cube, its inclined plane and P1-P5 are described in `screwcal.performance.testcube`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from screwcal.arguments import (
    add_option,
    add_vector,
    check_outputs,
    finite_float,
    positive_float,
    positive_int,
)
from screwcal.errors import DataFileError


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from screwcal.kinematics.modelfile import resolve_model
    from screwcal.performance.testcube import (
        FLANGE_DOWN_DEG,
        ArmSphere,
        find_test_cube,
        performance_pose_list,
        write_pose_list,
    )

    check_outputs([args.out, args.plot], [args.robot])
    if args.plot and Path(args.plot).suffix.lower() not in ("", ".png"):
        raise DataFileError(args.plot, "--plot writes a PNG: name a .png file")
    model = resolve_model(args.robot)
    arm = ArmSphere(tuple(args.arm_centre_mm), args.arm_radius_mm) if args.arm_centre_mm \
        else None
    cube = find_test_cube(model, args.edge_mm,
                          orientation_deg=args.orientation_deg or FLANGE_DOWN_DEG,
                          approach_mm=args.approach_mm, arm=arm, floor_z_mm=args.floor_z_mm,
                          centre_mm=args.centre_mm)
    plans = performance_pose_list(model, cube, args.cycles)
    write_pose_list(args.out, plans)
    c = cube.centre_mm
    print(f"cube edge {cube.edge_mm:.1f} mm, centre ({c[0]:.1f}, {c[1]:.1f}, {c[2]:.1f}) mm; "
          f"{len(plans)} poses ({args.cycles} cycles x 5 points x return + target) -> {args.out}")
    for label, p in cube.points_mm.items():
        print(f"  {label}: ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm")
    if args.plot:
        q_p1 = np.radians(next(p.q_deg for p in plans if p.point == "P1" and p.role == "target"))
        from screwcal.performance import plots  # matplotlib: 2 s of imports, for --plot only

        print(f"  plot -> {plots.test_cube(model, cube, q_p1, args.plot, arm)}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("testcube", help="ISO 9283 test cube and the performance pose list",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robot", required=True,
                   help="library robot (screwcal robot list) or robot / model "
                   "file")
    p.add_argument("--out", required=True, help="pose list CSV to write")
    p.add_argument("--edge-mm", type=positive_float, default=None,
                   help="cube edge (default: the largest that fits)")
    add_vector(p, "--centre-mm", renamed=["--centre"],
               help="use the cube with this centre (robot base frame; needs --edge-mm)")
    p.add_argument("--cycles", type=positive_int, default=30, help="measuring cycles (default 30)")
    add_vector(p, "--orientation-deg", renamed=["--orientation"], metavar=("RX", "RY", "RZ"),
               help="tool orientation (default flange down)")
    add_vector(p, "--approach-mm", renamed=["--approach"], default=(0.0, 0.0, 50.0),
               metavar=("DX", "DY", "DZ"), help="return point offset (default 0 0 50)")
    add_vector(p, "--arm-centre-mm", renamed=["--arm-centre"],
               help="measuring arm base in the robot frame: keep the cube in its reach")
    add_option(p, "--arm-radius-mm", renamed=["--arm-radius"], type=positive_float,
               default=1200.0, help="the measuring arm's reach (default 1200)")
    add_option(p, "--floor-z-mm", renamed=["--floor-z"], type=finite_float, default=0.0,
               help="lowest allowed z in the robot base frame (default 0)")
    p.add_argument("--plot", help="PNG of the cube, plane, points and robot")
    p.set_defaults(func=run)
