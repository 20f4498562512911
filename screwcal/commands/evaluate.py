"""`screwcal evaluate`: ISO 9283 pose accuracy and repeatability from a performance test file.

    screwcal evaluate --data performance.csv --out report.json [--before before.csv]
                      [--path line.csv [--path-before line0.csv]] [--plots DIR]

`performance.csv` columns (any order, extra ignored): cycle, point, q1..q6, x_cmd, y_cmd, z_cmd,
rx_cmd, ry_cmd, rz_cmd, x, y, z[, rx, ry, rz] — commanded and attained poses in mm and degrees.
Every point needs >= 2 cycles, one row per (point, cycle), and one commanded pose.
`line.csv` holds x, y, z (mm) of points measured along a commanded straight line (straightness).
With `--before`, the report and plots compare the two (e.g. before and after calibration).
"""

from __future__ import annotations

import argparse

from screwcal.arguments import check_outputs
from screwcal.commands.options import make_output_folder


def run(args: argparse.Namespace) -> int:
    from screwcal.performance.evaluate import (
        build_report,
        point_metrics,
        read_path_csv,
        read_performance_csv,
    )
    from screwcal.performance.straightness import straightness
    from screwcal.tables import write_json_atomic

    check_outputs([args.out], [args.data, args.before, args.path, args.path_before])
    folder = make_output_folder(args.plots, "--plots") if args.plots else None
    after = read_performance_csv(args.data, args.length_unit)
    before = read_performance_csv(args.before, args.length_unit) if args.before else None
    line = straightness(read_path_csv(args.path)) if args.path else None
    line_before = straightness(read_path_csv(args.path_before)) if args.path_before else None
    report = build_report(after, before, line, line_before)
    if folder is not None:
        from screwcal.performance import plots

        results = {"after": point_metrics(after)} if before is None else \
            {"before": point_metrics(before), "after": point_metrics(after)}
        written = [plots.accuracy_per_point(results, folder / "accuracy_per_point.png"),
                   plots.attained_vs_commanded(after.commanded_mm, after.attained_mm,
                                               folder / "attained_vs_commanded.png")]
        if line is not None:
            lines = {"after": line} if line_before is None else {"before": line_before,
                                                                 "after": line}
            written.append(plots.straightness_along_path(lines, folder / "straightness.png"))
        report["plots"] = [str(p) for p in written]
    write_json_atomic(args.out, report)
    overall = report["result"]["overall"]
    print(f"{overall['points']} points: AP mean {overall['ap_mm_mean']:.3f} mm, max "
          f"{overall['ap_mm_max']:.3f} mm; RP max {overall['rp_mm_max']:.3f} mm -> {args.out}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("evaluate", help="ISO 9283 pose accuracy/repeatability and straightness",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="performance test CSV (see above)")
    p.add_argument("--out", required=True, help="report JSON to write")
    p.add_argument("--before", help="a second performance CSV to compare with (e.g. before)")
    p.add_argument("--path", help="CSV of x, y, z measured along a straight line")
    p.add_argument("--path-before", help="the same line measured before, for comparison")
    p.add_argument("--plots", help="folder for PNG plots")
    p.add_argument("--length-unit", choices=["mm", "m", "in"], default="mm",
                   help="unit of the files' positions (default mm; positions that look like "
                   "metres are refused), as calibrate's")
    p.set_defaults(func=run)

