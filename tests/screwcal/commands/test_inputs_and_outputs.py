"""Issue 26: what the offline commands refuse before working (numbers, units, outputs), that an
output never destroys an input and gets the user's umask, and that compensation writes every
target it can and says, by its exit status, when it could not."""

import csv
import math
import os
import re
import stat

import numpy as np
import pytest

from screwcal.calibration.correction import compensate
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.commands.main import main
from screwcal.kinematics.confdata import confdata, solution_for_confdata
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.pose import pose_from_transform
from screwcal.kinematics.robots import irb120, irb1600
from screwcal.kinematics.se3 import exp_twist
from screwcal.studies.simulated_measurements import simulate_measurements
from tests.screwcal.calibration.test_identify import BASE, TOOL
from tests.screwcal.commands.test_calibrate_cli import _write_measurements


def _table11():
    return apply_virtual_joints(irb1600(), THESIS_TABLE11)


@pytest.fixture
def measurements(tmp_path, rng):
    truth = _table11().with_frames(BASE, TOOL)
    data = simulate_measurements(truth, random_configurations(30, rng), rng, full_pose=False)
    return _write_measurements(tmp_path / "m.csv", data, full_pose=False)


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "model.json"
    save_model(_table11(), path)
    return path


@pytest.mark.parametrize(("argv", "option"), [
    (["calibrate", "--noise-mm", "nan"], "--noise-mm"),
    (["calibrate", "--noise-mm", "-1"], "--noise-mm"),
    (["calibrate", "--noise-mm", "0"], "--noise-mm"),
    (["calibrate", "--weight-mm", "inf"], "--weight-mm"),
    (["calibrate", "--joint-noise-deg", "-0.1"], "--joint-noise-deg"),
    (["calibrate", "--payload-kg", "nan"], "--payload-kg"),
    (["calibrate", "--payload-cog-mm", "0,nan,0"], "--payload-cog-mm"),
    (["simulate", "--poses", "-5"], "--poses"),
    (["simulate", "--validation", "0"], "--validation"),
    (["testcube", "--edge-mm", "-100"], "--edge-mm"),
    (["testcube", "--cycles", "0"], "--cycles"),
    (["testcube", "--arm-radius-mm", "nan"], "--arm-radius-mm"),
    (["study", "planar", "--samples", "0"], "--samples"),
])
def test_bad_numbers_are_refused_by_the_parser_with_the_option_name(capsys, argv, option):
    required = {"calibrate": ["--robot", "irb1600", "--data", "m.csv", "--out", "r.json"],
                "testcube": ["--robot", "irb1600", "--out", "t.csv"]}.get(argv[0], [])
    with pytest.raises(SystemExit) as exit_:
        main([*argv, *required])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert re.search(f"argument {option}[:/]", err) and "Traceback" not in err, err


def test_a_missing_output_folder_is_refused_before_the_data_are_read(tmp_path, capsys):
    """Checked first: the data file here does not even exist, and the error is the folder's
    (the fit used to run to the end and then fail with a traceback)."""
    out = tmp_path / "missing" / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(tmp_path / "none.csv"),
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "missing" in err and "does not exist" in err and "Traceback" not in err


def test_an_output_that_is_an_input_is_refused(tmp_path, measurements, model_file, capsys):
    before = measurements.read_bytes()
    assert main(["calibrate", "--robot", "irb1600", "--data", str(measurements),
                 "--out", str(measurements)]) == 2
    assert "is also the input" in capsys.readouterr().err
    program = tmp_path / "P.mod"
    program.write_text("MODULE P\n  CONST robtarget p:=[[900,0,900],[0,0,1,0],[0,0,0,0],"
                       "[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")
    text, mode = program.read_bytes(), program.stat().st_mode
    # the same file by another name
    assert main(["compensate", "--result", str(model_file), "--robot", "irb1600", "--rapid",
                 str(program), "--out", str(tmp_path / "." / "P.mod")]) == 2
    assert "is also the input" in capsys.readouterr().err
    assert program.read_bytes() == text and program.stat().st_mode == mode
    assert measurements.read_bytes() == before


def test_a_file_that_is_not_rapid_is_refused(tmp_path, measurements, model_file, capsys):
    out = tmp_path / "out.mod"
    assert main(["compensate", "--result", str(model_file), "--robot", "irb1600", "--rapid",
                 str(measurements), "--out", str(out)]) == 2
    err = capsys.readouterr().err  # what it is and what takes it (issue 38)
    assert "is a measurement file" in err and "--rapid takes a RAPID module" in err, err
    assert not out.exists()


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_every_command_writes_with_the_users_umask(tmp_path, measurements, model_file, umask):
    joints = tmp_path / "j.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n0,10,10,0,30,0\n")
    targets = tmp_path / "t.csv"
    targets.write_text("id,x,y,z,rx,ry,rz\na,800,100,900,0,80,0\n")
    program = tmp_path / "P.mod"
    program.write_text("MODULE P\n  CONST robtarget p:=[[900,0,900],[0,0,1,0],[0,0,0,0],"
                       "[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")
    old = os.umask(umask)
    try:
        runs = {
            "r.json": ["calibrate", "--robot", "irb1600", "--data", str(measurements)],
            "p.csv": ["predict", "--model", "irb1600", "--joints", str(joints)],
            "c.csv": ["compensate", "--result", str(model_file), "--robot", "irb1600",
                      "--targets", str(targets)],
            "c.mod": ["compensate", "--result", str(model_file), "--robot", "irb1600",
                      "--rapid", str(program)],
            "cube.csv": ["testcube", "--robot", "irb1600", "--cycles", "2"],
        }
        for name, argv in runs.items():
            assert main([*argv, "--out", str(tmp_path / name)]) == 0, name
    finally:
        os.umask(old)
    modes = {name: stat.S_IMODE((tmp_path / name).stat().st_mode) for name in runs}
    assert modes == dict.fromkeys(runs, 0o666 & ~umask)


