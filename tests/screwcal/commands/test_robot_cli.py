"""`screwcal robot list / show / import / export` (issue 27)."""

import json
import re

import numpy as np
import pytest

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


CODE_NAME = re.compile(r"\b[a-z0-9]+_[a-z0-9_]+\b")  # reach_mm, drift_ppm, warmup_s


@pytest.mark.parametrize("name", list(LIBRARY))
def test_show_speaks_words_with_units_not_code_names(capsys, name):
    """Issue 38: 'checked against: ... (reach_mm 1611, within 8.055 mm)', and 'rz -0.000'."""
    assert main(["robot", "show", name]) == 0
    out = capsys.readouterr().out
    checked = next(line for line in out.splitlines() if "checked against" in line)
    assert not CODE_NAME.findall(checked), checked
    assert re.search(r"; the model's (reach \(the wrist centre's largest distance from axis 1\)|"
                     r"tool0 position at home) is .+ mm within \d", checked), checked
    assert "-0.000 " not in out and not out.rstrip().endswith("-0.000 deg"), out


def test_the_emulated_robots_effects_are_words_with_units():
    """What an emulated robot carries (the demo's terminal and the report's robot section):
    it printed the realism file's keys (compliance_deg_per_knm, drift_ppm, warmup_s)."""
    from simulators.realism import PRESETS

    for realism in PRESETS.values():
        lines = realism.describe()
        assert lines and not [line for line in lines if CODE_NAME.search(line)], lines
        assert all(not line.endswith(":") for line in lines), lines
    harsh = "\n".join(PRESETS["harsh"].describe())
    assert "J2 0.24 deg/kNm" in harsh and "warm-up time constant of 1800 s" in harsh
    assert "80 ppm" in harsh and "0.0006 deg per joint and stop (1 sigma)" in harsh


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


def test_a_result_carries_its_robot_to_compensate(tmp_path, rng, capsys):
    """A robot given as a file at calibrate: compensate once failed with "'my-arm' is neither a
    built-in robot nor an existing model file" unless given --robot again."""
    from dataclasses import replace

    from screwcal.calibration.posesets import random_configurations
    from screwcal.kinematics.modelfile import save_model
    from screwcal.kinematics.pose import pose_from_transform
    from screwcal.studies.simulated_measurements import simulate_measurements
    from tests.screwcal.calibration.test_identify import BASE, TOOL, full_truth
    from tests.screwcal.commands.test_calibrate_cli import _write_measurements

    robot = tmp_path / "my-arm.json"
    save_model(replace(LIBRARY["irb1600"].model(), name="my-arm"), robot)
    truth = full_truth(rng).with_frames(BASE, TOOL)
    data = simulate_measurements(truth, random_configurations(40, rng), rng, joint_noise_deg=0)
    result = tmp_path / "r.json"
    assert main(["calibrate", "--robot", str(robot), "--data",
                 str(_write_measurements(tmp_path / "m.csv", data)), "--out", str(result)]) == 0
    robot.unlink()  # the result alone is enough from here on
    targets = tmp_path / "t.csv"
    wanted = forward_kinematics(LIBRARY["irb1600"].model(), random_configurations(3, rng))
    targets.write_text("id,x,y,z,rx,ry,rz\n" + "\n".join(
        f"t{k}," + ",".join(f"{v:.8f}" for v in pose)
        for k, pose in enumerate(pose_from_transform(wanted))) + "\n")
    comp = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(result), "--targets", str(targets),
                 "--out", str(comp)]) == 0
    assert "model 'my-arm'" in capsys.readouterr().out
    assert main(["robot", "export", str(result), "--format", "urdf",
                 "--out", str(tmp_path / "cal.urdf")]) == 0
    old = json.loads(result.read_text())  # a result written before results held the robot
    del old["nominal_model"]
    result.write_text(json.dumps(old))
    assert main(["compensate", "--result", str(result), "--targets", str(targets),
                 "--out", str(comp)]) == 2
    err = capsys.readouterr().err
    assert "robot 'my-arm', which is not in the library" in err and "--robot FILE" in err


def test_the_templates_in_the_docs_import_to_the_library_robots(tmp_path, rng):
    """docs/robots.md's JSON examples are real: each imports and equals its library robot."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[3] / "docs" / "robots.md").read_text()
    blocks = re.findall(r"```json\n(.*?)```", text, re.S)
    assert len(blocks) == 2
    for k, block in enumerate(blocks):
        doc = json.loads(block)
        path = tmp_path / f"t{k}.json"
        path.write_text(block)
        out = tmp_path / f"r{k}.json"
        assert main(["robot", "import", str(path), "--format", doc["representation"],
                     "--out", str(out)]) == 0
        model, back = LIBRARY[doc["name"]].model(), load_model(out)
        q = random_q(model, rng, 300)
        np.testing.assert_allclose(forward_kinematics(back, q), forward_kinematics(model, q),
                                   atol=1e-9)


def test_calibrate_help_is_calibrate_s_own_and_every_option_has_help():
    """calibrate --help showed compensate's usage line; --solver and --base-frame had no help."""
    import argparse

    from screwcal.commands.main import build_parser

    commands = {}
    for name in ("calibrate", "compensate", "predict", "robot"):  # calibrate adds align
        sub = next(a for a in build_parser(name)._actions
                   if isinstance(a, argparse._SubParsersAction))
        commands |= sub.choices
    for name in ("calibrate", "compensate", "align", "predict", "robot"):
        assert all(a.help for a in commands[name]._actions if a.option_strings), name
    assert "screwcal compensate" not in commands["calibrate"].format_help()


