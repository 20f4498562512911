"""The residual model through the command line: calibrate keeps it where the robot has a smooth
error its physical model cannot hold and declines it where there is none; predict and
compensate (targets and RAPID) use it, with its uncertainty, and results without it still work."""

import csv
import json

import numpy as np
import pytest

from screwcal.calibration.posesets import WORKING_REGION_DEG, random_configurations
from screwcal.commands.main import main
from screwcal.kinematics.confdata import confdata
from screwcal.kinematics.forward import flange_kinematics, forward_kinematics
from screwcal.kinematics.pose import pose_from_transform
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation
from screwcal.studies.simulated_measurements import simulate_measurements
from tests.screwcal.calibration.test_identify import BASE, TOOL, full_truth
from tests.screwcal.commands.test_calibrate_cli import _write_measurements

POSES = 150


def unmodelled_mm(q: np.ndarray) -> np.ndarray:
    """(N, 3) a smooth error of the measured point over joint space (measuring frame, mm): what
    no geometric or compliance parameter holds (a gear's once-per-turn error, a cable's pull)."""
    return 0.12 * np.c_[np.sin(2 * q[:, 1]) * np.cos(q[:, 0]), np.cos(3 * q[:, 2]),
                        np.sin(q[:, 1] + 2 * q[:, 2]) * np.sin(q[:, 4])]


def _calibrate(folder, name, data, *extra) -> dict:
    path = _write_measurements(folder / f"{name}.csv", data)
    out = folder / f"{name}.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(path), "--out", str(out),
                 *extra]) == 0
    return json.loads(out.read_text()) | {"path": str(out)}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Calibrations of a robot with a smooth unmodelled error (auto, and none) and of one
    without (auto)."""
    rng = np.random.default_rng(43)
    folder = tmp_path_factory.mktemp("residual")
    truth = full_truth(rng).with_frames(BASE, TOOL)
    q = random_configurations(POSES, rng)
    plain = simulate_measurements(truth, q, rng, noise_mm=0.02, joint_noise_deg=0.0)
    bent = plain.__class__(plain.q, plain.positions_mm + unmodelled_mm(plain.q), plain.rotations)
    return {"truth": truth, "folder": folder,
            "auto": _calibrate(folder, "auto", bent),
            "none": _calibrate(folder, "none", bent, "--residual-model", "none"),
            "plain": _calibrate(folder, "plain", plain)}


def _read(path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_calibrate_keeps_it_for_a_smooth_error_and_declines_noise(runs, capsys):
    kept, plain = runs["auto"]["residual_model"], runs["plain"]["residual_model"]
    assert kept["used"] and kept["mode"] == "auto" and kept["version"] == 1
    cv = kept["cross_validation"]
    assert cv["corrected_mean_mm"] < 0.8 * cv["physical_mean_mm"]
    assert cv["gain_mm"] > cv["spread_mm"]
    assert len(kept["training"]["joints_deg"]) == POSES
    assert kept["predictive_std_mm"]["mean_over_calibration_poses"] > 0
    assert runs["auto"]["settings"]["residual_model"] == "auto"
    assert not plain["used"] and plain["note"].startswith("declined (auto)")
    assert "training" not in plain
    assert runs["none"]["residual_model"] == {
        "format": "screwcal-residual-model", "version": 1, "mode": "none", "used": False,
        "note": "not asked (--residual-model none)", "cross_validation": None}


def _predict(runs, which, q_deg) -> tuple[list[str], np.ndarray, list[list[str]]]:
    folder = runs["folder"]
    joints = folder / "joints.csv"
    joints.write_text("id,q1,q2,q3,q4,q5,q6\n" + "".join(
        f"t{k}," + ",".join(f"{v:.8f}" for v in row) + "\n" for k, row in enumerate(q_deg)))
    out = folder / f"predicted-{which}.csv"
    assert main(["predict", "--result", runs[which]["path"], "--joints", str(joints),
                 "--out", str(out)]) == 0
    header, rows = _read(out)
    return header, np.array([[float(v) for v in r[1:4]] for r in rows]), rows


def test_predict_adds_the_correction_and_its_uncertainty(runs, capsys):
    rng = np.random.default_rng(7)
    q = random_configurations(200, rng)
    true = forward_kinematics(runs["truth"], q)[:, :3, 3] + unmodelled_mm(q)
    header, with_it, rows = _predict(runs, "auto", np.degrees(q))
    assert header == ["id", "x", "y", "z", "rx", "ry", "rz", "dx", "dy", "dz", "std_mm", "note"]
    assert "residual model: correction mean" in capsys.readouterr().out
    _, without, _ = _predict(runs, "none", np.degrees(q))
    e_with = np.linalg.norm(with_it - true, axis=1)
    e_without = np.linalg.norm(without - true, axis=1)
    assert e_with.mean() < 0.75 * e_without.mean(), (e_with.mean(), e_without.mean())
    std = np.array([float(r[10]) for r in rows])
    assert np.mean(e_with ** 2 / std ** 2 <= 7.8147) > 0.85
    header, _, _ = _predict(runs, "plain", np.degrees(q))
    assert header == ["id", "x", "y", "z", "rx", "ry", "rz"]  # declined: the contract's file


def test_predict_beyond_the_reach_gives_the_physical_model_and_a_note(runs, capsys):
    """The reach the result file states governs: here cut to one length scale, which the
    configuration far outside the calibration's working region exceeds (1.5 of them away)."""
    doc = {k: v for k, v in runs["auto"].items() if k != "path"}
    doc["residual_model"]["reach_length_scales"] = 1.0
    short = runs["folder"] / "short-reach.json"
    short.write_text(json.dumps(doc))
    q_far = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [180.0, 140.0, -200.0, 0.0, 115.0, 0.0]])
    _, with_it, rows = _predict(runs | {"short": {"path": str(short)}}, "short", q_far)
    err = capsys.readouterr().err
    _, without, _ = _predict(runs, "none", q_far)
    far = [k for k, r in enumerate(rows) if r[11]]
    assert far == [1], "the second lies far outside the calibration's working region"
    assert "beyond the residual model's reach (1.5 length scales" in rows[1][11]
    assert [float(v) for v in rows[1][7:10]] == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(with_it[1], without[1], atol=1e-6)  # the physical model's
    assert "line 3: beyond the residual model's reach" in err


