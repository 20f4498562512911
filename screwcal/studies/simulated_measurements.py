"""Simulated measurements of a "true" robot (thesis Chapter 3, Fig. 17).

The controller reports joint readings q; the true joints differ by a random error (uniform
+-joint_noise_deg, Table 2); the measuring system sees the true measured point with Gaussian
noise (0.013 mm, the FARO arm) and, for full-pose data, the orientation with the noise a frame
built from three holes `hole_spacing_mm` apart would have.
"""

from __future__ import annotations

import numpy as np

from screwcal.calibration.measurements import MeasurementSet
from screwcal.instrument import HOLE_SPACING_MM, JOINT_ERROR_DEG, POSITION_NOISE_MM
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, rotation_from_rotvec

NOISE_MM = POSITION_NOISE_MM  # the instrument's figures (screwcal/instrument.py)
JOINT_NOISE_DEG = JOINT_ERROR_DEG


def orientation_noise_rad(noise_mm: float = NOISE_MM, hole_spacing_mm: float = HOLE_SPACING_MM
                          ) -> float:
    """1-sigma orientation noise of a frame from three points this far apart (per axis)."""
    return float(noise_mm * np.sqrt(2.0) / hole_spacing_mm)


def simulate_measurements(truth: SerialModel, q: Array, rng: np.random.Generator, *,
                          noise_mm: float = NOISE_MM, joint_noise_deg: float = JOINT_NOISE_DEG,
                          full_pose: bool = True, hole_spacing_mm: float = HOLE_SPACING_MM
                          ) -> MeasurementSet:
    """Measurements of `truth` at reported joints q (N, n) rad."""
    q_true = q + np.radians(rng.uniform(-joint_noise_deg, joint_noise_deg, q.shape)) \
        * truth.is_revolute
    T = forward_kinematics(truth, q_true)
    positions = T[:, :3, 3] + rng.normal(0.0, noise_mm, (len(q), 3))
    rotations = None
    if full_pose:
        sigma = orientation_noise_rad(noise_mm, hole_spacing_mm)
        rotations = rotation_from_rotvec(rng.normal(0.0, sigma, (len(q), 3))) \
            @ T[:, :3, :3]
    return MeasurementSet(q.copy(), positions, rotations)
