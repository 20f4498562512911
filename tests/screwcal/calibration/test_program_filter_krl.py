"""A KUKA KRL program compensated: every declaration form (E6POS and FDAT of the inline forms,
POS, FRAME, arrays, GLOBAL, CIRC's two points, inline aggregates), tools and bases from
$config.dat, the fold, the motion data and $TOOL/$BASE/BAS; the true robot on the nominal
controller reaches every original target."""

import re

import numpy as np
import pytest

from screwcal.calibration.program_filter import filter_program
from screwcal.kinematics.robots import builtin_model
from screwcal.programs import read_program
from tests.screwcal.calibration.program_cells import (
    controller_tcp,
    kuka_flags,
    misses,
    pose,
    true_robot,
)

CONFIG = """DEFDAT $CONFIG PUBLIC
DECL GLOBAL FRAME TOOL_DATA[16]
TOOL_DATA[1]={X 0.0,Y 0.0,Z 150.0,A 0.0,B 0.0,C 0.0}
TOOL_DATA[2]={X 12.5,Y -4.0,Z 210.0,A 30.0,B 10.0,C -5.0}
DECL GLOBAL FRAME BASE_DATA[32]
BASE_DATA[1]={X 900.0,Y -250.0,Z 300.0,A 15.0,B 0.0,C 0.0}
BASE_DATA[2]={X 700.0,Y 350.0,Z 150.0,A -20.0,B 4.0,C 2.0}
ENDDAT
"""
# target name, declaration form, (tool, base) numbers
FORMS = [("XP1", "E6POS", (1, 1)), ("XP2", "E6POS", (2, 0)), ("XP3", "GLOBAL POS", (1, 2)),
         ("XP4", "FRAME", (1, 2)), ("XPA[1]", "ARRAY", (1, 2)), ("XPA[2]", "ARRAY", (1, 2)),
         ("XC1", "E6POS", (1, 2)), ("XC2", "E6POS", (1, 2)), ("INLINE1", "INLINE", (1, 2)),
         ("INLINE2", "INLINE", (2, 0))]


def _joints(rng: np.random.Generator) -> np.ndarray:
    q = np.column_stack([rng.uniform(-60, 60, 10), rng.uniform(-110, -50, 10),
                         rng.uniform(60, 120, 10), rng.uniform(-90, 90, 10),
                         rng.uniform(30, 90, 10) * rng.choice([-1, 1], 10),
                         rng.uniform(-170, 170, 10)])
    q[3] = q[2] + [1.0, 2.0, -1.5, 0.5, 1.0, -1.0]  # a LIN to a FRAME next to XP3
    return np.radians(q)


def _aggregate(values: list[float], flags: tuple[int, int] | None, extra: str = "") -> str:
    body = ",".join(f"{k} {v:.6f}" for k, v in zip("XYZABC", values, strict=True))
    if flags is not None:
        body += f",S {flags[0]},T {flags[1]}"
    return "{" + body + extra + "}"


def krl_cell(rng: np.random.Generator):
    """The nominal KR 16, the program's files and the taught joints."""
    nominal = builtin_model("kr16")
    from screwcal.calibration.program_filter import CONVENTIONS, matrices

    conv = CONVENTIONS["krl"]
    tools = {1: [0, 0, 150, 0, 0, 0], 2: [12.5, -4, 210, 30, 10, -5]}
    bases = {0: [0] * 6, 1: [900, -250, 300, 15, 0, 0], 2: [700, 350, 150, -20, 4, 2]}
    q = _joints(rng)
    agg = {}
    for k, (name, form, (t, b)) in enumerate(FORMS):
        values = pose("krl", matrices(np.array(bases[b], float), conv)[0],
                      matrices(np.array(tools[t], float), conv)[0], nominal, q[k])
        flags = None if form == "FRAME" else kuka_flags(nominal, q[k])
        extra = ",E1 0.0,E2 0.0" if form == "E6POS" else ""
        agg[name] = _aggregate(values, flags, extra)
    dat = ("&ACCESS RVP\n&REL 1\nDEFDAT prog PUBLIC\n"
           "DECL E6AXIS XHOME={A1 0.0,A2 -90.0,A3 90.0,A4 0.0,A5 0.0,A6 0.0,E1 0.0}\n"
           f"DECL E6POS XP1={agg['XP1']}\n"
           "DECL FDAT FP1={TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE,POINT2[] \" \"}\n"
           "DECL PDAT PPDAT1={VEL 100,ACC 100,APO_DIST 100}\n"
           f"DECL E6POS XP2={agg['XP2']}\n"
           "DECL FDAT FP2={TOOL_NO 2,BASE_NO 0,IPO_FRAME #BASE}\n"
           f"DECL GLOBAL POS XP3={agg['XP3']}\n"
           f"DECL FRAME XP4={agg['XP4']}\n"
           "DECL E6POS XPA[4]\n"
           f"XPA[1]={agg['XPA[1]']}\n"
           f"XPA[2]={agg['XPA[2]']}\n"
           f"E6POS XC1={agg['XC1']}\n"
           f"E6POS XC2={agg['XC2']}\n"
           "ENDDAT\n")
    src = ("&ACCESS RVP\nDEF prog( )\n;FOLD INI\n  BAS (#INITMOV,0 )\n;ENDFOLD\nPTP XHOME\n"
           ";FOLD PTP P1 Vel=100 % PDAT1 Tool[1] Base[1];%{PE}%R 8.3.38,%MKUKATPBASIS\n"
           "$BWDSTART=FALSE\nPDAT_ACT=PPDAT1\nFDAT_ACT=FP1\nBAS(#PTP_PARAMS,100)\nPTP XP1\n"
           ";ENDFOLD\n"
           ";FOLD LIN P2 CONT Vel=2 m/s CPDAT1 Tool[2] Base[0];%{PE}\n"
           "FDAT_ACT=FP2\nBAS(#CP_PARAMS,2)\nLIN XP2 C_DIS\n;ENDFOLD\n"
           "$TOOL=TOOL_DATA[1]\n$BASE=BASE_DATA[2]\n"
           "PTP XP3\nLIN XP4\nPTP XPA[1]\nLIN XPA[2]\nCIRC XC1, XC2, CA 90.0\n"
           f"PTP {agg['INLINE1']} C_PTP ; an inline target\n"
           "BAS(#TOOL,2)\nBAS(#BASE,0)\n"
           f"PTP {agg['INLINE2']}\nEND\n")
    return nominal, {"prog.dat": dat, "prog.src": src}, q