def _path(n: int, rng: np.random.Generator) -> np.ndarray:
    """n configurations (rad) a few degrees apart, inside 0.8 of the working region: a path
    (a pose file is solved target after target on the branch nearest the one before)."""
    low, high = np.radians(WORKING_REGION_DEG * 0.8).T
    q = [random_configurations(1, rng)[0] * 0.8]
    for _ in range(n - 1):
        q.append(np.clip(q[-1] + np.radians(rng.normal(0.0, 4.0, 6)), low, high))
    return np.array(q)


def test_compensated_targets_reach_the_true_robot_better(runs):
    rng = np.random.default_rng(11)
    q = _path(30, rng)
    truth = runs["truth"]
    wanted = forward_kinematics(truth, q)
    wanted[:, :3, 3] += unmodelled_mm(q)
    targets = runs["folder"] / "targets.csv"
    targets.write_text("id,x,y,z,rx,ry,rz\n" + "".join(
        f"t{k}," + ",".join(f"{v:.8f}" for v in p) + "\n"
        for k, p in enumerate(pose_from_transform(wanted))))
    errors = {}
    for which in ("auto", "none"):
        out = runs["folder"] / f"comp-{which}.csv"
        assert main(["compensate", "--result", runs[which]["path"], "--measuring-targets",
                     str(targets), "--out", str(out)]) == 0
        header, rows = _read(out)
        q_c = np.radians([[float(v) for v in r[1:7]] for r in rows])
        reached = forward_kinematics(truth, q_c)[:, :3, 3] + unmodelled_mm(q_c)
        errors[which] = np.linalg.norm(reached - wanted[:, :3, 3], axis=1).mean()
        assert ("dx" in header) == (which == "auto")
    assert errors["auto"] < 0.75 * errors["none"], errors


def _module(q: np.ndarray) -> str:
    nominal = irb1600()
    T = flange_kinematics(nominal, q)
    quats = quaternion_wxyz_from_rotation(T[:, :3, :3])
    cf = confdata(nominal, q)
    lines = [f"  CONST robtarget p{k}:=[[{T[k, 0, 3]:.4f},{T[k, 1, 3]:.4f},{T[k, 2, 3]:.4f}],"
             f"[{quats[k, 0]:.9f},{quats[k, 1]:.9f},{quats[k, 2]:.9f},{quats[k, 3]:.9f}],"
             f"[{cf[k, 0]},{cf[k, 1]},{cf[k, 2]},{cf[k, 3]}],[9E9,9E9,9E9,9E9,9E9,9E9]];"
             for k in range(len(q))]
    return "MODULE M\n" + "\n".join(lines) + "\nENDMODULE\n"


def test_rapid_compensation_carries_the_residual(runs, capsys):
    rng = np.random.default_rng(5)
    q = random_configurations(20, rng) * 0.8
    source = runs["folder"] / "in.mod"
    source.write_text(_module(q))
    outs = {}
    for which in ("auto", "none"):
        out = runs["folder"] / f"out-{which}.mod"
        assert main(["compensate", "--result", runs[which]["path"], "--rapid", str(source),
                     "--out", str(out)]) == 0
        outs[which] = out.read_text()
        printed = capsys.readouterr().out
        assert ("residual model: correction mean" in printed) == (which == "auto")
    assert outs["auto"] != outs["none"]


@pytest.mark.parametrize("form", ["urdf", "mdh"])
def test_exports_carry_the_physical_model_and_say_what_they_drop(runs, capsys, form):
    texts = {}
    for which in ("auto", "none"):
        out = runs["folder"] / f"export-{which}.{form}"
        assert main(["robot", "export", runs[which]["path"], "--format", form,
                     "--out", str(out)]) == 0
        texts[which] = out.read_text()
        printed = capsys.readouterr().out
        said = f"note: the {form} export carries the physical model only: the result's " \
               "residual model (its correction over the calibration poses: mean"
        assert (said in printed) == (which == "auto"), printed
    assert texts["auto"] == texts["none"]
