"""The `screwcal` console script: a thin face that only dispatches to each command's module.

It is the one place that imports across packages (ARCHITECTURE.md): the core owns calibrate,
predict, evaluate, ...; the simulators own `emulator`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from screwcal import __version__
from screwcal.commands import calibrate, evaluate, predict, simulate, study, testcube
from screwcal.errors import ScrewcalError
from service import cli as service_cli
from service import demo as service_demo
from service.errors import ServiceError
from simulators import cli as simulators_cli


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="screwcal",
        description="Screw-theory calibration of 6-axis industrial robots (mm and degrees).")
    parser.add_argument("--version", action="version", version=f"screwcal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for module in (simulate, calibrate, predict, evaluate, testcube, study,
                   service_demo,
                   simulators_cli, service_cli):
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except (ScrewcalError, ServiceError) as err:
        print(f"screwcal {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"screwcal {args.command}: interrupted", file=sys.stderr)
        return 130
