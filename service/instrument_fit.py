"""How a job's measurements are fitted, by what its instrument measured: three points a pose
(the arm's holes, three SMRs) give the flange's pose, fitted in the robot's base frame as the
thesis does; one point a pose (a tracker's SMR, an external instrument's target) gives positions
only: where the point sits on the flange is identified too, starting from where the robot's
record says it is; a tracker's points are weighted by the covariance each was stated with plus
what the data show beyond it along and across the beam (`calibration.beam_weighting`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from screwcal.calibration.beam_weighting import BeamFit, identify_beam_weighted
from screwcal.calibration.identify import CalibrationResult, Frames, identify
from screwcal.calibration.measurements import MeasurementSet
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import parse_model
from screwcal.kinematics.se3 import Array
from service.robot_record import RobotRecord, TrackerSetup


def point_frame(robot: RobotRecord) -> Array:
    """tool0 -> the one point the instrument measures, as the robot's record states it."""
    frame = np.eye(4)
    frame[:3, 3] = robot.targets_mm()[0]
    return frame


def fit(nominal: SerialModel, data: MeasurementSet, robot: RobotRecord,
        **options: Any) -> tuple[CalibrationResult, BeamFit | None, Frames]:
    """The identification of `data` (options: identify's kind, compliance, lag), the beam
    levels of a tracker's fit, and the frames it identified."""
    frames: Frames = "base"
    if data.rotations is None:
        nominal = nominal.with_frames(tool=point_frame(robot))
        frames = "unknown"
    if data.rotations is None and data.position_cov_mm2 is not None and \
            isinstance(robot.instrument, TrackerSetup):
        beam = identify_beam_weighted(nominal, data, frames=frames, **options)
        return beam.result, beam, frames
    return identify(nominal, data, frames=frames, **options), None, frames


def measured_point(robot: RobotRecord, calibration: dict[str, Any] | None) -> Array:
    """Of one-point data: the point in tool0 the calibration identified (else the record's)."""
    tool = parse_model(calibration["model"]).tool if calibration else point_frame(robot)
    return np.asarray(tool[:3, 3], dtype=float)
