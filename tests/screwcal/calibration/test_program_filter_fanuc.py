"""A FANUC LS program compensated: /POS positions in user and tool frames from a frames file,
every configuration (flip, up/down, top/bottom, turn numbers), a circular motion's two points,
joint positions left alone, registers and offsets listed; the true robot on the nominal
controller reaches every original target."""

import re

import numpy as np
import pytest

from screwcal.calibration.program_filter import CONVENTIONS, filter_program, matrices
from screwcal.kinematics.robots import builtin_model
from screwcal.programs import ProgramSyntaxError, read_program
from tests.screwcal.calibration.program_cells import (
    controller_tcp,
    fanuc_flags,
    misses,
    pose,
    true_robot,
)

FRAMES = """# user and tool frames (mm, deg), as the controller's SETUP screens show them
UF,1,600.0,-100.0,200.0,0.0,0.0,30.0
UF,2,450.0,250.0,-50.0,2.0,-3.0,-45.0
UT,1,0.0,0.0,120.0,0.0,0.0,0.0
UT,2,10.0,5.0,180.0,0.0,-30.0,15.0
"""
HEADER = """/PROG  CELL
/ATTR
OWNER\t\t= MNEDITOR;
COMMENT\t\t= "calibration cell";
PROG_SIZE\t= 1200;
CREATE\t\t= DATE 26-11-27  TIME 10:00:00;
DEFAULT_GROUP\t= 1,*,*,*,*;
/APPL
/MN
"""
USES = [(1, 1), (1, 1), (2, 1), (2, 2), (0, 1), (0, 2), (1, 2), (2, 1), (1, 1), (0, 1)]


def _joints(rng: np.random.Generator, j6_max_deg: float) -> np.ndarray:
    """Ten postures, joint 6 over its whole range (turn numbers other than 0)."""
    q = np.column_stack([rng.uniform(-60, 60, 10), rng.uniform(-10, 40, 10),
                         rng.uniform(-30, 20, 10), rng.uniform(-90, 90, 10),
                         rng.uniform(30, 90, 10) * rng.choice([-1, 1], 10),
                         rng.uniform(-0.95, 0.95, 10) * j6_max_deg])
    q[:, 2] += q[:, 1]  # serial J3: the FANUC reading plus J2
    return np.radians(q)


def _position(k: int, values: list[float], uf: int, ut: int, config: str) -> str:
    x, y, z, w, p, r = values
    label = ':"pick"' if k == 2 else ""
    return (f"P[{k}{label}]{{\n   GP1:\n\tUF : {uf}, UT : {ut},\t\t"
            f"CONFIG : '{config}',\n"
            f"\tX = {x:10.4f}  mm,\tY = {y:10.4f}  mm,\tZ = {z:10.4f}  mm,\n"
            f"\tW = {w:10.5f} deg,\tP = {p:10.5f} deg,\tR = {r:10.5f} deg\n}};\n")


def fanuc_cell(rng: np.random.Generator, robot: str = "lrmate200id"):
    nominal = builtin_model(robot)
    conv = CONVENTIONS["fanuc"]
    frames = {0: np.eye(4), 1: matrices(np.array([600, -100, 200, 0, 0, 30.0]), conv)[0],
              2: matrices(np.array([450, 250, -50, 2, -3, -45.0]), conv)[0]}
    tools = {1: matrices(np.array([0, 0, 120, 0, 0, 0.0]), conv)[0],
             2: matrices(np.array([10, 5, 180, 0, -30, 15.0]), conv)[0]}
    q = _joints(rng, float(np.degrees(nominal.limits[5, 1])))
    positions = "".join(_position(k + 1, pose("fanuc", frames[uf], tools[ut], nominal, q[k]),
                                  uf, ut, fanuc_flags(nominal, q[k]))
                        for k, (uf, ut) in enumerate(USES))
    joints = ("P[11]{\n   GP1:\n\tUF : 0, UT : 1,\t\n\tJ1=     0.000 deg,\tJ2=     0.000 deg,"
              "\tJ3=     0.000 deg,\n\tJ4=     0.000 deg,\tJ5=   -90.000 deg,\tJ6=     0.000 "
              "deg\n};\n")
    motions = ["UFRAME_NUM=1 ;", "UTOOL_NUM=1 ;", "J P[11] 100% FINE    ;",
               "J P[1] 100% FINE    ;", "L P[2:pick] 500mm/sec CNT50    ;",
               "J P[3] 50% CNT100    ;", "L P[4] 200mm/sec FINE    ;",
               "J P[5] 100% FINE    ;", "L P[6] 100mm/sec FINE    ;",
               "C P[7]    \n    :  P[8] 100mm/sec FINE    ;", "J P[9] 100% FINE    ;",
               "J P[10] 100% FINE    ;"]
    mn = "".join(f"{k + 1:4d}:{'  ' if '=' in m else ''}{m}\n" for k, m in enumerate(motions))
    text = HEADER + mn + "/POS\n" + positions + joints + "/END\n"
    return nominal, {"cell.ls": text}, q


