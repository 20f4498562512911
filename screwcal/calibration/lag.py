"""Joint readings that lag the motion: estimated from the residuals and corrected.

A controller asked for its joints right after a move returns readings taken before the arm has
settled: each reading still carries part of the move that brought the arm there. The readings are
modelled as q_read = q_true - lambda_j (q_read - q_previous), per joint j, with q_previous the
readings of the pose measured just before (`MeasurementSet.q_previous`). `lag_increment` gives
the lambda that best explains, pose by pose, the joint errors behind the residual (the
minimum-norm joint change that would remove each residual, regressed on the previous move);
`correct_lag` applies a lambda to the readings. The identification alternates the two
(`identify(..., lag="auto")`) when the lag diagnostic flags a joint; the commanded joints, when
available, are the better cure.
"""

from __future__ import annotations

import numpy as np

from screwcal.calibration.diagnostics import explaining_joint_errors
from screwcal.calibration.measurements import MeasurementSet
from screwcal.kinematics.forward import forward_kinematics, point_jacobian, spatial_jacobian
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array


def previous_move(data: MeasurementSet) -> Array:
    """(N, n) the move that brought the arm to each pose (rad / mm; 0 where unknown)."""
    if data.q_previous is None:
        return np.zeros_like(data.q)
    return np.nan_to_num(data.q - data.q_previous)


def correct_lag(data: MeasurementSet, lag: Array) -> MeasurementSet:
    """The readings with `lag` (n,) of the previous move added back: q + lag (q - q_previous)."""
    if not np.any(lag):
        return data
    return data.with_q(data.q + np.asarray(lag) * previous_move(data))


def lag_increment(model: SerialModel, data: MeasurementSet) -> Array:
    """(n,) the lag per joint that best explains the model's position residuals on `data`
    (through the origin, over the poses whose previous move is known)."""
    step = previous_move(data)
    T = forward_kinematics(model, data.q)
    e = data.positions_mm - T[:, :3, 3]
    Jp = point_jacobian(spatial_jacobian(model, data.q), T)[:, :3, :]
    dq = explaining_joint_errors(e, Jp)
    denom = np.sum(step * step, axis=0)
    return np.where(denom > 0, np.sum(step * dq, axis=0) / np.where(denom > 0, denom, 1.0), 0.0)