def test_every_krl_form_reaches_the_original_targets(rng):
    nominal, files, q = krl_cell(rng)
    truth = true_robot(nominal, rng)
    config = ("$config.dat", CONFIG)
    program = read_program(files, config=config)
    assert len(program.targets) == 10 and not program.notes
    assert program.joint_targets == 1
    out, report = filter_program(program, truth, nominal)
    assert report.compensated == 10, report.summary()
    assert report.complete and report.chosen_nearest == 1  # the FRAME
    compensated = read_program(out, config=config)
    order = [t.name for t in program.targets]
    assert [t.name for t in compensated.targets] == order
    taught = q[[[f[0] for f in FORMS].index(_form_name(n)) for n in order]]
    reached, _, wanted = controller_tcp(program, truth, nominal, taught)
    before_mm, _ = misses(reached, wanted)
    reached, _, _ = controller_tcp(compensated, truth, nominal, taught)
    position_mm, angle_deg = misses(reached, wanted)
    assert position_mm < 0.02 and angle_deg < 0.01
    assert before_mm > 0.5  # uncompensated, the true robot misses by a millimetre or more


def _form_name(name: str) -> str:
    return {"PTP inline": "INLINE1"}.get(name, name)


def test_only_the_numbers_and_flags_change(rng):
    nominal, files, _ = krl_cell(rng)
    program = read_program(files, config=("$config.dat", CONFIG))
    out, _ = filter_program(program, true_robot(nominal, rng), nominal)
    number = r"[-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"
    for path in files:
        assert re.split(number, out[path]) == re.split(number, files[path])
    assert "XHOME={A1 0.0,A2 -90.0" in out["prog.dat"]  # joints left as they are


def test_what_krl_cannot_compensate_is_listed_with_its_line(rng):
    nominal, files, _ = krl_cell(rng)
    src = files["prog.src"].replace("END\n", "LIN XP1:{X 10.0}\nPTP_REL {A1 10.0}\n"
                                    "PTP XNOWHERE\nXP3.X = XP3.X + 1.0\nEND\n")
    dat = files["prog.dat"].replace("ENDDAT", "DECL POS XHALF={X 100.0,Y 0.0}\nENDDAT")
    program = read_program({"prog.dat": dat, "prog.src": src},
                           config=("$config.dat", CONFIG))
    _, report = filter_program(program, true_robot(nominal, rng), nominal)
    assert any(n.name.startswith("XP1:") and "geometric operator" in n.reason and n.line == 30
               for n in report.not_static)
    assert any(n.name == "PTP_REL" for n in report.not_static)
    assert any(n.name == "XNOWHERE" and "not declared" in n.reason for n in report.not_static)
    refused = {n.name: n.reason for n in report.refused}
    assert "assigned when the program runs" in refused["XP3"]
    assert "partial" in refused["XHALF"]
    assert not report.complete


def test_a_tool_missing_from_config_refuses_its_targets(rng):
    nominal, files, _ = krl_cell(rng)
    program = read_program(files)  # no $config.dat
    _, report = filter_program(program, true_robot(nominal, rng), nominal)
    refused = {n.name: n.reason for n in report.refused}
    assert "BASE_DATA[1]: not given (KUKA: --config $config.dat" in refused["XP1"]
    assert "TOOL_DATA[2]: not given" in refused["XP2"]


def test_an_external_tcp_is_refused(rng):
    nominal, files, _ = krl_cell(rng)
    dat = files["prog.dat"].replace("IPO_FRAME #BASE,POINT2", "IPO_FRAME #TCP,POINT2")
    program = read_program({**files, "prog.dat": dat}, config=("$config.dat", CONFIG))
    _, report = filter_program(program, true_robot(nominal, rng), nominal)
    assert "external (stationary) TCP" in {n.name: n.reason for n in report.refused}["XP1"]


@pytest.mark.parametrize("text", ["S 'B110'", "S 6"])
def test_status_written_in_binary_stays_binary(rng, text):
    from screwcal.calibration.program_filter import _kuka_text

    assert _kuka_text("'B110'", 2) == "'B010'"
    assert _kuka_text("6", 2) == "2"
    assert text
