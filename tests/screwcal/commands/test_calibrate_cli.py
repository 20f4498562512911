import csv
import json
import re
import subprocess
import sys

import numpy as np
import pytest

from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.commands.main import main
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, pose_from_transform
from screwcal.kinematics.robots import irb1600
from screwcal.studies.simulated_measurements import simulate_measurements
from tests.screwcal.calibration.test_identify import BASE, TOOL, full_truth


def _write_measurements(path, data, full_pose=True):
    cols = ["id", "q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"]
    if full_pose:
        cols += ["rx", "ry", "rz"]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for k in range(len(data)):
            row = [f"p{k}", *np.degrees(data.q[k]), *data.positions_mm[k]]
            if full_pose:
                row += list(euler_zyx_deg_from_rotation(data.rotations[k]))
            w.writerow([f"{v:.10f}" if isinstance(v, float) else v for v in row])
    return path


@pytest.fixture
def truth(rng):
    return full_truth(rng).with_frames(BASE, TOOL)


def test_calibrate_then_predict_in_the_measuring_frame(tmp_path, rng, truth):
    data = simulate_measurements(truth, random_configurations(50, rng), rng)
    csv_path = _write_measurements(tmp_path / "m.csv", data)
    out = tmp_path / "result.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(csv_path),
                 "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    # Eq. 2.2: 30 independent parameters; the unknown frames are absorbed into them.
    assert doc["identifiability"]["rank"] == 30
    names = [p["name"] for p in doc["parameters"]]
    assert all({"name", "unit", "value", "std_error"} <= set(p) for p in doc["parameters"])
    assert "base.x" in names and "tool.x" in names
    assert len(doc["residuals"]["before"]) == len(doc["residuals"]["after"]) == 50
    # At the calibration poses the residual holds the +-0.05 deg joint noise (~0.5 mm).
    assert doc["residuals"]["summary_after"]["mean"] < 1.0 < 10 < doc["residuals"][
        "summary_before"]["mean"]
    assert 0.6 < doc["convergence"]["chi2_reduced"] < 1.5
    assert {"rank", "condition_number", "unidentifiable_combinations"} <= set(
        doc["identifiability"])
    # predict reads the result and answers in the measuring frame, for the measured point.
    q_new = random_configurations(20, rng)
    joints = tmp_path / "j.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n" + "\n".join(
        ",".join(f"{v:.10f}" for v in row) for row in np.degrees(q_new)) + "\n")
    pred = tmp_path / "p.csv"
    assert main(["predict", "--model", str(out), "--joints", str(joints), "--out",
                 str(pred)]) == 0
    with pred.open() as f:
        rows = list(csv.DictReader(f))
    got = np.array([[float(r[c]) for c in "xyz"] for r in rows])
    expected = forward_kinematics(truth, q_new)[:, :3, 3]
    assert np.sqrt(np.mean(np.sum((got - expected) ** 2, axis=1))) < 0.5


def test_thesis_model_with_known_frames_and_de(tmp_path, rng):
    from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(40, rng), rng)
    csv_path = _write_measurements(tmp_path / "m.csv", data)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(csv_path), "--out", str(out),
                 "--model", "thesis", "--base-frame", "known", "--weight-mm", "1"]) == 0
    doc = json.loads(out.read_text())
    values = {p["name"]: p["value"] for p in doc["parameters"]}
    assert values["J5ry"] == pytest.approx(3.7, abs=0.1)
    assert doc["settings"]["weighting"] == "eq2.4"
    np.testing.assert_allclose(doc["correction"]["zero_command_deg"],
                               [-values[n] for n in ("J1rz", "J2ry", "J3rz", "J4rx", "J5ry",
                                                     "J6rx")])


@pytest.mark.parametrize(("content", "message"), [
    ("q1,q2,q3,q4,q5,q6,x,y\n", r"column 'z': missing column"),
    ("q1,q2,q3,q4,q5,q6,x,y,z,rx,ry\n0,0,0,0,0,0,1,2,3,0,0\n", r"rz missing"),
    ("q1,q2,q3,q4,q5,q6,x,y,z\n" + "0,10,10,0,10,0,800,0,900\n" * 4,
     r"m\.csv: 4 poses give 12 equations .* measure more poses"),  # names the file
    ("q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n0,0,0,0,0,0,1,2,3,0,0,\n", r"line 2, column 'rz'"),
    ("q1,q2,q3,q4,q5,q6,x,y,z\n0,200,0,0,0,0,1,2,3\n", r"line 2: joint values outside"),
    # the approach directions go together, refused as the file is read (not after the fit)
    ("q1,q2,q3,q4,q5,q6,x,y,z,dir1,dir2,dir3,dir4,dir5\n0,10,10,0,10,0,800,0,900,1,1,1,1,1\n",
     r"column 'dir6': columns dir1, dir2, dir3, dir4, dir5, dir6 go together; dir6 missing"),
    ("q1,q2,q3,q4,q5,q6,x,y,z,dir1,dir2,dir3,dir4,dir5,dir6\n0,0,0,0,0,0,1,2,3,1,1,1,1,1,\n",
     r"line 2, column 'dir6'"),
])
def test_bad_measurement_files_are_refused(tmp_path, capsys, content, message):
    path = tmp_path / "m.csv"
    path.write_text(content)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(path),
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(message, err), err
    assert not out.exists()


