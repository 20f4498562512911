"""Forms found in public programs nobody here wrote (FANUC controller backups with several
motion groups and untaught positions, KUKA training programs with partial aggregates, UR's own
script examples), written here in those forms; and, when $SCREWCAL_PUBLIC_PROGRAMS names a
folder of such programs (krl/, fanuc/, urscript/ under it, fetched, never committed), every one
read and filtered without a crash."""

import collections
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from screwcal.calibration.program_filter import filter_program
from screwcal.kinematics.robots import builtin_model
from screwcal.programs import ProgramSyntaxError, read_program

HEADER = "/PROG  UP002\n/ATTR\nOWNER\t\t= MNEDITOR;\nDEFAULT_GROUP\t= 1,1,1,*,*;\n/MN\n"


def _ls(*positions: str) -> dict[str, str]:
    mn = "".join(f"{k + 1:4d}:L P[{k + 1}] 100mm/sec FINE    ;\n" for k in range(len(positions)))
    return {"UP002.LS": HEADER + mn + "/POS\n" + "".join(positions) + "/END\n"}


def _position(k: int, body: str, extra_groups: str = "") -> str:
    return f"P[{k}]{{\n   GP1:\n\tUF : 0, UT : 0,\t\t{body}\n{extra_groups}}};\n"


CARTESIAN = ("CONFIG : 'N U T, 0, 0, 0',\n\tX =   400.000  mm,\tY =    -.384  mm,"
             "\tZ =   300.000  mm,\n\tW =   180.000 deg,\tP =      .881 deg,\tR =     0.000 deg")
GP2 = "   GP2:\n\tUF : 0, UT : 0,\t\n\tJ1=   200.000  mm\n"


def test_positions_with_other_groups_and_extended_axes_are_read():
    files = _ls(_position(1, CARTESIAN, GP2), _position(2, CARTESIAN + ",\n\tE1= -1290.488  mm"))
    program = read_program(files)
    assert [t.values for t in program.targets] == [(400.0, -0.384, 300.0, 180.0, 0.881, 0.0)] * 2
    nominal = builtin_model("lrmate200id")
    out, report = filter_program(program, nominal, nominal)
    assert report.compensated == 2
    assert "J1=   200.000  mm" in out["UP002.LS"] and "E1= -1290.488  mm" in out["UP002.LS"]


def test_an_untaught_position_is_refused_not_a_crash():
    untaught = ("CONFIG : 'N U T, 0, 0, 0',\n\tX = ********  mm,\tY = ********  mm,\tZ = ******** "
                " mm,\n\tW = ******** deg,\tP = ******** deg,\tR = ******** deg")
    program = read_program(_ls(_position(1, untaught), _position(2, CARTESIAN)))
    nominal = builtin_model("lrmate200id")
    _, report = filter_program(program, nominal, nominal)
    assert {n.name: n.reason for n in report.refused} == {
        "P[1]": "not taught (its values are ********)"}
    assert report.compensated == 1


def test_a_position_in_another_coordinate_form_is_refused_by_name():
    other = ("CONFIG : 'N U T, 0, 0, 0',\n\tRX =   341.681  mm,\tRY =  -170.477  mm,\tRZ =  "
             "-671.251  mm,\n\tRW =    29.745 deg,\tRP =   -14.702 deg,\tRR =    72.713 deg")
    program = read_program(_ls(_position(1, other, GP2)))
    nominal = builtin_model("lrmate200id")
    _, report = filter_program(program, nominal, nominal)
    (note,) = report.refused
    assert "found RP, RR, RW, RX, RY, RZ" in note.reason and note.line == 8


def test_krl_partial_inline_targets_and_a_global_home():
    src = ("DEF Test1( )\n;FOLD INI\nBAS (#INITMOV,0 )\n;ENDFOLD\nPTP  XHOME\n"
           "  LIN {X 0, Y 0, Z 100}\n  LIN {X 150, Y 0, Z 100, A 0, B 90, C 0}\nPTP XHOME\nEND\n")
    config = "DEFDAT $CONFIG\nDECL GLOBAL E6AXIS XHOME={A1 0.0,A2 -90.0,A3 90.0,A4 0.0,A5 0.0," \
        "A6 0.0}\nENDDAT\n"
    program = read_program({"Test1.src": src}, config=("$config.dat", config))
    assert not program.notes  # XHOME is the controller's own joint target
    nominal = builtin_model("kr16")
    _, report = filter_program(program, nominal, nominal)
    (partial,) = report.refused
    assert partial.line == 6 and "partial" in partial.reason
    without_config = read_program({"Test1.src": src})
    assert {(n.line, n.name) for n in without_config.notes} == {(5, "XHOME"), (8, "XHOME")}