def _radians_file(path, source):
    rows = list(csv.reader(source.read_text().splitlines()))
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(rows[0])
        for r in rows[1:]:
            w.writerow([r[0], *(f"{math.radians(float(v)):.12f}" for v in r[1:7]), *r[7:]])
    return path


def _scaled_lengths(path, source, divide):
    rows = list(csv.reader(source.read_text().splitlines()))
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(rows[0])
        for r in rows[1:]:
            w.writerow([*r[:7], *(f"{float(v) / divide:.12f}" for v in r[7:10]), *r[10:]])
    return path


def test_joints_in_radians_are_refused_with_the_fix(tmp_path, measurements, capsys):
    """They used to calibrate (exit 0) into "J2c 1.89e+05 deg/kNm"."""
    rad = _radians_file(tmp_path / "rad.csv", measurements)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(rad), "--out", str(out)]) == 2
    assert "--joint-unit rad" in capsys.readouterr().err and not out.exists()
    assert main(["calibrate", "--robot", "irb1600", "--data", str(rad), "--out", str(out),
                 "--joint-unit", "rad"]) == 0
    assert main(["calibrate", "--robot", "irb1600", "--data", str(measurements),
                 "--out", str(out), "--joint-unit", "rad"]) == 2  # degrees said to be radians
    assert "they look like degrees" in capsys.readouterr().err


@pytest.mark.parametrize(("unit", "divide"), [("m", 1000.0), ("in", 25.4)])
def test_positions_in_metres_or_inches_are_refused_with_the_fix(tmp_path, measurements, capsys,
                                                                 unit, divide):
    scaled = _scaled_lengths(tmp_path / "s.csv", measurements, divide)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(scaled),
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"they look like {unit}" in err and f"--length-unit {unit}" in err, err
    assert not out.exists()
    assert main(["calibrate", "--robot", "irb1600", "--data", str(scaled), "--out", str(out),
                 "--length-unit", unit]) == 0


@pytest.mark.parametrize("robot", [irb1600(), irb120()])
def test_the_home_robtarget_and_its_neighbours_have_their_confdata(robot, rng):
    """confdata [0,0,0,0] at home: every joint on a quadrant's edge and joint 5 at the wrist
    singularity; the numbers of a robtarget put the IK a hair either side (joint 1 at
    -4e-7 deg, joint 5 at -1e-9 deg, joints 4 and 6 at +-87 deg): refused 86 % of the time."""
    home = flange_kinematics(robot, np.zeros((1, 6)))[0]
    T = np.array([exp_twist(np.r_[rng.normal(0, 1e-9, 3), rng.normal(0, 1e-5, 3)]) @ home
                  for _ in range(100)])
    q, found = solution_for_confdata(robot, T, np.zeros((100, 4), int), strict=False)
    assert found.all()
    np.testing.assert_allclose(q, 0.0, atol=1e-6)  # joints 4 and 6 at home, not +-87 deg
    np.testing.assert_allclose(flange_kinematics(robot, q), T, atol=1e-4)  # 0.1 um
    np.testing.assert_array_equal(confdata(robot, np.zeros((1, 6))), [[0, 0, 0, 0]])


def test_targets_at_the_wrist_singularity_are_solved(rng):
    """Nominal targets with joint 5 at zero: the calibrated robot's wrist is singular near
    there too and joints 4 and 6 must turn together; 44 of 50 used to be refused."""
    nominal, calibrated = irb1600(), _table11()
    q = rng.uniform(-0.5, 0.5, (20, 6))
    q[:, 3] = rng.uniform(-1, 1, 20)
    q[:, 4] = rng.choice([0.0, 1e-7, -1e-7, 1e-4], 20)
    T = flange_kinematics(nominal, q)
    comp = compensate(calibrated, nominal, T, q, frame="base", strict=False)
    assert not comp.refused, comp.refused
    reached = flange_kinematics(calibrated, comp.q_rad)
    assert np.abs(reached[:, :3, 3] - T[:, :3, 3]).max() < 1e-3
    # joints 4 and 6 turn together, each no further than their combined turn needs
    d = np.degrees(comp.q_rad - q)
    assert np.abs(d[:, [0, 1, 2, 4]]).max() < 10 and np.abs(d[:, 3] + d[:, 5]).max() < 10


