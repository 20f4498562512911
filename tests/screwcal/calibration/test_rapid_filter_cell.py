"""`compensate --rapid` on a cell's program, never silent: robtargets in RECORD data, arrays of
records and nested records, moved to by SearchL, ArcLStart, ArcL, MoveC (both points) and
TriggL, each with its own tool and work object; the true robot reaches every original target
(the golden round trip of test_rapid_filter: the nominal controller solves the compensated
target with its confdata, the true robot moves there), or the target is listed and the exit
status says so. The controller's saved-module header is kept byte for byte."""

import subprocess
import sys
import warnings

import numpy as np

from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.rapid_filter import FilterReport, _frame, _static_targets, filter_rapid
from screwcal.calibration.rapid_source import read_rapid_module
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.confdata import confdata, solution_for_confdata
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import invert_transform, quaternion_wxyz_from_rotation

HEADER = "%%%\r\n  VERSION:1\r\n  LANGUAGE:ENGLISH\r\n%%%\r\n\r\n"
TOOLS = {"tGun": "[TRUE,[[10,-5,180],[0.991444861,0,0.130526192,0]],[2,[0,0,80],[1,0,0,0],0,0,0]]",
         "tProbe": "[TRUE,[[0,30,120],[1,0,0,0]],[1,[0,0,50],[1,0,0,0],0,0,0]]"}
WOBJS = {"wTable": '[FALSE,TRUE,"",[[700,-100,400],[1,0,0,0]],[[0,0,0],[1,0,0,0]]]',
         "wFixture": '[FALSE,TRUE,"",[[600,200,300],[0.965925826,0,0,0.258819045]],'
                     '[[10,0,5],[1,0,0,0]]]'}
# target name (as the filter labels it) -> (tool, work object) of the instruction using it
USES = {"wpSearch.p": ("tProbe", "wTable"), "weld{1}.p": ("tGun", "wFixture"),
        "weld{2}.p": ("tGun", "wFixture"), "s1.start.p": ("tGun", "wTable"),
        "s1.finish": ("tGun", "wTable"), "pCir": ("tGun", "wTable"),
        "pTo": ("tGun", "wTable"), "pTrigg": ("tProbe", "wFixture")}


def _frame_of(value: str) -> np.ndarray:
    """The frame of a tooldata's tframe or a wobjdata's uframe @ oframe, from its text."""
    numbers = [float(v) for v in value.replace("[", ",").replace("]", ",").split(",")
               if v.strip() and v.strip() not in ("TRUE", "FALSE", '""')]
    if len(numbers) == 14:  # wobjdata: uframe, oframe
        u, o = numbers[:7], numbers[7:14]
        return _pose(u) @ _pose(o)
    return _pose(numbers[:7])


def _pose(n) -> np.ndarray:
    from screwcal.kinematics.pose import rotation_from_quaternion_wxyz

    T = np.eye(4)
    T[:3, :3] = rotation_from_quaternion_wxyz(np.array(n[3:7]))
    T[:3, 3] = n[:3]
    return T