def test_compensate_makes_the_true_robot_reach_the_targets(tmp_path, rng, truth):
    data = simulate_measurements(truth, random_configurations(60, rng), rng, joint_noise_deg=0)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data",
                 str(_write_measurements(tmp_path / "m.csv", data)), "--out", str(out)]) == 0
    wanted = forward_kinematics(truth, random_configurations(10, rng))
    targets = tmp_path / "t.csv"
    targets.write_text("id,x,y,z,rx,ry,rz\n" + "\n".join(
        f"t{k}," + ",".join(f"{v:.8f}" for v in pose)
        for k, pose in enumerate(pose_from_transform(wanted))) + "\n")
    comp = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(out), "--measuring-targets", str(targets), "--out",
                 str(comp)]) == 0
    with comp.open() as f:
        rows = list(csv.DictReader(f))
    q = np.radians([[float(r[f"q{i}"]) for i in range(1, 7)] for r in rows])
    reached = forward_kinematics(truth, q)[:, :3, 3]
    assert np.abs(reached - wanted[:, :3, 3]).max() < 0.1  # the nominal model misses by mm
    nominal_tool0 = forward_kinematics(irb1600(), q)
    np.testing.assert_allclose([[float(r[c]) for c in "xyz"] for r in rows],
                               nominal_tool0[:, :3, 3], atol=1e-3)


def test_compensate_refuses_an_unreachable_target(tmp_path, rng, truth, capsys):
    data = simulate_measurements(truth, random_configurations(60, rng), rng)
    out = tmp_path / "r.json"
    main(["calibrate", "--robot", "irb1600", "--data",
          str(_write_measurements(tmp_path / "m.csv", data)), "--out", str(out)])
    reachable = pose_from_transform(forward_kinematics(truth, random_configurations(1, rng)))[0]
    targets = tmp_path / "t.csv"
    targets.write_text("id,x,y,z,rx,ry,rz\na," + ",".join(f"{v:.6f}" for v in reachable)
                       + "\nb,99999,0,0,0,0,0\n")
    assert main(["compensate", "--result", str(out), "--measuring-targets", str(targets), "--out",
                 str(tmp_path / "c.csv")]) == 3  # some refused: the others written
    err = capsys.readouterr().err
    assert "t.csv, line 3 (id b): it is out of the arm's reach" in err, err
    with (tmp_path / "c.csv").open() as f:
        assert [r["id"] for r in csv.DictReader(f)] == ["a"]
    # nothing to compensate: nothing written, the error says so
    targets.write_text("id,x,y,z,rx,ry,rz\nb,99999,0,0,0,0,0\n")
    assert main(["compensate", "--result", str(out), "--measuring-targets", str(targets), "--out",
                 str(tmp_path / "d.csv")]) == 2
    assert "no target compensated" in capsys.readouterr().err
    assert not (tmp_path / "d.csv").exists()


@pytest.fixture
def thirty_poses(tmp_path, rng):
    """m.csv in tmp_path: 30 poses of the IRB 1600 with the thesis's errors."""
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    return _write_measurements(tmp_path / "m.csv",
                               simulate_measurements(truth, random_configurations(30, rng), rng))


def test_calibrate_imports_only_what_it_needs(tmp_path, thirty_poses):
    """`screwcal calibrate` writes a model and reads none: pydantic (the schema) stays out of
    the process, and so do the service and the emulators (issue 14: start-up is most of a
    small calibration's time)."""
    code = ("import sys\nfrom screwcal.commands.main import main\n"
            "assert main(['calibrate', '--robot', 'irb1600', '--data', 'm.csv',"
            " '--out', 'r.json']) == 0\n"
            "print(sorted({m.split('.')[0] for m in sys.modules}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    loaded = set(eval(out.stdout.strip().splitlines()[-1]))
    assert "screwcal" in loaded and (tmp_path / "r.json").exists()
    assert not loaded & {"pydantic", "service", "simulators", "fastapi", "httpx", "asyncio"}


def test_a_reader_that_leaves_early_gets_no_traceback(tmp_path, thirty_poses):
    """`screwcal calibrate ... | head -0`: the reader is gone before the first line; the result
    file is complete and no traceback reaches the terminal (it printed a BrokenPipeError)."""
    proc = subprocess.Popen([sys.executable, "-m", "screwcal", "calibrate", "--robot", "irb1600",
                             "--data", "m.csv", "--out", "r.json"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader leaves before the command prints anything
    err = proc.stderr.read().decode()
    proc.stderr.close()
    proc.wait(60)
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert proc.returncode == 141
    assert json.loads((tmp_path / "r.json").read_text())["format"] == "screwcal-calibration"
