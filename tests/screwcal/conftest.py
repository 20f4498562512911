"""Every result `screwcal calibrate` writes in these tests is read by the commands that take
one (tests/screwcal/result_followers.py): a result the next command refuses fails its test."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _calibration_results_are_followed(monkeypatch):
    import screwcal.commands.calibrate as calibrate
    from tests.screwcal.result_followers import follow_result

    original = calibrate.run_calibrate

    def run_and_follow(args: argparse.Namespace) -> int:
        code = original(args)
        if code == 0 and Path(args.out).is_file():
            refused = follow_result(Path(args.out))
            assert not refused, f"{args.out}: " + "\n".join(refused)
        return code

    monkeypatch.setattr(calibrate, "run_calibrate", run_and_follow)
