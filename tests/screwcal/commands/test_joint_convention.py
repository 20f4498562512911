"""FANUC's J2/J3 coupling converted where joints enter and leave (issue 27, point 6): a FANUC
controller reports J3 as the forearm's angle to the horizontal (J3 = q3 - q2); the model is
serial. Measurements in, predict's joints in and compensate's joint targets out are in the
controller's convention (`--joint-convention`, default the robot's)."""

from dataclasses import replace

import numpy as np

from screwcal.commands.main import main
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.readings import readings_from_serial, serial_from_readings
from screwcal.kinematics.robots import LIBRARY

# The last three in an order a controller would keep them in: each on the branch nearest the one
# before it (compensate --targets solves a pose file so), the first on the one nearest home
READINGS_DEG = np.array([[0, 30, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0], [20, -15, 35, 40, -50, 60],
                         [-35, 40, -20, 10, -30, 20], [10, 10, 10, 10, 10, 10]], float)


def _joints_csv(path, q_deg):
    path.write_text("id,q1,q2,q3,q4,q5,q6\n" + "\n".join(
        f"j{k}," + ",".join(f"{v:.6f}" for v in q) for k, q in enumerate(q_deg)) + "\n")
    return path


def _read(path):
    rows = [line.split(",") for line in path.read_text().splitlines()[1:]]
    return np.array([[float(v) for v in r[1:]] for r in rows])


def test_fanuc_j3_is_the_forearm_to_the_horizontal(tmp_path, capsys):
    """J2 = 30, J3 = 0 on an M-20iA leaves the forearm, so the tool, as at home: predict with
    the robot's default convention says so; read as serial angles it does not."""
    joints = _joints_csv(tmp_path / "j.csv", READINGS_DEG[:2])
    for convention, same in ((None, True), ("serial", False)):
        out = tmp_path / f"p{convention}.csv"
        extra = [] if convention is None else ["--joint-convention", convention]
        assert main(["predict", "--robot", "m20ia", "--joints", str(joints), "--out",
                     str(out), *extra]) == 0
        rot = _read(out)[:, 3:]
        assert np.allclose(rot[0], rot[1], atol=1e-6) == same


def test_a_fanuc_target_round_trips(tmp_path, capsys):
    """FANUC readings (each on the branch compensate --targets picks: nearest the target before
    it, the first nearest home) -> predict (tool0 in the base frame) -> compensate --targets on the
    nominal robot -> the same FANUC readings; on a calibrated twin, the written readings put
    the twin on the targets within 0.02 mm."""
    from tests.screwcal.kinematics.test_robots import calibrated

    for name in ("m20ia", "lrmate200id"):
        nominal = LIBRARY[name].model()
        joints = _joints_csv(tmp_path / "j.csv", READINGS_DEG[2:])
        poses = tmp_path / "poses.csv"
        assert main(["predict", "--robot", name, "--joints", str(joints), "--out",
                     str(poses)]) == 0
        targets = tmp_path / "t.csv"
        targets.write_text(poses.read_text())
        save_model(nominal, tmp_path / "nominal.json")
        out = tmp_path / "c.csv"
        assert main(["compensate", "--result", str(tmp_path / "nominal.json"), "--targets",
                     str(targets), "--out", str(out)]) == 0
        assert "as FANUC counts it" in capsys.readouterr().out
        np.testing.assert_allclose(_read(out)[:, :6], READINGS_DEG[2:], atol=2e-4)
        twin = replace(calibrated(nominal, np.random.default_rng(5)), name=name)
        save_model(twin.with_frames(np.eye(4), np.eye(4)), tmp_path / "twin.json")
        assert main(["compensate", "--result", str(tmp_path / "twin.json"), "--robot", name,
                     "--targets", str(targets), "--out", str(out)]) == 0
        q = np.radians(serial_from_readings(_read(out)[:, :6], "fanuc"))
        wanted = flange_kinematics(nominal, np.radians(serial_from_readings(READINGS_DEG[2:],
                                                                            "fanuc")))
        reached = flange_kinematics(twin, q)
        assert np.abs(reached[:, :3, 3] - wanted[:, :3, 3]).max() < 0.02


def test_calibrate_reads_fanuc_readings_and_the_result_remembers(tmp_path, capsys):
    """Measurements with FANUC's J3 fit to the noise floor (read as serial angles they are
    refused or cannot fit), and predict on the result takes FANUC readings without being
    told."""
    import json

    from screwcal.calibration.posesets import random_set
    from screwcal.studies.simulated_measurements import simulate_measurements
    from tests.screwcal.commands.test_calibrate_cli import _write_measurements
    from tests.screwcal.kinematics.test_robots import calibrated

    rng = np.random.default_rng(3)
    nominal = LIBRARY["m20ia"].model()
    truth = calibrated(nominal, rng)
    data = simulate_measurements(truth, random_set(nominal, 50, seed=1), rng,
                                 joint_noise_deg=0.0)
    fanuc = replace(data, q=np.radians(readings_from_serial(np.degrees(data.q), "fanuc")))
    csv = _write_measurements(tmp_path / "m.csv", fanuc)
    result = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "m20ia", "--data", str(csv), "--out",
                 str(result)]) == 0
    doc = json.loads(result.read_text())
    assert doc["settings"]["joint_convention"] == "fanuc"
    assert doc["residuals"]["summary_after"]["max"] < 0.1
    code = main(["calibrate", "--robot", "m20ia", "--data", str(csv), "--out",
                 str(tmp_path / "serial.json"), "--joint-convention", "serial"])
    if code == 2:  # read as serial angles, some readings leave the limits
        assert "outside the limits" in capsys.readouterr().err
    else:
        wrong = json.loads((tmp_path / "serial.json").read_text())
        assert wrong["residuals"]["summary_after"]["max"] > 1.0
    capsys.readouterr()
    joints = _joints_csv(tmp_path / "j.csv", np.degrees(fanuc.q[:5]))
    assert main(["predict", "--result", str(result), "--joints", str(joints), "--out",
                 str(tmp_path / "p.csv")]) == 0
    predicted = _read(tmp_path / "p.csv")[:, :3]
    assert np.abs(predicted - data.positions_mm[:5]).max() < 0.1