def _cell(rng) -> tuple[str, dict[str, np.ndarray]]:
    """The cell's module (targets of reachable random configurations, each in its tool and
    work object) and the flange pose each target asks for."""
    nominal = irb1600()
    q = random_configurations(len(USES), rng)
    flange = flange_kinematics(nominal, q)
    conf = confdata(nominal, q)
    text, wanted = {}, {}
    for k, (name, (tool, wobj)) in enumerate(USES.items()):
        T = invert_transform(_frame_of(WOBJS[wobj])) @ flange[k] @ _frame_of(TOOLS[tool])
        quat = quaternion_wxyz_from_rotation(T[:3, :3])
        text[name] = (f"[[{T[0, 3]:.4f},{T[1, 3]:.4f},{T[2, 3]:.4f}],[{quat[0]:.9f},"
                      f"{quat[1]:.9f},{quat[2]:.9f},{quat[3]:.9f}],[{conf[k, 0]},{conf[k, 1]},"
                      f"{conf[k, 2]},{conf[k, 3]}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]")
        wanted[name] = flange[k]
    module = (
        f"{HEADER}MODULE Cell\r\n"
        "  RECORD waypoint\r\n    robtarget p;\r\n    num speed;\r\n  ENDRECORD\r\n"
        "  RECORD seam\r\n    waypoint start;\r\n    robtarget finish;\r\n  ENDRECORD\r\n"
        + "".join(f"  PERS tooldata {n}:={v};\r\n" for n, v in TOOLS.items())
        + "".join(f"  TASK PERS wobjdata {n}:={v};\r\n" for n, v in WOBJS.items())
        + f"  PERS waypoint wpSearch:=[{text['wpSearch.p']},100];\r\n"
        f"  PERS waypoint weld{{2}}:=[[{text['weld{1}.p']},50],\r\n"
        f"    [{text['weld{2}.p']},50]];\r\n"
        f"  CONST seam s1:=[[{text['s1.start.p']},20],{text['s1.finish']}];\r\n"
        + "".join(f"  CONST robtarget {n}:={text[n]};\r\n" for n in ("pCir", "pTo", "pTrigg"))
        + "  VAR robtarget pFound;\r\n  VAR triggdata trigg1;\r\n"
        "  PROC main()\r\n"
        "    SearchL \\Stop, diProbe \\PosFlank, pFound, wpSearch.p, v100, tProbe "
        "\\WObj:=wTable;\r\n"
        "    ArcLStart weld{1}.p, v100, seam1, weld1, fine, tGun \\WObj:=wFixture;\r\n"
        "    ArcL weld{2}.p, v100, seam1, weld1 \\Weave:=weave1, z1, tGun \\WObj:=wFixture;\r\n"
        "    ArcLEnd s1.start.p, v100, seam1, weld1, fine, tGun \\WObj:=wTable;\r\n"
        "    MoveL s1.finish, v100, fine, tGun \\WObj:=wTable;\r\n"
        "    MoveC pCir, pTo, v100, z10, tGun \\WObj:=wTable;\r\n"
        "    TriggL pTrigg, v100, trigg1, z10, tProbe \\WObj:=wFixture;\r\n"
        "  ENDPROC\r\nENDMODULE\r\n")
    return module, wanted


def _without_search(text: str) -> str:
    """The cell with its SearchL (whose result, pFound, the program writes) a MoveL."""
    return text.replace("  VAR robtarget pFound;\r\n", "").replace(
        "SearchL \\Stop, diProbe \\PosFlank, pFound, wpSearch.p, v100,", "MoveL wpSearch.p, v100, "
        "fine,")


def _reached(text: str, truth, nominal) -> dict[str, float]:
    """Position error (mm) of the true robot at each target of `text`, solved by the nominal
    controller in the target's own tool and work object."""
    module = read_rapid_module("cell.mod", text)
    scratch = FilterReport("cell.mod")
    out = {}
    for d in module.declarations:
        for t in _static_targets(module, d, scratch):
            tool, wobj = USES[t.name]
            T = _frame(t.tokens[:3], t.tokens[3:7])
            flange = _frame_of(WOBJS[wobj]) @ T @ invert_transform(_frame_of(TOOLS[tool]))
            conf = np.array([[int(tok.text) for tok in t.tokens[7:11]]])
            q, found = solution_for_confdata(nominal, flange[None], conf)
            assert found.all(), t.name
            out[t.name] = flange_kinematics(truth, q)[0]
    return out


