"""Each effect of the emulated true robot against its definition (simulators/realism.py)."""

from __future__ import annotations

import argparse
import asyncio
import json
from dataclasses import replace

import numpy as np
import pytest

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import Payload
from screwcal.kinematics.forward import forward_kinematics, joint_torques
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import transform_points
from simulators.cli import realism_of
from simulators.realism import (
    HARSH,
    IDEAL,
    PRESETS,
    TYPICAL,
    Realism,
    read_realism,
    realism_from_document,
)
from simulators.truth import make_world
from simulators.world import World

Q = np.array([10.0, 20.0, -10.0, 30.0, 40.0, 50.0])


def only(**changes: object) -> Realism:
    return replace(IDEAL, name="test", **changes)  # type: ignore[arg-type]


def world_with(realism: Realism, seed: int = 3) -> World:
    return make_world(None, seed, realism=realism, realism_seed=seed)


def arrive(world: World, q: np.ndarray) -> None:
    asyncio.run(world.set_joints(q))


def holes_at(world: World, model, q_deg: np.ndarray) -> np.ndarray:
    T = forward_kinematics(model.with_frames(tool=np.eye(4)), np.radians(q_deg)[None])[0]
    return transform_points(T, world.holes_mm)


def test_ideal_is_the_geometric_robot():
    world = world_with(IDEAL)
    target = np.float32(Q)
    arrive(world, target)
    assert np.array_equal(world.q_deg, target)
    assert not world.truth.has_compliance
    np.testing.assert_array_equal(world.true_holes_mm(), holes_at(world, world.truth, Q))


def test_compliance_bends_under_the_robots_own_masses():
    realism = only(compliance_deg_per_knm=(0, 0.3, 0.5, 0, 0, 0), mass_spread=0.25,
                   centre_shift_mm=50.0)
    world = world_with(realism)
    nominal = irb1600().masses
    own = world.truth.masses
    assert len(own) == len(nominal)
    for m, n in zip(own, nominal, strict=True):  # drawn around the nominal table
        assert abs(m.kg / n.kg - 1) <= 0.25 and m.kg != n.kg
        assert np.all(np.abs(np.subtract(m.home_mm, n.home_mm)) <= 50.0)
    arrive(world, Q)
    # Definition: joint j stands at q_j + c_j tau_j(q), tau from the robot's own masses.
    c = np.radians(realism.compliance_deg_per_knm) / 1000.0
    tau = joint_torques(world.truth, np.radians(Q)[None])[0]
    rigid = world.truth.derived(compliance=np.zeros(6))
    bent_q = Q + np.degrees(c * tau)
    np.testing.assert_allclose(world.true_holes_mm(), holes_at(world, rigid, bent_q), atol=1e-9)
    assert np.linalg.norm(world.true_holes_mm() - holes_at(world, rigid, Q), axis=1).max() > 0.05


def test_payload_adds_its_torque():
    realism = only(compliance_deg_per_knm=(0, 0.3, 0.5, 0, 0, 0), payload_kg=10.0,
                   payload_cog_mm=(0.0, 0.0, 100.0))
    world = world_with(realism)
    assert world.truth.payload == Payload(10.0, (0.0, 0.0, 100.0))
    arrive(world, Q)
    carrying = world.true_holes_mm()
    world.set_payload(Payload())
    bare = world.true_holes_mm()
    c = np.radians(realism.compliance_deg_per_knm) / 1000.0
    tau_bare = joint_torques(world.truth, np.radians(Q)[None])[0]
    rigid = world.truth.derived(compliance=np.zeros(6), payload=Payload())
    np.testing.assert_allclose(bare, holes_at(world, rigid, Q + np.degrees(c * tau_bare)),
                               atol=1e-9)
    assert np.linalg.norm(carrying - bare, axis=1).min() > 0.01  # 10 kg bends it further


def test_backlash_stops_depend_on_the_direction_of_approach():
    b = np.array([0.01, 0.02, 0.03, 0.04, 0.05, 0.06])
    world = world_with(only(backlash_deg=tuple(b)))
    arrive(world, Q - 5.0)
    arrive(world, Q)  # from below
    from_below = world.true_joints_deg
    arrive(world, Q + 5.0)
    arrive(world, Q)  # from above
    from_above = world.true_joints_deg
    np.testing.assert_allclose(from_below, Q - b / 2, atol=1e-5)
    np.testing.assert_allclose(from_above - from_below, b, atol=1e-5)  # the lost motion
    np.testing.assert_allclose(world.q_deg, Q, atol=1e-5)  # the encoders read the target
    arrive(world, Q)  # no move: the joint stays on the side it came from
    np.testing.assert_allclose(world.true_joints_deg, from_above, atol=1e-5)


