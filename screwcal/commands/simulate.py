"""`screwcal simulate`: a simulated offline calibration of an IRB 1600, before/after table.

A "true" robot is the nominal IRB 1600 with the thesis's Table 11 errors (joint and link offsets,
plus, with --seed, small random tilts and shifts of every axis). It is "measured" at 40 random
poses (full flange pose, 0.013 mm position noise, random joint error uniform +-0.05 deg, as
Table 2), the screw model is fitted, and both models are compared on 200 unseen poses.

    screwcal simulate --out measurements.csv

`--out` writes the calibration poses as measured: the measurement file `screwcal calibrate
--data` takes (the flange in the robot base frame: full pose, mm and degrees).
"""

from __future__ import annotations

import argparse

from screwcal.arguments import check_outputs, positive_int


def run(args: argparse.Namespace) -> int:
    from screwcal.studies.simulated_calibration import format_report, run_demo

    check_outputs([args.out], [])
    result = run_demo(args.seed, args.poses, args.validation)
    print(format_report(result, args.poses, args.validation))
    if args.out and result.measurements is not None:
        from screwcal.calibration.measurements import write_measurements_csv
        from screwcal.kinematics.robots import irb1600

        write_measurements_csv(args.out, result.measurements, irb1600())
        print(f"  the {args.poses} calibration poses as measured -> {args.out} (screwcal "
              f"calibrate --robot irb1600 --data {args.out} --out result.json)")
    return 0 if result.fit.converged else 1



def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="a simulated offline calibration, before/after",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=None,
                   help="also impose random axis errors drawn from this seed")
    p.add_argument("--poses", type=positive_int, default=40, help="calibration poses (default 40)")
    p.add_argument("--validation", type=positive_int, default=200,
                   help="unseen validation poses (default 200)")
    p.add_argument("--out", default=None, metavar="CSV",
                   help="write the calibration poses as measured: a measurement file for "
                   "screwcal calibrate --data")
    p.set_defaults(func=run)
