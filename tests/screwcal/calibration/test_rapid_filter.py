"""The RAPID program filter: every declaration form, golden output, the refusal list, and the
round trip through the nominal controller to the true robot."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from screwcal.calibration.identify import NoiseModel, identify
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.rapid_filter import _frame, _targets, filter_rapid
from screwcal.calibration.rapid_source import NUMBER, read_rapid_module
from screwcal.calibration.virtual_joints import (
    THESIS_TABLE11,
    apply_virtual_joints,
    perturbed_axes,
)
from screwcal.errors import DataFileError
from screwcal.kinematics.confdata import confdata, solution_for_confdata
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.pose import rotation_angle_deg
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import quaternion_wxyz_from_rotation
from screwcal.studies.simulated_measurements import simulate_measurements

DATA = Path(__file__).parent / "data"
EVERY_FORM = DATA / "every_form.mod"


def _table11() -> object:
    return apply_virtual_joints(irb1600(), THESIS_TABLE11)


def _split_numbers(text: str) -> tuple[list[str], list[float]]:
    """The text between numbers, and the numbers."""
    parts = re.split(f"({NUMBER.pattern})", text)
    return parts[0::2], [float(v) for v in parts[1::2]]


def test_every_declaration_form_matches_the_golden_output():
    text = EVERY_FORM.read_text()
    out, report = filter_rapid(read_rapid_module(str(EVERY_FORM), text), _table11(), irb1600())
    golden = (DATA / "every_form.expected.mod").read_text()
    frame_out, numbers_out = _split_numbers(out)
    frame_golden, numbers_golden = _split_numbers(golden)
    assert frame_out == frame_golden  # everything but the numbers, byte for byte
    np.testing.assert_allclose(numbers_out, numbers_golden, atol=2e-4)
    assert report.compensated == 9  # pHome .. pWobj, both elements of pArr


def test_only_the_numbers_of_trans_rot_and_robconf_change():
    text = EVERY_FORM.read_text()
    out, _ = filter_rapid(read_rapid_module(str(EVERY_FORM), text), _table11(), irb1600())
    before, after = text.splitlines(), out.splitlines()
    assert len(before) == len(after)
    for a, b in zip(before, after, strict=True):
        if a != b:
            assert "robtarget" in a or a.strip().startswith("[")  # a declaration's lines
            assert a.count("9E") == b.count("9E")  # external axes untouched
    assert "! a comment between the elements" in out


def test_what_cannot_be_compensated_is_listed_with_its_line():
    text = EVERY_FORM.read_text()
    _, report = filter_rapid(read_rapid_module(str(EVERY_FORM), text), _table11(), irb1600())
    refused = {(n.line, n.name): n.reason for n in report.refused}
    assert set(refused) == {(14, "pTwice"), (15, "pStationary"), (16, "pMoving"),
                            (17, "pRuntime")}
    assert "several tools" in refused[(14, "pTwice")]
    assert "stationary tool" in refused[(15, "pStationary")]
    assert "moving work object" in refused[(16, "pMoving")]
    assert "run time" in refused[(17, "pRuntime")]
    static = {(n.line, n.name) for n in report.not_static}
    assert {(36, "Offs"), (37, "RelTool"), (38, "CRobT")} <= static
    assert any(line == 39 for line, _ in static)  # the inline target
    summary = report.summary()
    assert f"{EVERY_FORM}:14: pTwice" in summary and "9 robtargets compensated" in summary


def test_a_tool_or_work_object_not_declared_is_refused_by_name():
    text = EVERY_FORM.read_text().replace("tool0 \\WObj:=wTable", "tool0 \\WObj:=wElsewhere")
    _, report = filter_rapid(read_rapid_module("m.mod", text), _table11(), irb1600())
    assert any(n.name == "pWobj" and "wElsewhere".lower() in n.reason.lower()
               for n in report.refused)
    with pytest.raises(Exception, match="tNowhere"):
        filter_rapid(read_rapid_module("m.mod", text), _table11(), irb1600(), tool="tNowhere")


def test_a_broken_declaration_names_the_file_and_line():
    with pytest.raises(DataFileError, match=r"bad\.mod, line 2"):
        read_rapid_module("bad.mod", "MODULE m\n  CONST robtarget p:=[[1,2,3],[1,0,0,0];\n")


def test_the_module_is_read_by_the_parser_whole():
    """Text after ENDMODULE (two modules pasted into one file) was ignored by the old reader;
    the parser refuses it with its line and column."""
    text = EVERY_FORM.read_text() + "MODULE Second\nENDMODULE\n"
    with pytest.raises(DataFileError, match=r"m\.mod, line 42: text after ENDMODULE.*column 1"):
        read_rapid_module("m.mod", text)


def test_a_target_computed_by_an_expression_is_refused_with_its_line():
    """A robtarget whose value (or one of its numbers) is an expression: listed, not a crash."""
    text = ("MODULE m\n  CONST num X0 := 800;\n"
            "  CONST robtarget pBase:=[[900,0,900],[0,0,1,0],[0,0,0,0],"
            "[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  CONST robtarget pOff := Offs(pBase, 0, 0, 10);\n"
            "  CONST robtarget pExpr:=[[X0 + 10,0,900],[0,0,1,0],[0,0,0,0],"
            "[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  CONST robtarget pRot:=[[900,0,900],[0,0,X0 / X0,0],[0,0,0,0],"
            "[9E9,9E9,9E9,9E9,9E9,9E9]];\n"  # in a row after rows of plain numbers
            "  CONST robtarget pHex:=[[0x384,0,900],[0,0,1,0],[0,0,0,0],"
            "[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")  # a literal, not a decimal one
    out, report = filter_rapid(read_rapid_module("m.mod", text), _table11(), irb1600())
    refused = {(n.line, n.name): n.reason for n in report.refused}
    assert set(refused) == {(4, "pOff"), (5, "pExpr"), (6, "pRot"), (7, "pHex")}
    assert all("expression" in why for why in refused.values())
    assert report.compensated == 1 and (4, "Offs") in {(n.line, n.name) for n in
                                                         report.not_static}
    assert out.splitlines()[3:] == text.splitlines()[3:]  # left as written


def test_the_tool_of_a_motion_with_a_signal_is_after_the_zone():
    """MoveLDO ToPoint, Speed, Zone, Tool, Signal, Value: the tool is not the last argument."""
    module = read_rapid_module("m.mod", "MODULE m\n  PROC p()\n"
                               "    MoveLDO p1, v100, z10, tGun \\WObj:=wT, doOut, 1;\n"
                               "    TriggL p2, v100, trigg1 \\T2:=trigg2, z10, tGun;\n"
                               "    MoveC p3, p4, v100, z10, tGun;\n  ENDPROC\nENDMODULE\n")
    assert [(m.targets, m.tool, m.wobj) for m in module.motions] == [
        (["p1"], "tGun", "wT"), (["p2"], "tGun", "wobj0"), (["p3", "p4"], "tGun", "wobj0")]


def _module_of(poses_T: np.ndarray, conf: np.ndarray) -> str:
    lines = ["MODULE Many"]
    for k, (T, c) in enumerate(zip(poses_T, conf, strict=True)):
        q = quaternion_wxyz_from_rotation(T[:3, :3])
        lines.append(f"    CONST robtarget p{k}:=[[{T[0, 3]:.4f},{T[1, 3]:.4f},{T[2, 3]:.4f}],"
                     f"[{q[0]:.9f},{q[1]:.9f},{q[2]:.9f},{q[3]:.9f}],"
                     f"[{c[0]},{c[1]},{c[2]},{c[3]}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];")
    lines.append("ENDMODULE")
    return "\n".join(lines) + "\n"


def _simulated_robots(rng):
    """A true robot with errors everywhere, and the model identified from its measurements
    (flange poses in the robot base frame, so no frame is left to guess)."""
    nominal = irb1600()
    truth = perturbed_axes(_table11(), rng, tilt_deg=0.02)  # axes tilted and shifted, flange
    data = simulate_measurements(truth, random_configurations(80, rng), rng,
                                 joint_noise_deg=0.0)
    calibrated = identify(nominal, data, kind="full", frames="known",
                          noise=NoiseModel(0.013, None, 0.0)).model
    return nominal, truth, calibrated


def test_compensated_targets_put_the_true_robot_on_the_original_targets(rng):
    """The issue's round trip: each compensated robtarget, solved by the nominal controller
    with its confdata, puts the true robot within 0.05 mm / 0.01 deg of the original target."""
    nominal, truth, calibrated = _simulated_robots(rng)
    q = random_configurations(300, rng)
    wanted = flange_kinematics(nominal, q)
    text = _module_of(wanted, confdata(nominal, q))
    out, report = filter_rapid(read_rapid_module("many.mod", text), calibrated, nominal)
    # Table 11's offsets are large (up to 4.6 deg): near the wrist singularity joints 4 and 6
    # would swing far to compensate them, and a few such targets are refused, by name.
    assert report.compensated >= 290
    assert all("near the wrist" in n.reason or "plausible" in n.reason for n in report.refused)
    refused = {n.name for n in report.refused}
    module = read_rapid_module("many.mod", out)
    targets = [t for d in module.declarations for t in _targets(d.name, d.value,
                                                                 module.line_of)]
    kept = np.array([t.name not in refused for t in targets])
    targets, wanted = [t for t in targets if t.name not in refused], wanted[kept]
    T = np.array([_frame(t.tokens[:3], t.tokens[3:7]) for t in targets])
    conf = np.array([[int(tok.text) for tok in t.tokens[7:11]] for t in targets])
    q_controller, found = solution_for_confdata(nominal, T, conf)  # the nominal controller
    assert found.all()
    reached = flange_kinematics(truth, q_controller)
    position = np.linalg.norm(reached[:, :3, 3] - wanted[:, :3, 3], axis=1)
    angle = rotation_angle_deg(reached[:, :3, :3], wanted[:, :3, :3])
    assert position.max() < 0.05 and angle.max() < 0.01
    before = np.linalg.norm(flange_kinematics(truth, q[kept])[:, :3, 3] - wanted[:, :3, 3],
                            axis=1)
    assert before.mean() > 10  # unfiltered, the true robot misses by centimetres


def test_compensate_rapid_command(tmp_path):
    model = tmp_path / "model.json"
    save_model(_table11(), model)
    out = tmp_path / "out.mod"
    run = subprocess.run([sys.executable, "-m", "screwcal", "compensate", "--result", str(model),
                          "--robot", "irb1600", "--rapid", str(EVERY_FORM), "--out", str(out)],
                         capture_output=True, text=True)
    assert run.returncode == 3, run.stderr  # some targets refused (pTwice): listed, not silent
    assert "9 robtargets compensated" in run.stdout and "pTwice" in run.stdout
    assert "largest change" in run.stdout
    frame, _ = _split_numbers(out.read_text())
    assert frame == _split_numbers(EVERY_FORM.read_text())[0]


def test_the_filter_compensates_joint_compliance_too(rng):
    """A calibrated model that bends under gravity: the filtered targets put the bending robot
    on the original targets (the chain the filter solves is the bent one); filtered with the
    same model without its compliance, the bending robot misses."""
    from dataclasses import replace

    nominal = irb1600()
    truth = replace(_table11(), compliance=np.radians([0, 0.6, 1.2, 0, 0, 0]) / 1000.0)
    q = random_configurations(60, rng)
    wanted = flange_kinematics(nominal, q)
    text = _module_of(wanted, confdata(nominal, q))

    def reached_with(model):
        out, report = filter_rapid(read_rapid_module("bent.mod", text), model, nominal)
        refused = {n.name for n in report.refused}
        module = read_rapid_module("bent.mod", out)
        targets = [t for d in module.declarations for t in _targets(d.name, d.value,
                                                                     module.line_of)]
        kept = np.array([t.name not in refused for t in targets])
        targets = [t for t in targets if t.name not in refused]
        T = np.array([_frame(t.tokens[:3], t.tokens[3:7]) for t in targets])
        conf = np.array([[int(tok.text) for tok in t.tokens[7:11]] for t in targets])
        q_controller, found = solution_for_confdata(nominal, T, conf)
        assert found.all() and kept.sum() >= 55
        reached = flange_kinematics(truth, q_controller)
        return np.linalg.norm(reached[:, :3, 3] - wanted[kept, :3, 3], axis=1)

    assert reached_with(truth).max() < 0.01
    assert reached_with(replace(truth, compliance=np.zeros(6))).max() > 0.05