def test_readings_lag_the_previous_move():
    lag = np.array([0.01, 0.02, 0.005, 0.0, 0.0, 0.03])
    world = world_with(only(lag=tuple(lag)))
    previous = world.q_deg.astype(float)
    for target in (Q, Q + 30.0, Q - 20.0):
        arrive(world, target)
        read = world.q_deg.astype(float)
        # calibration.lag's model: q_read = q_true - lag (q_read - q_previous)
        np.testing.assert_allclose(read, target - lag * (read - previous), atol=1e-4)
        np.testing.assert_allclose(world.true_joints_deg, target, atol=1e-4)
        previous = read
    assert np.abs(world.q_deg - (Q - 20.0)).max() > 0.1  # a 50 deg move, 3 % lag


def test_drift_grows_the_lengths_over_the_robots_own_time():
    realism = only(drift_ppm=100.0, warmup_s=600.0, speed_deg_s=50.0, dwell_s=2.0)
    world = world_with(realism)
    arrive(world, Q)  # the world knows no time scale: it counts the robot's motion time
    moved = np.abs(Q).max()
    expected_t = moved / 50.0 + 2.0
    assert world.running_s == pytest.approx(expected_t)
    for k in range(100):
        arrive(world, Q + (k % 2) * 10.0)
    expected_t += 100 * 2.0 + 99 * 10.0 / 50.0  # the first stays at Q: no move
    assert world.running_s == pytest.approx(expected_t)
    scale = 1 + 100e-6 * (1 - np.exp(-expected_t / 600.0))
    drifted = world.true_model()
    np.testing.assert_allclose(drifted.axis_points_mm, world.truth.axis_points_mm * scale)
    np.testing.assert_allclose(drifted.home_flange[:3, 3], world.truth.home_flange[:3, 3] * scale)
    np.testing.assert_allclose(world.true_holes_mm(), holes_at(world, drifted, Q + 10.0))


def test_repeatability_is_a_joint_error_the_encoders_do_not_see():
    world = world_with(only(repeatability_deg=0.002))
    errors = []
    for k in range(400):
        arrive(world, Q + (k % 2))
        np.testing.assert_allclose(world.q_deg, Q + (k % 2), atol=1e-5)
        errors.append(world.true_joints_deg - (Q + (k % 2)))
    std = np.std(errors, axis=0)
    np.testing.assert_allclose(std, 0.002, rtol=0.15)


def test_same_seed_same_robot_and_stops():
    a, b = world_with(TYPICAL, 5), world_with(TYPICAL, 5)
    for world in (a, b):
        for target in (Q, Q + 3.0, Q - 7.0):
            arrive(world, target)
    np.testing.assert_array_equal(a.true_holes_mm(), b.true_holes_mm())
    assert world_with(TYPICAL, 6).truth.masses != a.truth.masses


def test_harsh_doubles_the_non_geometric_effects():
    assert HARSH.compliance_deg_per_knm == tuple(2 * v for v in TYPICAL.compliance_deg_per_knm)
    assert HARSH.backlash_deg == tuple(2 * v for v in TYPICAL.backlash_deg)
    assert HARSH.lag == tuple(2 * v for v in TYPICAL.lag)
    assert HARSH.drift_ppm == 2 * TYPICAL.drift_ppm
    assert HARSH.repeatability_deg == 2 * TYPICAL.repeatability_deg
    assert HARSH.mass_spread == TYPICAL.mass_spread and IDEAL.is_ideal
    assert set(PRESETS) == {"ideal", "typical", "harsh"}


def test_realism_file_and_its_errors(tmp_path):
    path = tmp_path / "realism.json"
    path.write_text(json.dumps({"preset": "typical", "payload_kg": 10,
                                "lag": [0.001] * 3 + [0] * 3}))
    realism = read_realism(str(path))
    assert realism.payload_kg == 10 and realism.lag[0] == 0.001
    assert realism.backlash_deg == TYPICAL.backlash_deg
    with pytest.raises(ModelError, match=r"unknown field.*backlash"):
        realism_from_document({"backlash": 1}, "f.json")
    with pytest.raises(ModelError, match="6 values"):
        realism_from_document({"lag": [0.1]}, "f.json")
    with pytest.raises(ModelError, match="cannot be negative"):
        realism_from_document({"drift_ppm": -1}, "f.json")
    with pytest.raises(ModelError, match="preset 'warm'"):
        realism_from_document({"preset": "warm"}, "f.json")


def test_cli_options_make_the_realism():
    args = argparse.Namespace(realism="typical", realism_file=None, payload_kg=5.0,
                              payload_cog_mm=(0.0, 0.0, 50.0))
    realism = realism_of(args)
    assert realism.payload_kg == 5.0 and realism.compliance_deg_per_knm == \
        TYPICAL.compliance_deg_per_knm
    args.payload_kg = None
    assert realism_of(args) == TYPICAL


def test_zero_keeps_the_true_state_consistent():
    world = world_with(replace(TYPICAL, repeatability_deg=0.0, drift_ppm=0.0))
    arrive(world, Q)
    before = world.true_holes_mm()
    world.set_zero(Q)
    np.testing.assert_allclose(world.true_holes_mm(), before, atol=1e-9)
    arrive(world, np.zeros(6))  # the same physical place, now read as 0 (no move: same side)
    np.testing.assert_allclose(world.true_holes_mm(), before, atol=1e-6)