def test_every_target_of_a_cell_reaches_its_original_in_its_own_tool_and_work_object(rng):
    nominal, truth = irb1600(), apply_virtual_joints(irb1600(), THESIS_TABLE11)
    text, wanted = _cell(rng)
    out, report = filter_rapid(read_rapid_module("cell.mod", text), truth, nominal)
    listed = {n.name for n in report.refused}
    assert listed == {"pFound"}  # the search's result: declared without a value
    assert report.compensated == len(USES)
    assert out.startswith(HEADER)  # the header byte for byte
    reached = _reached(out, truth, nominal)
    assert set(reached) == set(USES)
    errors = {n: float(np.linalg.norm(reached[n][:3, 3] - wanted[n][:3, 3])) for n in USES}
    assert max(errors.values()) < 0.02, errors
    before = _reached(text, truth, nominal)
    assert min(float(np.linalg.norm(before[n][:3, 3] - wanted[n][:3, 3])) for n in USES) > 1


def test_a_target_in_the_wrong_frame_would_miss(rng):
    """The check has teeth: the same targets solved as if each were moved with tool0 and
    wobj0 (what the filter did for SearchL and ArcLStart) miss by far more than 0.02 mm."""
    nominal, truth = irb1600(), apply_virtual_joints(irb1600(), THESIS_TABLE11)
    text, wanted = _cell(rng)
    plain = text.replace("\\WObj:=wFixture", "").replace("\\WObj:=wTable", "")
    for tool in TOOLS:
        plain = plain.replace(f", {tool} ", ", tool0 ").replace(f", {tool};", ", tool0;")
    out, _ = filter_rapid(read_rapid_module("cell.mod", plain), truth, nominal)
    reached = _reached(out, truth, nominal)
    worst = max(float(np.linalg.norm(reached[n][:3, 3] - wanted[n][:3, 3])) for n in USES)
    assert worst > 0.1


