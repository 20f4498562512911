"""`screwcal study NAME|all`: the simulated calibration studies (thesis Chapter 3), the
distance-only calibration of Appendix D and the Chapter 5 experiment, measured as the thesis
measured them.

What each study does and how it compares with the thesis: `screwcal.studies.study`.
"""

from __future__ import annotations

import argparse
import time

from screwcal.arguments import positive_int
from screwcal.commands.options import make_output_folder

# The studies' names, for --help without importing the studies (a test holds them to
# screwcal.studies.study.STUDIES).
STUDY_NAMES = ("planar", "table8", "table9", "solvers", "weight", "replications",
               "configurations", "quadrants", "design", "appendix-d", "chapter5")


def run(args: argparse.Namespace) -> int:
    from screwcal.studies.study import STUDIES, run_study

    names = list(STUDIES) if args.name == "all" else [args.name]
    out = make_output_folder(args.out)
    start = time.perf_counter()
    for name in names:
        print(run_study(name, args.seed, args.samples, args.workers, out,
                        args.scheduler))
    print(f"{len(names)} studies in {time.perf_counter() - start:.1f} s -> {args.out}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("study", help="simulated calibration studies (thesis Chapter 3)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("name", choices=[*STUDY_NAMES, "all"], help="the study, or all of them")
    p.add_argument("--seed", type=int, default=2018, help="random seed (default 2018)")
    p.add_argument("--samples", type=positive_int, default=20,
                   help="random samples of the study, one seed each (default 20)")
    p.add_argument("--workers", type=positive_int, default=2,
                   help="processes run in parallel (default 2)")
    p.add_argument("--out", default="studies", help="folder for the tables and figures "
                   "(default ./studies)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the samples on a Dask distributed cluster (tcp://host:port; "
                   "needs the extra: pip install 'screwcal[cluster]')")
    p.set_defaults(func=run)
