"""Lost motion per joint (calibration/backlash.py) against its definition: a joint stops b/2
short of its target on the side it came from (simulators/realism.py's backlash)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from screwcal.calibration.backlash import (
    backlash_from_pairs,
    direction_pairs,
    estimate_backlash,
    pair_jacobians,
    pose_residuals,
)
from screwcal.calibration.flange import MeasuringFlange
from screwcal.calibration.measurements import read_measurements_csv
from screwcal.calibration.posesets import random_set
from screwcal.commands.main import main
from screwcal.errors import InputError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.pose import pose_from_transform
from screwcal.kinematics.robots import irb1600
from simulators.arm import NOISE_MM
from simulators.realism import IDEAL
from simulators.truth import make_world


def test_pairs_jacobian_matches_finite_differences():
    model = irb1600()
    q = random_set(model, 3, seed=1)
    J = pair_jacobians(model, q)
    h = 1e-6
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        T0 = forward_kinematics(model, q)
        fd = pose_residuals(model, q, forward_kinematics(model, q + dq)) / h
        assert np.allclose(fd, J[:, :, j], atol=1e-4 * np.abs(J).max()), j
        assert T0.shape == (3, 4, 4)


def test_noise_free_pairs_give_the_imposed_backlash_exactly():
    model = irb1600()
    q = random_set(model, 6, seed=2)
    b = np.radians([0.004, 0.01, 0.006, 0.02, 0.015, 0.03])
    s = np.ones((6, 6))
    # approached from below (link q - b/2), then from above (link q + b/2)
    Ta = forward_kinematics(model, q - b / 2)
    Tb = forward_kinematics(model, q + b / 2)
    est = backlash_from_pairs(model, q, q, Ta, Tb, s)
    assert np.allclose(est.backlash_deg, np.degrees(b), atol=2e-5)
    assert est.identifiable.all() and est.pairs == 6


def test_emulated_backlash_on_j2_is_identified_within_its_uncertainty():
    """Imposed 0.01 deg on J2 alone: each pose approached from 1 deg below, then 1 deg above,
    on the emulated robot, its holes probed with the arm's noise; identified 0.010 +- 0.002."""
    realism = IDEAL.__class__(name="j2", backlash_deg=(0.0, 0.01, 0.0, 0.0, 0.0, 0.0))
    world = make_world(None, 3, realism=realism)
    flange = MeasuringFlange.from_holes_in_flange(world.holes_mm)
    rng = np.random.default_rng(5)
    q_deg = np.degrees(random_set(world.nominal, 12, seed=4))
    read, measured = {"a": [], "b": []}, {"a": [], "b": []}
    for q in q_deg:
        for side, approach in (("a", q - 1.0), ("b", q + 1.0)):
            world.arrive(approach)
            world.arrive(q)
            holes = world.true_holes_mm() + rng.normal(0.0, NOISE_MM, (3, 3))
            read[side].append(np.radians(world.q_deg.astype(float)))
            measured[side].append(flange.flange_poses(holes[None])[0])
    truth = world.truth.with_frames(tool=np.eye(4))
    est = backlash_from_pairs(truth, np.array(read["a"]), np.array(read["b"]),
                              np.array(measured["a"]), np.array(measured["b"]),
                              np.ones((12, 6)))
    print(f"J2 {est.backlash_deg[1]:.4f} +- {est.std_deg[1]:.4f} deg (imposed 0.010)")
    assert est.identifiable.all()
    assert est.backlash_deg[1] == pytest.approx(0.010, abs=max(3 * est.std_deg[1], 5e-4))
    assert est.std_deg[1] < 0.002
    others = np.delete(np.arange(6), 1)  # none imposed: zero within 3 sigma
    assert np.all(np.abs(est.backlash_deg[others]) < 3 * est.std_deg[others] + 1e-4)
    doc = est.to_dict()
    assert doc["joints"][1]["joint"] == "J2" and "approached from one fixed direction" in \
        doc["compensation"]


def test_a_joint_no_pair_flipped_is_not_identified():
    model = irb1600()
    q = random_set(model, 5, seed=6)
    s = np.ones((5, 6))
    s[:, 5] = 0.0
    est = estimate_backlash(pair_jacobians(model, q), np.zeros((5, 6)), s)
    assert not est.identifiable[5] and np.isnan(est.backlash_deg[5])
    assert est.identifiable[:5].all()
    assert est.to_dict()["joints"][5]["backlash_deg"] is None


