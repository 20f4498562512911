"""Shared fixtures: seeded generators and random serial models for property tests."""

from __future__ import annotations

import numpy as np
import pytest

from screwcal.model import SerialModel
from screwcal.se3 import exp_twist


def random_model(rng: np.random.Generator, joint_types: str = "RRRRRR",
                 frames: bool = True) -> SerialModel:
    """A serial model with random axes, points, zeros and (optionally) base and tool frames."""
    n = len(joint_types)
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    points = rng.uniform(-500, 500, (n, 3))
    home = exp_twist(np.r_[rng.normal(0, 1, 3), rng.uniform(-800, 800, 3)])

    def frame() -> np.ndarray:
        return exp_twist(np.r_[rng.normal(0, 1, 3), rng.uniform(-300, 300, 3)]) if frames \
            else np.eye(4)

    rev = np.array([t == "R" for t in joint_types])
    limits = np.where(rev[:, None], [-np.pi, np.pi], [-200.0, 200.0])
    return SerialModel(name="random", joint_types=tuple(joint_types), axis_dirs=dirs,
                       axis_points_mm=points, home_flange=home, limits=limits,
                       joint_zero=rng.normal(0, 0.05, n), base=frame(), tool=frame())


def random_q(model: SerialModel, rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(model.limits[:, 0], model.limits[:, 1], (n, model.n_joints))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20181122)