def test_the_command_lists_what_it_did_not_compensate_and_exits_3(tmp_path, rng):
    """Inline targets of SearchL and ArcL and a [0,0,0,0] placeholder are listed with their
    lines; the exit status is 3 (not every target compensated), 0 once none is left; no
    numpy warning escapes."""
    model = tmp_path / "model.json"
    save_model(apply_virtual_joints(irb1600(), THESIS_TABLE11), model)
    text, _ = _cell(rng)
    inline = "[[900,0,900],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
    unset = text.replace("  VAR robtarget pFound;\r\n", "  CONST robtarget pUnset:=[[0,0,0],"
                         "[0,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
                         "  VAR robtarget pFound;\r\n")
    unset = unset.replace("  ENDPROC", f"    ArcL {inline}, v100, seam1, weld1, z1, tGun;\r\n"
                          "  ENDPROC")
    src = tmp_path / "cell.mod"
    src.write_bytes(unset.encode("latin-1"))
    out = tmp_path / "out.mod"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-m", "screwcal",
                              "compensate", "--result", str(model), "--robot", "irb1600",
                              "--rapid", str(src), "--out", str(out)],
                             capture_output=True, text=True)
    assert run.returncode == 3, run.stderr
    assert "RuntimeWarning" not in run.stderr
    assert "pUnset: its orientation is [0,0,0,0], a placeholder" in run.stdout
    assert f"{len(USES)} robtargets compensated" in run.stdout
    arc_line = unset.split("\r\n").index(f"    ArcL {inline}, v100, seam1, weld1, z1, tGun;") + 1
    assert f":{arc_line}: [[900,0,900]" in run.stdout  # the inline target, listed
    assert out.read_bytes().startswith(HEADER.encode())
    # every target declared with a value and moved to statically: exit 0
    clean = tmp_path / "clean.mod"
    clean.write_bytes(_without_search(text).encode("latin-1"))
    done = subprocess.run([sys.executable, "-m", "screwcal", "compensate", "--result",
                           str(model), "--robot", "irb1600", "--rapid", str(clean), "--out",
                           str(tmp_path / "clean_out.mod")], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def _targets_by_name(text: str, path: str = "m.mod") -> dict[str, list[str]]:
    module = read_rapid_module(path, text)
    scratch = FilterReport(path)
    return {t.name: [tok.text for tok in t.tokens] for d in module.declarations
            for t in _static_targets(module, d, scratch)}


def test_a_target_moved_to_through_a_routine_takes_that_routines_tool_and_work_object(rng):
    """`PROC Approach(robtarget p, PERS tooldata t)` moving to `p` with `t` and wTable: each
    call moves to its argument in the tool it passes and the routine's work object, as if the
    call were that MoveL; the MoveL on the parameter itself is not an undeclared target."""
    nominal, truth = irb1600(), apply_virtual_joints(irb1600(), THESIS_TABLE11)
    text, _ = _cell(rng)
    direct = text.replace("    MoveC pCir, pTo, v100, z10, tGun \\WObj:=wTable;\r\n",
                          "    MoveL pCir, v100, z10, tGun \\WObj:=wTable;\r\n"
                          "    MoveL pTo, v100, z10, tGun \\WObj:=wTable;\r\n")
    routed = text.replace("    MoveC pCir, pTo, v100, z10, tGun \\WObj:=wTable;\r\n",
                          "    Approach pCir, tGun;\r\n    Approach pTo, tGun;\r\n").replace(
        "  ENDPROC\r\nENDMODULE", "  ENDPROC\r\n  PROC Approach(robtarget p, PERS tooldata t)\r\n"
        "    MoveL p, v200, z10, t \\WObj:=wTable;\r\n  ENDPROC\r\nENDMODULE")
    out_direct, _ = filter_rapid(read_rapid_module("d.mod", direct), truth, nominal)
    out_routed, report = filter_rapid(read_rapid_module("r.mod", routed), truth, nominal)
    assert report.not_static == [] and {n.name for n in report.refused} == {"pFound"}
    assert _targets_by_name(out_routed) == _targets_by_name(out_direct)
    plain = routed.replace("Approach pCir, tGun", "Approach pCir, tool0")
    assert _targets_by_name(filter_rapid(read_rapid_module("p.mod", plain), truth,
                                         nominal)[0])["pCir"] != _targets_by_name(out_direct)[
        "pCir"]  # the tool passed counts


def test_the_modules_of_a_task_are_compensated_together(tmp_path, rng):
    """Tools and work objects in a system module, targets in one program module, motions in
    another (a backup's TASK1 folder): compensated as one module holding them all; --out a
    folder receives each module under its own name; exit 0."""
    nominal, truth = irb1600(), apply_virtual_joints(irb1600(), THESIS_TABLE11)
    text, _ = _cell(rng)
    lines = text.split("\r\n")
    frames = [x for x in lines if "tooldata" in x or "wobjdata" in x]
    head, body = text.split("  PROC main()")
    data = head.split("MODULE Cell\r\n")[1]
    data = "\r\n".join(x for x in data.split("\r\n") if x not in frames)
    task = tmp_path / "BACKUP" / "RAPID" / "TASK1"
    (task / "SYSMOD").mkdir(parents=True)
    (task / "PROGMOD").mkdir()
    (task / "SYSMOD" / "CellData.sys").write_bytes(
        ("MODULE CellData(SYSMODULE)\r\n" + "\r\n".join(frames) + "\r\nENDMODULE\r\n").encode())
    (task / "PROGMOD" / "Targets.mod").write_bytes(
        (HEADER + "MODULE Targets\r\n" + data + "ENDMODULE\r\n").encode())
    (task / "PROGMOD" / "Main.mod").write_bytes(
        ("MODULE Main\r\n  VAR triggdata trigg1;\r\n  PROC main()" + body).replace(
            "  VAR triggdata trigg1;\r\n  VAR triggdata trigg1;", "").encode())
    model = tmp_path / "model.json"
    save_model(apply_virtual_joints(irb1600(), THESIS_TABLE11), model)
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "screwcal", "compensate", "--result",
                          str(model), "--robot", "irb1600", "--rapid", str(task), "--out",
                          str(out)], capture_output=True, text=True)
    assert run.returncode == 3, run.stdout + run.stderr  # pFound: declared without a value
    assert f"{len(USES)} robtargets compensated" in run.stdout
    assert sorted(p.name for p in out.iterdir()) == ["CellData.sys", "Main.mod", "Targets.mod"]
    together, _ = filter_rapid(read_rapid_module("cell.mod", text), truth, nominal)
    assert _targets_by_name((out / "Targets.mod").read_text(), "t.mod") == \
        _targets_by_name(together)


