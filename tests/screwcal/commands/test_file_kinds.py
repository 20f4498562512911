"""Issue 38: a file of one kind given where another goes is refused with the command that
takes it, before any work; a file of no known kind is left to the command's reader."""

import json

import pytest

from screwcal.commands.file_kinds import kind_of
from screwcal.commands.main import main
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.robots import irb1600

FILES = {
    "job.json": json.dumps({"id": 1, "state": "done", "performance": {}, "calibration": None}),
    "report.html": "<!DOCTYPE html>\n<html><body>report</body></html>\n",
    "evaluation.json": json.dumps({"units": {"length": "mm"}, "result": {}}),
    "measurements.csv": "id,q1,q2,q3,q4,q5,q6,x,y,z\np1,0,10,10,0,30,0,900,0,900\n",
    # a measurement file missing a position column: still one (its reader names the column)
    "no_z.csv": "q1,q2,q3,q4,q5,q6,x,y\n0,10,10,0,30,0,900,0\n",
    "perf.csv": "cycle,point,q1,q2,q3,q4,q5,q6,x_cmd,y_cmd,z_cmd,x,y,z\n",
    "joints.csv": "q1,q2,q3,q4,q5,q6\n0,10,10,0,30,0\n",
    "targets.csv": "id,x,y,z,rx,ry,rz\na,800,100,900,0,80,0\n",
    "sweeps.csv": "joint,q1,x,y,z\n1,0,1000,0,800\n",
    "P.mod": "MODULE P\nENDMODULE\n",
    "robot.urdf": "<?xml version='1.0'?>\n<robot name='r'></robot>\n",
}
KINDS = {"job.json": "job", "report.html": "html", "evaluation.json": "evaluation",
         "measurements.csv": "measurements", "no_z.csv": "measurements",
         "perf.csv": "performance", "joints.csv": "joints",
         "targets.csv": "poses", "sweeps.csv": "sweeps", "P.mod": "rapid", "robot.urdf": "urdf"}


@pytest.fixture
def files(tmp_path):
    for name, text in FILES.items():
        (tmp_path / name).write_text(text)
    save_model(irb1600(), tmp_path / "model.json")
    return tmp_path


def test_each_kind_is_recognised(files):
    assert {name: kind_of(files / name) for name in KINDS} == KINDS
    assert kind_of(files / "model.json") == "model"
    (files / "other.json").write_text('{"a": 1}')
    assert kind_of(files / "other.json") is None and kind_of(files / "none") is None


@pytest.mark.parametrize(("argv", "given", "names"), [
    (["predict", "--result", "{job.json}", "--joints", "{joints.csv}"], "job.json",
     ["result.json", "screwcal job model"]),
    (["compensate", "--result", "{report.html}", "--targets", "{targets.csv}"], "report.html",
     ["browser"]),
    (["robot", "export", "{job.json}", "--format", "urdf"], "job.json", ["result.json"]),
    (["calibrate", "--robot", "irb1600", "--data", "{perf.csv}"], "perf.csv",
     ["screwcal evaluate --data"]),
    (["evaluate", "--data", "{measurements.csv}"], "measurements.csv",
     ["screwcal calibrate --data"]),
    (["predict", "--robot", "{robot.urdf}", "--joints", "{joints.csv}"], "robot.urdf",
     ["screwcal robot import"]),
    (["compensate", "--result", "{model.json}", "--rapid", "{targets.csv}"], "targets.csv",
     ["--targets"]),
])
def test_a_file_of_another_kind_is_refused_with_the_command_that_takes_it(files, capsys, argv,
                                                                         given, names):
    out = files / "out.txt"
    line = [str(files / a[1:-1]) if a.startswith("{") else a for a in argv] + ["--out", str(out)]
    assert main(line) == 2
    err = capsys.readouterr().err
    assert given in err and all(n in err for n in names), err
    assert len(err.strip().splitlines()) == 1 and not out.exists()


def test_simulate_writes_the_measurement_file_calibrate_takes(tmp_path, capsys):
    data = tmp_path / "measurements.csv"
    assert main(["simulate", "--poses", "30", "--out", str(data)]) == 0
    assert kind_of(data) == "measurements"
    assert f"--data {data}" in capsys.readouterr().out  # the next command, named
    assert main(["calibrate", "--robot", "irb1600", "--data", str(data), "--base-frame", "known",
                 "--out", str(tmp_path / "result.json")]) == 0
    assert kind_of(tmp_path / "result.json") == "result"
