import csv
import re
import subprocess
import sys

import numpy as np
import pytest

from screwcal.commands.main import main
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.pose import pose_from_transform
from tests.conftest import random_model, random_q


def _write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def _read(path):
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_predict_irb1600_nominal(tmp_path):
    joints = _write(tmp_path / "joints.csv",
                    "q3,id,q1,q2,q4,q5,q6,comment\n"
                    "0,home,0,0,0,0,0,x\n"
                    "6.5768,37,-53.6383,45.9603,-9.2281,-83.1463,55.7123,y\n")
    out = tmp_path / "predicted.csv"
    assert main(["predict", "--model", "irb1600", "--joints", str(joints), "--out", str(out)]) == 0
    rows = _read(out)
    assert list(rows[0]) == ["id", "x", "y", "z", "rx", "ry", "rz"]
    assert [r["id"] for r in rows] == ["home", "37"]
    np.testing.assert_allclose([float(rows[0][c]) for c in "xyz"], [815, 0, 961.5], atol=1e-6)
    assert float(rows[0]["ry"]) == pytest.approx(90.0)
    np.testing.assert_allclose([float(rows[1][c]) for c in ("x", "z", "rx", "ry", "rz")],
                               [548.8550, 373.0396, 52.5837, 34.3963, 23.5934], atol=2e-3)


def test_predict_with_a_model_file_includes_base_and_tool(tmp_path, rng):
    model = random_model(rng)
    save_model(model, tmp_path / "m.json", "mdh")
    q = random_q(model, rng, 5)
    lines = ["q1,q2,q3,q4,q5,q6"] + [",".join(f"{v:.10f}" for v in row)
                                     for row in np.degrees(q)]
    joints = _write(tmp_path / "j.csv", "\n".join(lines) + "\n")
    out = tmp_path / "p.csv"
    assert main(["predict", "--model", str(tmp_path / "m.json"), "--joints", str(joints),
                 "--out", str(out)]) == 0
    rows = _read(out)
    assert [r["id"] for r in rows] == ["1", "2", "3", "4", "5"]
    got = np.array([[float(r[c]) for c in ("x", "y", "z", "rx", "ry", "rz")] for r in rows])
    expected = pose_from_transform(forward_kinematics(model, q))
    np.testing.assert_allclose(got[:, :3], expected[:, :3], atol=1e-5)


@pytest.mark.parametrize(("content", "message"), [
    ("q1,q2,q3,q4,q5\n0,0,0,0,0\n", r"joints\.csv, line 1, column 'q6': missing column"),
    ("q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n0,0,abc,0,0,0\n",
     r"line 3, column 'q3': 'abc' is not a number"),
    ("q1,q2,q3,q4,q5,q6\n0,0,0,nan,0,0\n", r"line 2, column 'q4': 'nan' is not a finite"),
    ("q1,q2,q3,q4,q5,q6\n0,0,0,0,0\n", r"line 2: 5 fields where the header has 6"),
    ("q1,q2,q3,q4,q5,q6\n", r"0 data row"),
    ("", r"line 1: the file is empty"),
    ("q1,q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0,0\n", r"duplicate column"),
])
def test_bad_joint_files_are_refused_and_nothing_is_written(tmp_path, capsys, content, message):
    joints = _write(tmp_path / "joints.csv", content)
    out = tmp_path / "predicted.csv"
    code = main(["predict", "--model", "irb1600", "--joints", str(joints), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code != 0
    assert len(err.splitlines()) == 1
    assert err.startswith("screwcal predict: error: ")
    assert re.search(message, err), err
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [joints]  # no temporary file left behind either


def test_unknown_model_is_refused(tmp_path, capsys):
    joints = _write(tmp_path / "j.csv", "q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n")
    assert main(["predict", "--model", "irb9999", "--joints", str(joints),
                 "--out", str(tmp_path / "o.csv")]) == 2
    assert "neither a library robot" in capsys.readouterr().err


def test_out_of_limit_joints_are_predicted_with_a_warning(tmp_path, capsys):
    joints = _write(tmp_path / "j.csv", "q1,q2,q3,q4,q5,q6\n0,170,0,0,0,0\n")
    assert main(["predict", "--model", "irb1600", "--joints", str(joints),
                 "--out", str(tmp_path / "o.csv")]) == 0
    assert "line 2: joints outside the limits" in capsys.readouterr().err


COMMANDS = ("demo", "simulate", "predict", "calibrate", "compensate", "evaluate", "testcube",
            "align", "emulator", "serve", "job")


def test_the_console_script_runs():
    exe = [sys.executable, "-m", "screwcal"]
    top = subprocess.run([*exe, "--help"], capture_output=True, text=True, check=True).stdout
    assert all(command in top for command in COMMANDS)


@pytest.mark.parametrize("command", COMMANDS)
def test_every_subcommand_has_help(command, capsys):
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    assert done.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: screwcal {command}")


def test_the_command_table_names_each_modules_commands():
    """main imports only the named command's module: the table must list every command each
    module registers, and nothing else (a command missing from it would still work, through
    the full parser, but pay every module's import)."""
    import argparse
    import importlib

    from screwcal.commands.main import COMMANDS as TABLE

    for module in set(TABLE.values()):
        sub = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(module).add_parser(sub)
        assert set(sub.choices) == {c for c, m in TABLE.items() if m == module}, module
    assert set(TABLE) >= set(COMMANDS)


def test_a_mistyped_command_lists_them_all(capsys):
    with pytest.raises(SystemExit) as done:
        main(["calibrat"])
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'calibrat'" in err and "emulator" in err and "calibrate" in err


def test_predict_uses_the_model_files_compliance_and_a_given_payload(tmp_path):
    from dataclasses import replace

    from screwcal.kinematics.robots import irb120

    stiff = irb120()
    soft = replace(stiff, compliance=np.radians([0, 3.0, 15.0, 0, 0, 0]) / 1000.0)
    save_model(soft, tmp_path / "soft.json")
    joints = _write(tmp_path / "joints.csv", "q1,q2,q3,q4,q5,q6\n0,60,0,0,30,0\n")
    outs = {}
    for name, extra in (("bent", []), ("loaded", ["--payload-kg", "3", "--payload-cog-mm",
                                                  "0,0,50"])):
        out = tmp_path / f"{name}.csv"
        assert main(["predict", "--model", str(tmp_path / "soft.json"), "--joints",
                     str(joints), "--out", str(out), *extra]) == 0
        outs[name] = np.array([[float(r[k]) for k in ("x", "y", "z")] for r in _read(out)])
    q = np.radians([[0, 60, 0, 0, 30, 0]])
    rigid = forward_kinematics(stiff, q)[0, :3, 3]
    assert outs["bent"][0, 2] < rigid[2] - 0.05  # the stretched arm sags
    assert outs["loaded"][0, 2] < outs["bent"][0, 2] - 0.05  # and more under a payload