def test_a_target_moved_to_only_through_offs_takes_that_motions_frames(rng):
    """`MoveL Offs(pTo, 0, 0, 20), ..., tGun \\WObj:=wTable` alone: pTo is compensated in
    tGun and wTable (the offset itself listed as run-time), not in tool0 and wobj0."""
    nominal, truth = irb1600(), apply_virtual_joints(irb1600(), THESIS_TABLE11)
    text, _ = _cell(rng)
    direct = text.replace("    MoveC pCir, pTo, v100, z10, tGun \\WObj:=wTable;\r\n",
                          "    MoveL pCir, v100, z10, tGun \\WObj:=wTable;\r\n"
                          "    MoveL pTo, v100, z10, tGun \\WObj:=wTable;\r\n")
    offset = direct.replace("    MoveL pTo, v100, z10, tGun \\WObj:=wTable;\r\n",
                            "    MoveL Offs(pTo, 0, 0, 20), v100, z10, tGun \\WObj:=wTable;\r\n")
    out_direct, _ = filter_rapid(read_rapid_module("d.mod", direct), truth, nominal)
    out_offset, report = filter_rapid(read_rapid_module("o.mod", offset), truth, nominal)
    assert _targets_by_name(out_offset)["pTo"] == _targets_by_name(out_direct)["pTo"]
    assert any(n.name == "Offs" for n in report.not_static)


def test_an_encrypted_module_of_the_task_is_written_as_it_is_and_listed(tmp_path, rng):
    """A backup's task holding an encrypted library beside the program: the program's targets
    are compensated, the library is copied byte for byte and listed; exit 3."""
    model = tmp_path / "model.json"
    save_model(apply_virtual_joints(irb1600(), THESIS_TABLE11), model)
    text, _ = _cell(rng)
    task = tmp_path / "RAPID" / "TASK1" / "PROGMOD"
    task.mkdir(parents=True)
    (task / "Cell.mod").write_bytes(_without_search(text).encode("latin-1"))
    secret = bytes([0xFE, 0xC0, 0x01, 0x10, 0x3E, 0x1D, 0x09, 0x84]) * 64
    (task / "Lib.mod").write_bytes(secret)
    out = tmp_path / "out"
    run = subprocess.run([sys.executable, "-m", "screwcal", "compensate", "--result",
                          str(model), "--robot", "irb1600", "--rapid", str(task.parent),
                          "--out", str(out)], capture_output=True, text=True)
    assert run.returncode == 3, run.stdout + run.stderr
    assert f"{len(USES)} robtargets compensated" in run.stdout
    assert "Lib.mod:1: the module: an encrypted or binary module" in run.stdout
    assert (out / "Lib.mod").read_bytes() == secret


def test_a_tool_or_work_object_with_a_zero_quaternion_is_a_named_placeholder():
    """No numpy warning: the targets moved with them are refused, saying why."""
    text = ("MODULE m\n  PERS tooldata tNew:=[TRUE,[[0,0,100],[0,0,0,0]],[1,[0,0,1],[1,0,0,0],"
            "0,0,0]];\n  PERS wobjdata wNew:=[FALSE,TRUE,\"\",[[0,0,0],[0,0,0,0]],[[0,0,0],"
            "[1,0,0,0]]];\n"
            "  CONST robtarget p1:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  CONST robtarget p2:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  PROC main()\n    MoveL p1, v100, z10, tNew;\n"
            "    MoveL p2, v100, z10, tool0 \\WObj:=wNew;\n  ENDPROC\nENDMODULE\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, report = filter_rapid(read_rapid_module("m.mod", text),
                                 apply_virtual_joints(irb1600(), THESIS_TABLE11), irb1600())
    reasons = {n.name: n.reason for n in report.refused}
    assert reasons == {"p1": "tool tnew: its orientation is [0,0,0,0], a placeholder: never "
                       "defined", "p2": "work object wnew: its orientation is [0,0,0,0], a "
                       "placeholder: never defined"}