def test_library_robot_written_in_the_frame_its_controller_reports_in(tmp_path, rng, capsys):
    """FANUC's World frame (ROS-I's `base`) is 330 mm above the LR Mate's base_link; UR's
    controller base is the library's frame and base_link is turned 180 deg from it."""
    assert main(["robot", "show", "lrmate200id"]) == 0
    assert "frames: base_link (default); base at z 330 mm" in capsys.readouterr().out
    assert main(["robot", "show", "ur5e"]) == 0
    assert "frames: base (default); base_link at rz 180 deg" in capsys.readouterr().out
    out = tmp_path / "world.json"
    assert main(["robot", "import", "lrmate200id", "--base-link", "base", "--out", str(out)]) == 0
    assert "in frame 'base'" in capsys.readouterr().out
    world, model = load_model(out), LIBRARY["lrmate200id"].model()
    q = random_q(model, rng, 100)
    shift = forward_kinematics(model, q)[:, :3, 3] - [0, 0, 330.0]
    np.testing.assert_allclose(world.with_frames(np.eye(4)).home_flange[:3, 3],
                               model.home_flange[:3, 3] - [0, 0, 330.0], atol=1e-9)
    np.testing.assert_allclose(forward_kinematics(world.with_frames(np.eye(4)), q)[:, :3, 3],
                               shift, atol=1e-9)
    assert main(["robot", "import", "ur5e", "--base-link", "base_link", "--out", str(out)]) == 0
    np.testing.assert_allclose(load_model(out).axis_dirs[1], [0, 1, 0], atol=1e-12)  # was -y
    assert main(["robot", "import", "ur5e", "--base-link", "world", "--out",
                 str(tmp_path / "no.json")]) == 2
    assert "no frame 'world'; its frames: base, base_link (default base)" in \
        capsys.readouterr().err and not (tmp_path / "no.json").exists()


