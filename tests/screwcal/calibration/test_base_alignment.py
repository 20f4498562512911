import json

import numpy as np
import pytest

from screwcal.calibration.base_alignment import base_from_sweeps, fit_circle
from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.commands.main import main
from screwcal.errors import AlignmentError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.pose import transform_from_pose
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist, invert_transform
from screwcal.studies.simulated_measurements import simulate_measurements

BASE = exp_twist([0.1, -0.2, 2.0, 1500, -400, -250])
TOOL = exp_twist([0.0, 0.0, 0.0, 20, 30, 60])


def sweeps(truth, rng, q1_during_j2=10.0, noise=0.013):
    q = np.zeros((9, 6))
    q[:, 0] = np.radians(np.linspace(-60, 60, 9))
    q[:, 1:3] = np.radians([20, -10])
    q2 = np.zeros((9, 6))
    q2[:, 1] = np.radians(np.linspace(-30, 60, 9))
    q2[:, 0] = np.radians(q1_during_j2)
    p1 = forward_kinematics(truth, q)[:, :3, 3] + rng.normal(0, noise, (9, 3))
    p2 = forward_kinematics(truth, q2)[:, :3, 3] + rng.normal(0, noise, (9, 3))
    return p1, p2


def test_circle_fit_recovers_axis_centre_radius_and_sense(rng):
    t = np.radians(np.linspace(0, 100, 12))
    frame = exp_twist([0.5, -0.3, 0.2, 100, 200, 300])
    local = np.column_stack([250 * np.cos(t), 250 * np.sin(t), np.zeros_like(t)])
    pts = local @ frame[:3, :3].T + frame[:3, 3] + rng.normal(0, 0.01, local.shape)
    c = fit_circle(pts)
    np.testing.assert_allclose(c.centre_mm, frame[:3, 3], atol=0.05)
    np.testing.assert_allclose(c.normal, frame[:3, 2], atol=1e-3)  # counter-clockwise: +z
    assert c.radius_mm == pytest.approx(250, abs=0.03) and c.rms_mm < 0.03
    assert np.dot(fit_circle(pts[::-1]).normal, frame[:3, 2]) < 0  # the sense of travel


def test_collinear_sweep_is_refused():
    with pytest.raises(AlignmentError, match="collinear"):
        fit_circle(np.outer(np.arange(6.0), [1, 2, 3]))


def test_base_from_sweeps_of_a_nominal_robot(rng):
    truth = irb1600().with_frames(BASE, TOOL)
    found = base_from_sweeps(irb1600(), *sweeps(truth, rng), 10.0)
    d = invert_transform(BASE) @ found
    assert np.linalg.norm(d[:3, 3]) < 0.1
    assert np.degrees(np.arccos(np.clip((np.trace(d[:3, :3]) - 1) / 2, -1, 1))) < 0.02


def test_align_command_and_base_guess_for_calibrate(tmp_path, rng):
    truth = irb1600().with_frames(BASE, TOOL)
    p1, p2 = sweeps(truth, rng, q1_during_j2=0.0)
    lines = ["joint,q1,x,y,z"]
    lines += [f"1,{q:.3f},{x:.4f},{y:.4f},{z:.4f}" for q, (x, y, z) in
              zip(np.linspace(-60, 60, 9), p1, strict=True)]
    lines += [f"2,0,{x:.4f},{y:.4f},{z:.4f}" for x, y, z in p2]
    sweep_csv = tmp_path / "sweeps.csv"
    sweep_csv.write_text("\n".join(lines) + "\n")
    out = tmp_path / "base.json"
    assert main(["align", "--robot", "irb1600", "--sweeps", str(sweep_csv), "--out",
                 str(out)]) == 0
    b = json.loads(out.read_text())["base"]
    found = transform_from_pose([b[k] for k in ("x", "y", "z", "rx", "ry", "rz")])
    assert np.abs(found[:3, 3] - BASE[:3, 3]).max() < 0.1
    # As the solver's starting guess, it converges to the same answer as the automatic one.
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    guessed = identify(irb1600(), data, kind="full", base_guess=found)
    automatic = identify(irb1600(), data, kind="full")
    assert guessed.converged
    np.testing.assert_allclose(guessed.model.base, automatic.model.base, atol=1e-6)