def test_a_routine_moving_to_an_offset_of_its_parameter_counts_for_the_argument(rng):
    """`PROC Above(robtarget p) MoveL Offs(p, 0, 0, 20), ..., tGun \\WObj:=wTable;` called as
    `Above pTo;`: pTo is compensated in tGun and wTable, as a direct MoveL would."""
    nominal, truth = irb1600(), apply_virtual_joints(irb1600(), THESIS_TABLE11)
    text, _ = _cell(rng)
    direct = text.replace("    MoveC pCir, pTo, v100, z10, tGun \\WObj:=wTable;\r\n",
                          "    MoveL pCir, v100, z10, tGun \\WObj:=wTable;\r\n"
                          "    MoveL pTo, v100, z10, tGun \\WObj:=wTable;\r\n")
    routed = direct.replace("    MoveL pTo, v100, z10, tGun \\WObj:=wTable;\r\n",
                            "    Above pTo;\r\n").replace(
        "  ENDPROC\r\nENDMODULE", "  ENDPROC\r\n  PROC Above(robtarget p)\r\n"
        "    MoveL Offs(p, 0, 0, 20), v200, z10, tGun \\WObj:=wTable;\r\n  ENDPROC\r\nENDMODULE")
    out_direct, _ = filter_rapid(read_rapid_module("d.mod", direct), truth, nominal)
    out_routed, _ = filter_rapid(read_rapid_module("r.mod", routed), truth, nominal)
    assert _targets_by_name(out_routed)["pTo"] == _targets_by_name(out_direct)["pTo"]


def test_a_target_nothing_moves_to_is_said_to_be_compensated_in_the_default_frames():
    text = ("MODULE m\n  CONST robtarget pSpare:=[[900,0,900],[0,0,1,0],[0,0,0,0],"
            "[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")
    _, report = filter_rapid(read_rapid_module("m.mod", text),
                             apply_virtual_joints(irb1600(), THESIS_TABLE11), irb1600())
    assert report.compensated == 1 and [(n.line, n.name) for n in report.unmoved] == \
        [(2, "pSpare")]
    assert "1 moved to by no instruction (compensated in the --tool and --wobj given):\n" \
        "    m.mod:2: pSpare: tool0 and wobj0" in report.summary()


def test_a_target_the_program_writes_is_listed_not_compensated(rng):
    """A declared robtarget the program assigns (`p := ...`, `p.trans.z := ...`) or a search
    writes its result into: its declared value is not what the robot moves to."""
    text = ("MODULE m\n"
            "  PERS robtarget pLast:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  PERS robtarget pHigh:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  PERS robtarget pSeen:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  CONST robtarget pTo:=[[900,50,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
            "  PROC main()\n    pLast := CRobT();\n    IF TRUE THEN\n      pHigh.trans.z := 1000;\n"
            "    ENDIF\n    SearchL \\Stop, di1, pSeen, pTo, v100, tool0;\n"
            "    MoveL pLast, v100, fine, tool0;\n    MoveL pHigh, v100, fine, tool0;\n"
            "  ENDPROC\nENDMODULE\n")
    _, report = filter_rapid(read_rapid_module("m.mod", text),
                             apply_virtual_joints(irb1600(), THESIS_TABLE11), irb1600())
    refused = {n.name: n.reason for n in report.refused}
    assert set(refused) == {"pLast", "pHigh", "pSeen"}
    assert refused["pLast"].startswith("assigned when the program runs (line 7)")
    assert refused["pHigh"].startswith("assigned when the program runs (line 9)")
    assert refused["pSeen"].startswith("SearchL's result when the program runs (line 11)")
    assert report.compensated == 1  # pTo
