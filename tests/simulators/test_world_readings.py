"""The arm's readings of the true robot: exact as the definition (the forward kinematics of
`World.true_model()` without its tool), and the true robot's kinematic tables built once per
true robot, not once per reading."""

from __future__ import annotations

import asyncio
from dataclasses import replace

import numpy as np
import pytest

from screwcal.kinematics import forward
from screwcal.kinematics.compliance import Payload
from screwcal.kinematics.se3 import transform_points
from simulators.realism import IDEAL, TYPICAL
from simulators.truth import make_world

DRIFTING = replace(TYPICAL, name="drifting", drift_ppm=300.0, warmup_s=60.0)


def definition(world) -> np.ndarray:
    model = world.true_model().with_frames(tool=np.eye(4))
    q = np.radians(world.true_joints_deg)[None]
    return transform_points(forward.forward_kinematics(model, q)[0], world.holes_mm)


@pytest.mark.parametrize("realism", [IDEAL, TYPICAL, DRIFTING], ids=lambda r: r.name)
def test_readings_are_the_true_models_kinematics(realism):
    world = make_world(None, 3, realism=realism, realism_seed=3)
    rng = np.random.default_rng(0)
    for k in range(12):
        asyncio.run(world.set_joints(rng.uniform(-40.0, 40.0, 6)))
        if k == 6:
            world.set_payload(Payload(5.0, (0.0, 0.0, 80.0)))
        np.testing.assert_allclose(world.true_holes_mm(), definition(world), rtol=0, atol=1e-9)
    if realism is DRIFTING:
        assert world.realism.drift_scale(world.running_s) > 1.00005  # the lengths have grown


def test_the_tables_are_built_once_per_true_robot(monkeypatch):
    built = []
    tables = forward._few_pose_tables

    def counted(model):
        built.append(id(model))
        return tables(model)

    monkeypatch.setattr(forward, "_few_pose_tables", counted)
    world = make_world(None, 3, realism=DRIFTING, realism_seed=3)
    rng = np.random.default_rng(1)
    for _ in range(20):
        asyncio.run(world.set_joints(rng.uniform(-40.0, 40.0, 6)))
        world.true_holes_mm()
    assert len(set(built)) == 1, f"{len(set(built))} models for 20 readings"
    world.set_zero(np.full(6, 0.5))  # a new true robot: its tables once more
    world.true_holes_mm()
    world.true_holes_mm()
    assert len(set(built)) == 2
