"""A URScript program compensated: pose literals in movel/movej/movep/movec, pose variables,
features by pose_trans, get_inverse_kin, two TCPs set by set_tcp; no flags, so each target
keeps the solution nearest the one before it, as UR's controller takes it."""

import re

import numpy as np

from screwcal.calibration.program_filter import CONVENTIONS, filter_program, matrices
from screwcal.kinematics.robots import builtin_model
from screwcal.programs import read_program
from tests.screwcal.calibration.program_cells import controller_tcp, misses, pose, true_robot

TCP1 = [0.0, 0.0, 0.15, 0.0, 0.0, 0.0]
TCP2 = [0.01, 0.005, 0.18, 0.0, -0.5236, 0.2618]
FEATURE = [0.3, -0.2, 0.05, 0.0, 0.0, 0.5236]
LITERAL_FEATURE = [-0.1, 0.25, 0.0, 0.1, 0.0, -0.3]


def _p(values: list[float]) -> str:
    return "p[" + ", ".join(f"{v:.7f}" for v in values) + "]"


def ur_cell(rng: np.random.Generator):
    """UR5e, a path of ten postures a few tens of degrees apart, the program and its TCPs and
    features per target."""
    nominal = builtin_model("ur5e")
    conv = CONVENTIONS["urscript"]
    q = [np.radians([10.0, -100.0, 90.0, -80.0, -90.0, 20.0])]
    for _ in range(9):
        q.append(q[-1] + np.radians(rng.uniform(-20, 20, 6)))
    q = np.array(q)
    m = {name: matrices(np.array(v), conv)[0] for name, v in
         (("tcp1", TCP1), ("tcp2", TCP2), ("feature", FEATURE), ("lit", LITERAL_FEATURE))}
    eye = np.eye(4)
    # (frame, tool) of each target, in program order
    uses = [(eye, m["tcp1"]), (eye, m["tcp1"]), (m["feature"], m["tcp1"]),
            (m["lit"], m["tcp1"]), (eye, m["tcp1"]), (eye, m["tcp1"]), (eye, m["tcp1"]),
            (eye, m["tcp2"]), (eye, m["tcp2"]), (eye, m["tcp2"])]
    p = [_p(pose("urscript", f, t, nominal, q[k])) for k, (f, t) in enumerate(uses)]
    text = (f"def cell():\n  # a pick and place cell\n  set_tcp({_p(TCP1)})\n"
            f"  feature = {_p(FEATURE)}\n  approach = {p[0]}\n"
            "  movej(approach, a=1.2, v=0.5)\n"
            f"  movel({p[1]}, a=1.2, v=0.25)\n"
            f"  movel(pose_trans(feature, {p[2]}), a=1.2, v=0.25)\n"
            f"  movel(pose_trans({_p(LITERAL_FEATURE)}, {p[3]}), a=1.2, v=0.25)\n"
            f"  movep({p[4]}, a=1.2, v=0.25, r=0.01)\n"
            f"  movec({p[5]}, {p[6]}, a=1.2, v=0.25, r=0, mode=0)\n"
            f"  set_tcp({_p(TCP2)})\n"
            f"  movej(get_inverse_kin({p[7]}), a=1.4, v=1.05)\n"
            f"  place = {p[9]}\n"
            f"  movel({p[8]}, a=1.2, v=0.25)\n"
            "  movel(place, a=1.2, v=0.25)\n"
            "  movej([0.0, -1.57, 1.57, -1.57, -1.57, 0.0], a=1.4, v=1.05)\nend\n")
    return nominal, {"cell.script": text}, q


def _taught_in_file_order(program, q):
    # the variables are declared before their motions: file order puts `approach` (motion 1)
    # and `place` (motion 10) where they are assigned
    names = [t.name for t in program.targets]
    order = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]  # `place` is assigned before motion 9
    assert names[0] == "approach" and names[8] == "place", names
    return q[order]


def test_every_urscript_form_reaches_the_original_target(rng):
    nominal, files, q = ur_cell(rng)
    truth = true_robot(nominal, rng)
    program = read_program(files)
    assert len(program.targets) == 10 and program.joint_targets == 1, program.targets
    assert not program.notes
    out, report = filter_program(program, truth, nominal, start_deg=np.degrees(q[0]))
    assert report.compensated == 10 and report.complete, report.summary()
    assert report.chosen_nearest == 10
    taught = _taught_in_file_order(program, q)
    reached, _, wanted = controller_tcp(program, truth, nominal, taught)
    before_mm, _ = misses(reached, wanted)
    compensated = read_program(out)
    reached, q_controller, _ = controller_tcp(compensated, truth, nominal, taught)
    position_mm, angle_deg = misses(reached, wanted)
    assert position_mm < 0.02 and angle_deg < 0.01
    assert before_mm > 0.5
    assert np.abs(q_controller - taught).max() < np.radians(1.0)  # the taught branch kept


def test_only_the_pose_numbers_change(rng):
    nominal, files, q = ur_cell(rng)
    out, _ = filter_program(read_program(files), true_robot(nominal, rng), nominal,
                            start_deg=np.degrees(q[0]))
    number = r"[-+]?\d+(?:\.\d*)?"
    assert re.split(number, out["cell.script"]) == re.split(number, files["cell.script"])
    for kept in (_p(TCP1), _p(TCP2), _p(FEATURE), _p(LITERAL_FEATURE), "r=0.01",
                 "# a pick and place cell"):
        assert kept in out["cell.script"]


def test_computed_poses_are_listed_with_their_line(rng):
    text = ("def prog():\n  base = p[0.4, 0.0, 0.3, 0.0, 3.1416, 0.0]\n"
            "  movel(pose_add(base, p[0.0, 0.0, 0.05, 0.0, 0.0, 0.0]))\n"
            "  moved = p[0.4, 0.1, 0.3, 0.0, 3.1416, 0.0]\n  moved = pose_inv(moved)\n"
            "  movel(moved)\n  movel(p[0.4, 0.1, d2r(10), 0, 3.14, 0])\n"
            "  set_tcp(get_tcp_offset())\n  movel(p[0.4, 0.1, 0.3, 0.0, 3.1416, 0.0])\nend\n")
    program = read_program({"prog.script": text})
    nominal = builtin_model("ur5e")
    _, report = filter_program(program, nominal, nominal)
    lines = {(n.line, n.reason.split(":")[0][:30]) for n in report.not_static + report.refused}
    assert (3, "computed when the program runs") in lines  # pose_add
    refused = {(n.line, n.name): n.reason for n in report.refused}
    assert "assigned 2 times" in refused[(4, "moved")]
    assert "expression" in refused[(7, "movel pose")]
    assert "set_tcp(get_tcp_offset())" in refused[(9, "movel pose")]
    # a pose variable no motion names (a speed, a force frame, a pose_add operand) is no target
    assert not any(n.name == "base" for n in report.not_static + report.refused)
