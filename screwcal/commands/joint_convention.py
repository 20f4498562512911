"""`--joint-convention`: how the joint files of calibrate, predict and compensate count
joint 3 (screwcal.kinematics.readings); the model inside is always serial."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from screwcal.kinematics.model import SerialModel
    from screwcal.kinematics.readings import JointConvention


def joint_convention(args: argparse.Namespace, document: object, model: SerialModel
                     ) -> JointConvention:
    """The joint readings' convention of predict's and compensate's files: --joint-convention,
    else the one the result was calibrated with, else its robot's (readings.robot_convention)."""
    from screwcal.kinematics.readings import robot_convention

    if args.joint_convention:
        return args.joint_convention
    if isinstance(document, dict):
        settings = document.get("settings")
        if isinstance(settings, dict) and settings.get("joint_convention") in ("serial",
                                                                               "fanuc"):
            return settings["joint_convention"]
        if isinstance(document.get("robot"), str):
            return robot_convention(document["robot"])
    return robot_convention(model.name)


def add_joint_convention(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--joint-convention", choices=["serial", "fanuc"], default=None,
                   help=f"{what}: serial (each joint from the link before it) or fanuc (J3 "
                   "the forearm's angle to the horizontal: J3 = q3 - q2); default: the "
                   "robot's (fanuc for the library's FANUC arms)")
