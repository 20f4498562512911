"""Small real sets: how well 36 position-only poses of the real IRB 120 predict new ones
(issue 26, point 6).

    python -m screwcal.studies.small_sets [--data DIR] [--subsets 12] [--poses 36]

Each subset is `--poses` random poses of the tracker set (reflector 1's position only), split
into three folds; each fold is predicted by a fit of the other two (24 poses), and the held-out
mean position error of all folds is the subset's figure. Fits compared:
- "plain": the full model by plain least squares (no prior, no outlier rejection, no compliance
  or lag): the yardstick;
- "plausible scale": identify's defaults with the prior at the plausible ranges' scale;
- "learned scale": identify's defaults (on a set this small the prior's scale is learned from
  the data, `calibration.empirical_prior`);
- "thesis": the thesis's virtual joints, identify's defaults otherwise;
- "600 other poses": identify's defaults on 600 poses outside the subset: the floor a small
  fit approaches (the robot's repeatability and what no model of ours represents).
Each figure is also given as a share of "plain"'s.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np

from screwcal.calibration.identify import CalibrationResult, identify
from screwcal.calibration.measurements import MeasurementSet
from screwcal.errors import DataFileError
from screwcal.kinematics.robots import irb120
from screwcal.studies.markdown import markdown_table
from screwcal.studies.tracker_dataset import (
    add_data_argument,
    locate_dataset,
    read_tracker_dataset,
)
from screwcal.studies.tracker_study import position_errors

FOLDS = 3
FLOOR_POSES = 600
Fit = Callable[[MeasurementSet], CalibrationResult]
FITS: dict[str, Fit] = {
    "plain": lambda d: identify(irb120(), d, compliance="none", lag="none", plausible=None,
                                outliers="keep"),
    "plausible scale": lambda d: identify(irb120(), d, prior_scale="plausible"),
    "learned scale": lambda d: identify(irb120(), d),
    "thesis": lambda d: identify(irb120(), d, kind="thesis"),
}
FLOOR = f"{FLOOR_POSES} other poses"


def run(data: MeasurementSet, subsets: int = 12, poses: int = 36, seed: int = 100
        ) -> dict[str, list[float]]:
    """Per fit, the held-out mean error (mm) of each subset."""
    out: dict[str, list[float]] = {name: [] for name in [*FITS, FLOOR]}
    for r in range(subsets):
        perm = np.random.default_rng(seed + r).permutation(len(data))
        folds = np.array_split(perm[:poses], FOLDS)
        floor = identify(irb120(), data.take(np.sort(perm[poses:poses + FLOOR_POSES])))
        errors: dict[str, list[np.ndarray]] = {name: [] for name in out}
        for f in range(FOLDS):
            held = data.take(np.sort(folds[f]))
            fitted = data.take(np.sort(np.concatenate([folds[g] for g in range(FOLDS)
                                                       if g != f])))
            for name, fit in FITS.items():
                errors[name].append(position_errors(fit(fitted), held))
            errors[FLOOR].append(position_errors(floor, held))
        for name, e in errors.items():
            out[name].append(float(np.concatenate(e).mean()))
    return out


def format_table(results: dict[str, list[float]], poses: int) -> str:
    plain = float(np.mean(results["plain"]))
    rows = []
    for name, values in results.items():
        v = np.array(values)
        rows.append((name, f"{v.mean():.4f}", f"{v.min():.4f}-{v.max():.4f}",
                     f"{v.mean() / plain:.3f}"))
    return "\n".join([f"{len(results['plain'])} subsets of {poses} position-only poses, "
                      f"{FOLDS}-fold (fits on {poses - poses // FOLDS} poses); held-out mean "
                      "error, mm",
                      *markdown_table(("fit", "mean over subsets", "min-max", "share of plain"),
                                      rows)])


def parser() -> argparse.ArgumentParser:
    """`python -m screwcal.studies.small_sets`'s options."""
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    add_data_argument(p)
    p.add_argument("--subsets", type=int, default=12, help="random subsets (default 12)")
    p.add_argument("--poses", type=int, default=36, help="poses per subset (default 36)")
    return p


def main() -> None:
    parser_ = parser()
    args = parser_.parse_args()
    if args.subsets < 1 or args.poses < 3 * FOLDS:
        parser_.error(f"--subsets must be at least 1 and --poses at least {3 * FOLDS}")
    try:
        data = read_tracker_dataset(locate_dataset(args.data)).measurements(full_pose=False)
    except DataFileError as err:  # the data set is not there, or not readable
        parser_.exit(2, f"error: {err}\n")
    print(format_table(run(data, args.subsets, args.poses), args.poses))


if __name__ == "__main__":
    main()
