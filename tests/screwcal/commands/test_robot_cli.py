"""`screwcal robot list / show / import / export` (issue 27)."""

import json

import numpy as np

from screwcal.commands.main import main
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.modelfile import load_model
from screwcal.kinematics.robots import LIBRARY
from tests.conftest import random_q


def test_list_names_every_library_robot(capsys):
    assert main(["robot", "list"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in LIBRARY)


def test_show_gives_geometry_limits_masses_and_sources(capsys):
    assert main(["robot", "show", "kr16"]) == 0
    out = capsys.readouterr().out
    assert "KR 16-2 datasheet: max. reach 1611 mm" in out
    assert "[ -185.0,   185.0]" in out and "kg moving with joint 2" in out


def test_export_import_round_trip_through_urdf(tmp_path, rng, capsys):
    urdf, robot = tmp_path / "ur10e.urdf", tmp_path / "robot.json"
    assert main(["robot", "export", "ur10e", "--format", "urdf", "--out", str(urdf)]) == 0
    assert main(["robot", "import", str(urdf), "--out", str(robot), "--name", "my-ur"]) == 0
    back, model = load_model(robot), LIBRARY["ur10e"].model()
    assert back.name == "my-ur" and len(back.masses) == 3
    q = random_q(model, rng, 500)
    np.testing.assert_allclose(forward_kinematics(back, q), forward_kinematics(model, q),
                               atol=1e-9)


def test_dh_export_of_a_calibrated_result_is_refused_and_names_mdh(tmp_path, rng, capsys):
    from screwcal.kinematics.modelfile import save_model
    from tests.screwcal.kinematics.test_robots import calibrated

    path = tmp_path / "cal.json"
    save_model(calibrated(LIBRARY["irb1600"].model(), rng), path)
    out = tmp_path / "dh.json"
    assert main(["robot", "export", str(path), "--format", "dh", "--out", str(out)]) == 2
    assert "mdh" in capsys.readouterr().err and not out.exists()
    assert main(["robot", "export", str(path), "--format", "mdh", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["representation"] == "mdh"


def test_import_of_a_wrong_form_names_the_template(tmp_path, capsys):
    path = tmp_path / "t.json"
    path.write_text(json.dumps({"representation": "dh", "name": "x", "joints": []}))
    assert main(["robot", "import", str(path), "--format", "mdh", "--out",
                 str(tmp_path / "o.json")]) == 2
    assert "docs/robots.md" in capsys.readouterr().err