def test_targets_writes_every_target_it_can_and_lists_the_rest(tmp_path, model_file, capsys):
    nominal = irb1600()
    q = np.radians([[10, 20, 10, 30, 40, 10], [0, 0, 0, 0, 0, 0], [-20, 10, 5, 40, 0, -40]])
    poses = pose_from_transform(flange_kinematics(nominal, q))
    targets = tmp_path / "t.csv"
    lines = [f"t{k}," + ",".join(f"{v:.6f}" for v in p) for k, p in enumerate(poses)]
    lines.insert(1, "far,9999,0,0,0,0,0")
    targets.write_text("id,x,y,z,rx,ry,rz\n" + "\n".join(lines) + "\n")
    out = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(model_file), "--robot", "irb1600", "--targets",
                 str(targets), "--out", str(out)]) == 3
    captured = capsys.readouterr()
    assert "t.csv, line 3 (id far)" in captured.err and "1 target refused" in captured.out
    with out.open() as f:
        assert [r["id"] for r in csv.DictReader(f)] == ["t0", "t1", "t2"]


def test_a_long_tool_is_not_taken_for_another_unit(tmp_path, rng):
    """A point 600 mm out on the tool, poses that mostly turn the wrist: the points spread far
    more than the flange does, and no unit explains it: accepted."""
    from screwcal.calibration.measurements import read_measurements_csv

    truth = _table11().with_frames(BASE, exp_twist([0, 0, 0, 0, 0, 600]))
    q = np.zeros((30, 6))
    q[:, 1:3] = np.radians([10, 10])
    q[:, 3:] = rng.uniform(-1.5, 1.5, (30, 3))
    data = simulate_measurements(truth, q, rng, full_pose=False)
    path = _write_measurements(tmp_path / "m.csv", data, full_pose=False)
    assert len(read_measurements_csv(path, irb1600())) == 30


def test_written_numbers_that_round_to_zero_carry_no_minus(tmp_path):
    """Joints, poses and positions a hair below zero are written 0.0000 (compensate) and
    0.000000 (predict), as the program filter writes them: never "-0.0000"."""
    model = tmp_path / "nominal.json"
    save_model(irb1600(), model)
    q = np.radians([[-1e-7, 10, 10, -1e-7, 40, -1e-7], [0, 0, 0, 0, -1e-7, 0]])
    poses = pose_from_transform(flange_kinematics(irb1600(), q))
    targets = tmp_path / "t.csv"
    targets.write_text("id,x,y,z,rx,ry,rz\n" + "".join(
        f"t{k}," + ",".join(repr(float(v)) for v in p) + "\n" for k, p in enumerate(poses)))
    out = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(model), "--targets", str(targets),
                 "--out", str(out)]) == 0
    _zero_written_unsigned(out.read_text(), "0.0000")
    joints = tmp_path / "j.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n-1e-9,0,0,-1e-9,30,0\n")
    predicted = tmp_path / "p.csv"
    assert main(["predict", "--result", str(model), "--joints", str(joints),
                 "--out", str(predicted)]) == 0
    _zero_written_unsigned(predicted.read_text(), "0.000000")


def _zero_written_unsigned(text: str, zero: str) -> None:
    """`text` (a CSV, ids first) holds the value `zero` and no zero with a minus."""
    assert re.search(rf"(^|,){re.escape(zero)}(,|$)", text, re.M), text
    assert not re.search(r"-0\.0+(,|$)", text, re.M), text


def test_the_measurement_file_and_the_pose_list_write_no_minus_zero(tmp_path):
    """The same rule for `simulate --out` (the measurement file) and `testcube --out` (the pose
    list): a value a hair below zero is 0.000000 / 0.0000."""
    from screwcal.calibration.measurements import MeasurementSet, write_measurements_csv
    from screwcal.performance.testcube import PosePlan, write_pose_list

    model = irb1600()
    data = MeasurementSet(q=np.radians([[-1e-9, 10, 10, 0, 30, 0]]),
                          positions_mm=np.array([[800.0, -1e-9, 1000.0]]), ids=("p1",))
    write_measurements_csv(tmp_path / "m.csv", data, model)
    assert (tmp_path / "m.csv").read_text().splitlines()[1] == \
        "p1,0.000000,10.000000,10.000000,0.000000,30.000000,0.000000,800.000000,0.000000," \
        "1000.000000"
    write_pose_list(str(tmp_path / "p.csv"), [PosePlan(0, 1, "P1", "target",
                                                       (-1e-6, 0.0, 0.0, 0.0, 90.0, 0.0),
                                                       (800.0, -1e-6, 900.0, -0.0, 90.0, 0.0))])
    assert (tmp_path / "p.csv").read_text().splitlines()[1] == \
        "0,1,P1,target,0.0000,0.0000,0.0000,0.0000,90.0000,0.0000,800.0000,0.0000,900.0000," \
        "0.0000,90.0000,0.0000"