@pytest.mark.parametrize("robot", ["lrmate200id", "m20ia"])
def test_every_fanuc_position_reaches_the_original_target(rng, robot):
    nominal, files, q = fanuc_cell(rng, robot)
    truth = true_robot(nominal, rng)
    frames = ("frames.csv", FRAMES)
    program = read_program(files, frames=frames)
    assert len(program.targets) == 10 and program.joint_targets == 1 and not program.notes
    out, report = filter_program(program, truth, nominal)
    assert report.compensated == 10 and report.complete, report.summary()
    compensated = read_program(out, frames=frames)
    reached, _, wanted = controller_tcp(program, truth, nominal, q)
    before_mm, _ = misses(reached, wanted)
    reached, q_controller, _ = controller_tcp(compensated, truth, nominal, q)
    position_mm, angle_deg = misses(reached, wanted)
    assert position_mm < 0.02 and angle_deg < 0.01
    assert before_mm > 0.5
    # the turn numbers written are those of the joints the controller took
    for t, qq in zip(compensated.targets, q_controller, strict=True):
        turns = [int(v) for v in t.flags["CONFIG"].text.split(",")[1:]]
        assert turns == np.floor((np.degrees(qq[[0, 3, 5]]) + 180) / 360).astype(int).tolist()


def test_only_numbers_and_configurations_change(rng):
    nominal, files, _ = fanuc_cell(rng)
    program = read_program(files, frames=("frames.csv", FRAMES))
    out, _ = filter_program(program, true_robot(nominal, rng), nominal)
    number = r"[-+]?\d+(?:\.\d*)?"
    strip = [re.sub(r"'[NF] [UD] [TB][^']*'", "C", re.sub(number, "#", t))
             for t in (out["cell.ls"], files["cell.ls"])]
    assert strip[0] == strip[1]
    assert "J5=   -90.000 deg" in out["cell.ls"]


def test_registers_offsets_and_increments_are_listed(rng):
    nominal, files, _ = fanuc_cell(rng)
    text = files["cell.ls"].replace(
        "/POS", "  13:L PR[5] 100mm/sec FINE    ;\n  14:L P[1] 100mm/sec FINE Offset,PR[2]"
        "    ;\n  15:L P[9] 100mm/sec FINE INC    ;\n/POS", 1)
    program = read_program({"cell.ls": text}, frames=("frames.csv", FRAMES))
    _, report = filter_program(program, true_robot(nominal, rng), nominal)
    notes = {(n.line, n.name) for n in report.not_static}
    assert (23, "PR[5]") in notes and (24, "Offset") in notes
    assert "INC" in {n.name: n.reason for n in report.refused}["P[9]"]


def test_a_frame_not_in_the_frames_file_refuses_its_positions(rng):
    nominal, files, _ = fanuc_cell(rng)
    program = read_program(files, frames=("frames.csv", FRAMES.replace("UF,2", "UF,7")))
    _, report = filter_program(program, true_robot(nominal, rng), nominal)
    refused = {n.name: n.reason for n in report.refused}
    assert "UF 2 is not in the frames file" in refused["P[3]"]
    assert report.compensated == 10 - sum(uf == 2 for uf, _ in USES)


def test_a_bad_frames_file_names_its_line():
    with pytest.raises(ProgramSyntaxError, match=r"frames\.csv, line 2: expected 'UF,n"):
        read_program({"a.ls": HEADER + "/POS\n/END\n"},
                     frames=("frames.csv", "UF,1,0,0,0,0,0,0\nUFRAME 2\n"))