PUBLIC = os.environ.get("SCREWCAL_PUBLIC_PROGRAMS")


@pytest.mark.skipif(not PUBLIC, reason="SCREWCAL_PUBLIC_PROGRAMS names no folder of fetched "
                    "public programs")
def test_every_public_program_is_read_and_filtered_without_a_crash():
    robots = {"krl": "kr16", "fanuc": "lrmate200id", "urscript": "ur5e"}
    seen = collections.Counter()
    for language, robot in robots.items():
        nominal = builtin_model(robot)
        groups = collections.defaultdict(list)
        for f in sorted(p for p in (Path(PUBLIC) / language).rglob("*") if p.is_file()):
            groups[(f.parent, f.stem.lower()) if language == "krl" else (f, "")].append(f)
        for files in groups.values():
            texts = {str(f): f.read_bytes().decode("latin-1") for f in files}
            try:
                program = read_program(texts)
            except ProgramSyntaxError:
                seen[language, "refused"] += 1  # with its file and line: not a crash
                continue
            filter_program(program, nominal, nominal, start_deg=np.zeros(6))
            seen[language, "read"] += 1
    assert all(seen[lang, "read"] for lang in robots), seen


def test_krl_typed_aggregates_and_inline_joints():
    """`$BASE = {FRAME: X ...}` and `LIN {E6POS: X ...}` name their type first; `PTP {A1 ...}`
    is a joint target (a CAM post-processor's program writes both)."""
    src = ("DEF Milling ( )\n$BASE = {FRAME: X 0.000,Y -1000.000,Z 0.000,A 0.000,B 0.000,C 0.000}"
           "\n$TOOL = {FRAME: X 166.604,Y -4.165,Z 109.636,A -0.000,B 90.000,C 0.000}\n"
           "PTP {A1 7.78457,A2 -44.95260,A3 141.64681,A4 17.66839,A5 -87.93467,A6 6.37710}\n"
           "LIN {E6POS: X 900.000,Y 1000.000,Z 606.350,A -180.000,B 0.000,C -180.000}\nEND\n")
    program = read_program({"Milling.src": src})
    assert program.joint_targets == 1 and not program.notes
    (target,) = program.targets
    assert target.values == (900.0, 1000.0, 606.35, -180.0, 0.0, -180.0)
    assert program.frames[target.frame].values == (0.0, -1000.0, 0.0, 0.0, 0.0, 0.0)
    assert program.tools[target.tool].values == (166.604, -4.165, 109.636, -0.0, 90.0, 0.0)


def test_a_german_controllers_konfig_and_tool_offset_read_as_config_and_tool_offset():
    # A controller set to German writes KONFIG and WKZ_Offset (public VW backups): the same
    # program in English compensates to the same numbers and flags, and the offset is noted
    german = {"MOTN010.LS": (
        "/PROG  MOTN010\n/ATTR\nKOMMENTAR\t= \"Schweißen\";\n/MN\n"
        "   1:J P[1] 100% CNT100 ACC100    ;\n"
        "   2:J P[2] 100% CNT100 ACC100 WKZ_Offset,PR[52]    ;\n/POS\n" +
        "".join(_position(k, CARTESIAN.replace("CONFIG : 'N U T", f"KONFIG : '{c}").replace(
            "400.000", x)) for k, c, x in ((1, "F U T", "400.000"), (2, "N U T", "380.000"))) +
        "/END\n")}
    english = {name: text.replace("KONFIG", "CONFIG").replace("WKZ_Offset", "Tool_Offset")
               for name, text in german.items()}
    nominal = builtin_model("lrmate200id")
    calibrated = replace(nominal, axis_points_mm=nominal.axis_points_mm + 0.3)
    outs, reports = [], []
    for files in (german, english):
        program = read_program(files)
        configs = [t.flags["CONFIG"].text for t in program.targets]
        assert configs == ["F U T, 0, 0, 0", "N U T, 0, 0, 0"]
        out, report = filter_program(program, calibrated, nominal)
        outs.append(out["MOTN010.LS"])
        reports.append(report)
    assert outs[0] != german["MOTN010.LS"] and reports[0].compensated == 2
    assert outs[0].replace("KONFIG", "CONFIG").replace("WKZ_Offset", "Tool_Offset") == outs[1]
    assert "KONFIG : 'F U T, 0, 0, 0'" in outs[0]
    assert [(n.line, n.name) for n in reports[0].not_static] == [(6, "WKZ_Offset")]