def test_urdf_import_in_the_controller_frame_by_link_name(tmp_path, capsys):
    """An exported LR Mate with ROS-I's `base` link added: the default import starts at
    base_link and says where `base` is; --base-link base gives the library's World-frame robot;
    --tip-link ends the chain elsewhere."""
    from screwcal.kinematics.urdf import urdf_from_model

    text = urdf_from_model(LIBRARY["lrmate200id"].model()).replace(
        "</robot>", '<link name="base"/><joint name="base_link-base" type="fixed"><parent '
        'link="base_link"/><child link="base"/><origin xyz="0 0 0.33"/></joint></robot>')
    path, out = tmp_path / "lrmate.urdf", tmp_path / "r.json"
    path.write_text(text)
    assert main(["robot", "import", str(path), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "chain from 'base_link' (default; --base-link) to 'tool0' (default" in said
    assert "link 'base' (ROS-Industrial: the frame the controller reports in) is at z 330 mm" \
        in said
    assert main(["robot", "import", str(path), "--base-link", "base", "--out", str(out)]) == 0
    expected = LIBRARY["lrmate200id"].model_in("base")
    np.testing.assert_allclose(load_model(out).home_flange, expected.home_flange, atol=1e-9)
    np.testing.assert_allclose(load_model(out).axis_points_mm, expected.axis_points_mm,
                               atol=1e-9)
    assert main(["robot", "import", str(path), "--tip-link", "link_5", "--out", str(out)]) == 0
    assert load_model(out).n_joints == 5


def test_fanuc_urdf_takes_the_controller_readings_as_they_are(tmp_path, rng, capsys):
    """The LR Mate's exported joint_3 was the serial angle: fed the controller's J3 it was
    2091 mm off predict. Now a mimic joint carries the J2/J3 coupling, said on export; a URDF
    library (yourdfpy) given the readings puts tool0 where the model does, and the file reads
    back to the same serial robot."""
    yourdfpy = pytest.importorskip("yourdfpy")
    from screwcal.kinematics.forward import flange_kinematics
    from screwcal.kinematics.readings import readings_from_serial

    path = tmp_path / "lrmate.urdf"
    assert main(["robot", "export", "lrmate200id", "--format", "urdf", "--out", str(path)]) == 0
    assert "FANUC's J2/J3 coupling is in the URDF" in capsys.readouterr().out
    model = LIBRARY["lrmate200id"].model()
    q = random_q(model, rng, 30)
    readings = readings_from_serial(q, "fanuc")
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False,
                              load_collision_meshes=False)
    assert urdf.actuated_joint_names == [f"joint_{i}" for i in range(1, 7)]
    expected = flange_kinematics(model, q)
    for k in range(len(q)):
        urdf.update_cfg(readings[k])
        T = urdf.get_transform("tool0", "base_link")
        assert np.abs(T[:3, 3] * 1000.0 - expected[k, :3, 3]).max() < 1e-6
    out = tmp_path / "back.json"
    assert main(["robot", "import", str(path), "--out", str(out)]) == 0
    assert "FANUC's J2/J3 coupling, read as one serial joint" in capsys.readouterr().out
    np.testing.assert_allclose(forward_kinematics(load_model(out), q),
                               forward_kinematics(model, q), atol=1e-9)
    assert main(["robot", "export", "lrmate200id", "--format", "urdf", "--joint-convention",
                 "serial", "--out", str(path)]) == 0
    assert "coupling" not in path.read_text()


def test_a_mimic_joint_other_than_the_coupling_is_refused(tmp_path, capsys):
    from screwcal.kinematics.urdf import urdf_from_model

    text = urdf_from_model(LIBRARY["m20ia"].model(), j23_coupling=True).replace(
        'multiplier="1"', 'multiplier="2"')
    path = tmp_path / "m.urdf"
    path.write_text(text)
    assert main(["robot", "import", str(path), "--out", str(tmp_path / "o.json")]) == 2
    assert "joint 'joint_3_coupling' mimics joint 'joint_2': not a serial arm" in \
        capsys.readouterr().err


def test_joint_names_efforts_and_speeds_survive_import_calibrate_export(tmp_path, capsys):
    """Exports wrote effort="0" velocity="0" and joint_1 .. joint_6 whatever the URDF said
    (joint_a1, shoulder_pan_joint); now the robot file keeps them and the export writes them."""
    import xml.etree.ElementTree as ET

    from tests.screwcal.commands.test_robot_import_hostile import arm

    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
             "wrist_2_joint", "wrist_3_joint"]
    swap = tuple((f'name="joint_{i}"', f'name="{n}"') for i, n in enumerate(names, 1))
    swap += (('effort="10" velocity="3"/>\n</joint>\n<link name="link_2"',
              'effort="150" velocity="3.14159"/>\n</joint>\n<link name="link_2"'),)
    path, robot, urdf = tmp_path / "ur.urdf", tmp_path / "ur.json", tmp_path / "out.urdf"
    path.write_text(arm(swap=swap))
    assert main(["robot", "import", str(path), "--out", str(robot)]) == 0
    doc = json.loads(robot.read_text())
    assert [j["name"] for j in doc["joints"]] == names
    assert doc["joints"][0]["effort_nm"] == 150 and \
        doc["joints"][0]["velocity_deg_s"] == pytest.approx(179.9998, abs=1e-4)
    assert main(["robot", "export", str(robot), "--format", "urdf", "--out", str(urdf)]) == 0
    joints = {j.get("name"): j for j in ET.parse(urdf).getroot().findall("joint")}
    assert set(names) <= set(joints)
    limit = joints["shoulder_pan_joint"].find("limit")
    assert float(limit.get("effort")) == 150 and float(limit.get("velocity")) == \
        pytest.approx(3.14159, abs=1e-12)
    assert float(joints["wrist_3_joint"].find("limit").get("effort")) == 10
    capsys.readouterr()
    assert main(["robot", "show", str(robot)]) == 0
    assert "1 shoulder_pan_joint (150 N m, 180 deg/s); 2 shoulder_lift_joint (10 N m, 171.9 " \
        "deg/s)" in capsys.readouterr().out


def test_library_urdf_export_names_frames_as_ros_industrial(tmp_path, rng, capsys):
    """An exported UR5e's base_link was UR's controller base (180 deg from ROS-I's base_link);
    now the root is ROS-I's base_link and `base` a link of its own, so the export reads like
    ROS-I's file: imported from base (or base_link) it is the library robot (or ROS-I's)."""
    for name, said in (("ur5e", "link 'base' (the frame the controller reports in) at rz 180"),
                       ("lrmate200id", "link 'base' (the frame the controller reports in) at "
                                       "z 330 mm")):
        path, out = tmp_path / f"{name}.urdf", tmp_path / f"{name}.json"
        assert main(["robot", "export", name, "--format", "urdf", "--out", str(path)]) == 0
        assert said in capsys.readouterr().out
        entry = LIBRARY[name]
        q = random_q(entry.model(), rng, 50)
        for link in ("base", "base_link"):
            assert main(["robot", "import", str(path), "--base-link", link, "--out",
                         str(out)]) == 0
            np.testing.assert_allclose(
                forward_kinematics(load_model(out).with_frames(np.eye(4)), q),
                forward_kinematics(entry.model_in(link).with_frames(np.eye(4)), q), atol=1e-9)