def test_bad_shapes_are_refused_naming_them():
    with pytest.raises(InputError, match="jacobians"):
        estimate_backlash(np.zeros((2, 6, 6)), np.zeros((2, 5)), np.ones((2, 6)))


def test_direction_pairs_are_rows_of_one_pose_from_opposite_sides():
    q = np.array([[10.0] * 6, [20.0] * 6, [10.004] * 6, [20.0] * 6, [30.0] * 6])
    d = np.array([[1] * 6, [1] * 6, [-1] * 6, [1] * 6, [0] * 6])
    d[3, 2] = -1  # row 3 repeats row 1 with joint 3 from above only
    a, b, s = direction_pairs(q, d)
    assert a.tolist() == [0, 1] and b.tolist() == [2, 3]
    assert s[0].tolist() == [1.0] * 6 and s[1].tolist() == [0, 0, 1.0, 0, 0, 0]
    with pytest.raises(InputError, match="approach directions"):
        direction_pairs(q, np.full((5, 6), 2.0))


def test_the_direction_columns_are_read_with_the_measurements(tmp_path):
    """dir1..dir6 are an optional group of the measurement file, carried on the set (and on
    any subset of it); a file without them has none."""
    head = "q1,q2,q3,q4,q5,q6,x,y,z"
    path = tmp_path / "m.csv"
    path.write_text(f"{head},dir6,dir1,dir2,dir3,dir4,dir5\n"
                    "0,10,10,0,10,0,800,0,900,-1,1,1,0,1,1\n"
                    "5,10,10,0,10,0,810,0,900,1,-1,-1,-1,-1,-1\n")
    data = read_measurements_csv(path, irb1600())
    assert data.directions.tolist() == [[1, 1, 0, 1, 1, -1], [-1, -1, -1, -1, -1, 1]]
    assert data.take([1]).directions.tolist() == [[-1, -1, -1, -1, -1, 1]]
    path.write_text(f"{head}\n0,10,10,0,10,0,800,0,900\n")
    assert read_measurements_csv(path, irb1600()).directions is None


def test_offline_calibrate_reports_backlash_from_the_direction_columns(tmp_path, capsys):
    """A measurement file with the optional dir1..dir6 columns (the sign of each joint's last
    move): 40 poses once, 12 of them again from the other side; the emulated robot has 0.01 deg
    of lost motion on J2: `screwcal calibrate` reports it in result.json and on the terminal."""
    realism = IDEAL.__class__(name="j2", backlash_deg=(0.0, 0.01, 0.0, 0.0, 0.0, 0.0))
    world = make_world(None, 3, realism=realism)
    flange = MeasuringFlange.from_holes_in_flange(world.holes_mm)
    rng = np.random.default_rng(8)
    q_deg = np.degrees(random_set(world.nominal, 40, seed=9))
    rows = []
    plan = [(q, 1.0) for q in q_deg] + [(q, -1.0) for q in q_deg[:12]]
    for q, side in plan:  # from below (+1) first, then the repeats from above (-1)
        world.arrive(q - side)
        world.arrive(q)
        holes = world.true_holes_mm() + rng.normal(0.0, NOISE_MM, (3, 3))
        T = flange.flange_poses(holes[None])[0]
        rows.append([*world.q_deg.astype(float), *pose_from_transform(T), *[side] * 6])
    path = tmp_path / "m.csv"
    header = ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "rx", "ry", "rz",
              "dir1", "dir2", "dir3", "dir4", "dir5", "dir6"]
    path.write_text(",".join(header) + "\n" + "\n".join(
        ",".join(f"{v:.6f}" for v in r) for r in rows) + "\n")
    out = tmp_path / "result.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(path), "--out",
                 str(out)]) == 0
    joints = {j["joint"]: j for j in json.loads(out.read_text())["backlash"]["joints"]}
    assert joints["J2"]["backlash_deg"] == pytest.approx(
        0.010, abs=max(3 * joints["J2"]["std_deg"], 1e-3))
    assert joints["J2"]["std_deg"] < 0.002
    said = capsys.readouterr().out
    assert "lost motion (backlash, from pairs approached from both sides): J1" in said
    assert "approached from one fixed direction" in said
