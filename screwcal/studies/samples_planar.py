"""The planar case of the simulated calibration studies (thesis 3.1, Tables 2-6): a planar
3R with two link offsets, calibrated on Table 3's three sets of four configurations.
"""

from __future__ import annotations

import functools

import numpy as np

from screwcal.calibration.identify import NoiseModel, identify
from screwcal.calibration.posesets import PLANAR_SETS_DEG
from screwcal.calibration.virtual_joints import apply_virtual_joints
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import transform_from_pose
from screwcal.kinematics.se3 import Array
from screwcal.studies.simulated_measurements import (
    JOINT_NOISE_DEG,
    NOISE_MM,
    simulate_measurements,
)
from screwcal.studies.thesis_metrics import Row, pose_errors, scored


def planar_model() -> SerialModel:
    z = (0.0, 0.0, 1.0)
    return SerialModel(name="planar 3R", joint_types=("R", "R", "R"),
                       axis_dirs=np.array([z, z, z]),
                       axis_points_mm=np.array([[0, 0, 0], [600, 0, 0], [1200, 0, 0.0]]),
                       home_flange=transform_from_pose([1800, 0, 0, 0, 0, 0]),
                       limits=np.radians([[-180, 180]] * 3))


PLANAR_ERRORS = {"J1rz": 1.0, "J2rz": 3.0, "J3rz": 2.0, "J1px": 0.3, "J2px": 0.3}  # Table 2


@functools.cache
def planar_validation_configurations() -> Array:
    """The planar case's 200 held-out configurations (200, 3) rad, uniform over a turn (seed
    98), drawn on first use (not at import) and read-only."""
    q = np.random.default_rng(98).uniform(-np.pi, np.pi, (200, 3))
    q.setflags(write=False)
    return q


def sample_planar(seed: int) -> list[Row]:
    rng = np.random.default_rng(seed)
    nominal = planar_model()
    truth = apply_virtual_joints(nominal, PLANAR_ERRORS)
    noise = NoiseModel(NOISE_MM, 1e-4, JOINT_NOISE_DEG)
    every = np.radians(np.vstack([PLANAR_SETS_DEG[n] for n in PLANAR_SETS_DEG]))
    rows = []
    for name, configs in PLANAR_SETS_DEG.items():
        q = np.radians(np.repeat(np.array(configs, float), 2, axis=0))  # two replications
        data = simulate_measurements(truth, q, rng, hole_spacing_mm=1e9)
        r = identify(nominal, data, kind="thesis", frames="known", noise=noise,
                     link_offsets=("J1px", "J2px"))
        q4 = np.radians(np.array(configs, float))
        row: Row = {"set": name, **scored(nominal, truth, q4, rng, "before_"),
                    **scored(r.model, truth, q4, rng), **scored(r.model, truth, every, rng,
                                                                 "all_"),
                    "val_mm": pose_errors(r.model, truth,
                                          planar_validation_configurations())["norm_mm"]}
        row |= {f"est_{n}": float(v) for n, v in zip(r.names, r.values, strict=True)}
        rows.append(row)
    return rows
