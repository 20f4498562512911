"""`rapid check` against RAPID as RobotWare controllers run it: saved-module headers, the base
system's names with every optional argument and alternative, the names RobotWare options
bring (said as such), placeholders and encrypted modules (notes), a backup's tasks, and public
modules fetched from other repositories (when present: `SCREWCAL_RAPID_CORPUS`, default
/tmp/rapid_corpus, holds them one repository a folder; the test skips without them).

Each module here is written in the form real cells use (never a copy of theirs)."""

import os
from pathlib import Path

import pytest

from screwcal.commands.main import main
from screwcal.rapid.check import NOTE_KINDS, check_modules

CORPUS = Path(os.environ.get("SCREWCAL_RAPID_CORPUS", "/tmp/rapid_corpus"))


def _findings(body: str, data: str = "", options=None, header: str = ""):
    text = f"{header}MODULE M\n{data}  PROC main()\n{body}  ENDPROC\nENDMODULE\n"
    if options is None:
        return check_modules([("m.mod", text)])
    return check_modules([("m.mod", text)], options=options)


def test_base_system_forms_real_backups_use_have_no_finding():
    """The forms a RobotWare 6.13 backup holds, which the first table refused (ErrLog with
    its five arguments, WaitDI shown on the FlexPendant, the I/O aliases, speed limits, the
    UI message box, motor torques, external-axis search, the service routine)."""
    header = "\ufeff%%%\r\n  VERSION:1\r\n  LANGUAGE:ENGLISH\r\n%%%\r\n\r\n"
    data = ("  VAR signaldi diAlias;\n  VAR btnres answer;\n  VAR num torque;\n"
            "  VAR jointtarget jSearch;\n"
            "  CONST jointtarget jEnd:=[[0,0,0,0,0,0],[100,9E9,9E9,9E9,9E9,9E9]];\n")
    body = ('    ErrLog 4800, "Gripper", "not closed", "check air", "", "";\n'
            '    ErrLog 4801 \\W, "Gripper", "slow", "", "", "";\n'
            '    WaitDI di1, 1 \\MaxTime:=5 \\Visualize \\Header:="Waiting" '
            '\\MsgArray:=["part", "present"] \\Icon:=iconInfo;\n'
            '    AliasIO "diPartPresent", diAlias;\n    AliasIOReset diAlias;\n'
            '    SpeedLimAxis ROB_1, 1, 10;\n    SpeedLimCheckPoint 250;\n'
            '    answer := UIMessageBox(\\Header:="Cell" \\Message:="Continue?" '
            '\\Buttons:=btnOKCancel \\Icon:=iconWarning);\n'
            '    torque := GetMotorTorque(\\MecUnit:=ROB_1 \\Axis:=2);\n'
            '    SearchExtJ \\Stop, di1 \\PosFlank, jSearch, jEnd, v100;\n'
            '    LoadIdentify;\n'
            '    TPWrite "torque " \\Num:=torque;\n')
    assert _findings(body, data, header=header) == []


@pytest.mark.parametrize("body, kind, says", [
    ("    TPWrite \"a \", nPart, \" b\";\n", "argument",
     "TPWrite takes 1 required argument, 3 given"),  # RAPID has no variadic TPWrite
    ("    MoveL p10, v100 \\V:=120 \\T:=3, z10, tool0;\n", "argument",
     "\\V and \\T are alternatives"),
    ("    WaitDI di1, 1 \\Message:=\"x\" \\MsgArray:=[\"y\"];\n", "argument",
     "\\Message and \\MsgArray are alternatives"),
    ("    ErrLog 4800, \"Title\";\n", "argument", "ErrLog takes 6 required arguments, 2 given"),
])
def test_truly_invalid_forms_found_in_public_modules_are_findings(body, kind, says):
    """What remains on the fetched public modules, in their forms: the controller refuses
    each at load (a reference error: wrong number of arguments, or two alternatives)."""
    findings = _findings(body, "  CONST robtarget p10:=[[1,2,3],[1,0,0,0],[0,0,0,0],"
                         "[9E9,9E9,9E9,9E9,9E9,9E9]];\n  VAR num nPart;\n")
    assert [(f.kind, says in f.reason) for f in findings] == [(kind, True)], findings


def test_a_function_of_the_task_called_with_too_few_arguments_is_a_finding():
    """A socket dispatcher's form: `str := GoSnap() + "\\0D\\0A";` where GoSnap takes two
    strings: the controller refuses the module (too few arguments)."""
    text = ('MODULE Cmd\n  FUNC string GoSnap(string speed, string nozzle)\n'
            '    RETURN speed + nozzle;\n  ENDFUNC\n  PROC main()\n    VAR string s;\n'
            '    s := GoSnap() + "\\0D\\0A";\n  ENDPROC\nENDMODULE\n')
    findings = check_modules([("cmd.mod", text)])
    assert [(f.line, f.kind) for f in findings] == [(7, "argument")]
    assert "GoSnap takes 2 required arguments, 0 given" in findings[0].reason


@pytest.mark.parametrize("body, data, option, title", [
    ("    ArcLStart p10, v100, seam1, weld1, fine, tWeld \\WObj:=wobj0;\n"
     "    ArcL p20, v100, seam1, weld1 \\Weave:=weave1, z1, tWeld;\n",
     "  PERS seamdata seam1:=[0,0,[0,0,0,0,0,0,0,0,0],0,0,0,0,0,[0,0,0,0,0,0,0,0,0],0,0,"
     "[0,0,0,0,0,0,0,0,0],0,0,[0,0,0,0,0,0,0,0,0],0];\n"
     "  PERS welddata weld1:=[10,0,[0,0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0,0]];\n"
     "  PERS weavedata weave1:=[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0];\n", "arc", "RobotWare Arc"),
    ("    MotionSup \\On \\TuneValue:=150;\n", "", "collision-detection", "Collision Detection"),
    ("    WZHomeJointDef \\Inside, home, jPos, jDelta;\n",
     "  VAR shapedata home;\n  CONST jointtarget jPos:=[[0,0,0,0,0,0],[9E9,9E9,9E9,9E9,9E9,"
     "9E9]];\n  CONST jointtarget jDelta:=[[2,2,2,2,2,2],[9E9,9E9,9E9,9E9,9E9,9E9]];\n",
     "world-zones", "World Zones"),
    ("    CSSAct CSS_REFFRAME_WOBJ, CSS_Z \\Stiffness:=20 \\AllowMove;\n", "", "softmove",
     "SoftMove"),
    ("    EGMActPose egmId \\Tool:=tool0 \\WObj:=wobj0, corr, EGM_FRAME_WOBJ, sens, "
     "EGM_FRAME_WOBJ \\x:=lin \\y:=lin \\z:=lin \\rx:=rot \\ry:=rot \\rz:=rot \\LpFilter:=20 "
     "\\SampleRate:=4 \\MaxPosDeviation:=1000 \\MaxSpeedDeviation:=1000;\n",
     "  VAR egmident egmId;\n  CONST pose corr:=[[0,0,0],[1,0,0,0]];\n"
     "  CONST pose sens:=[[0,0,0],[1,0,0,0]];\n  CONST egm_minmax lin:=[-1,1];\n"
     "  CONST egm_minmax rot:=[-2,2];\n", "egm", "Externally Guided Motion"),
])
def test_a_name_an_option_brings_says_which_option(body, data, option, title):
    """Without the option (the base system alone), every such name is an `option` finding
    naming it; with `--options` naming it, none remains."""
    without = _findings(body, data, options=[])
    assert without and all(f.kind == "option" and title in f.reason for f in without), without
    assert _findings(body, data, options=[option]) == []


def test_placeholders_and_encrypted_modules_are_notes(tmp_path, capsys):
    unfinished = tmp_path / "Unfinished.mod"
    unfinished.write_text("MODULE Unfinished\n  PROC Empty()\n    <SMT>\n  ENDPROC\nENDMODULE\n")
    secret = tmp_path / "Secret.sys"
    secret.write_bytes(bytes([0xFE, 0xC0, 0x01, 0x10, 0x3E, 0x1D, 0x09, 0x84]) * 64)
    assert main(["rapid", "check", str(unfinished), str(secret)]) == 0
    out = capsys.readouterr().out
    assert f"{unfinished}:3:5: placeholder: <SMT>" in out
    assert f"{secret}:1:1: encrypted: an encrypted or binary module" in out


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_a_backup_folder_is_checked_task_by_task(tmp_path, capsys):
    """RAPID/TASKn/PROGMOD and SYSMOD of one task checked together (a routine of a system
    module is known to the program modules), each task apart (a routine of TASK1 is not
    TASK2's), HOME's files left out (they are files, not a task's modules)."""
    backup = tmp_path / "Cell_BACKUP_2025-01-01"
    _write(backup / "RAPID/TASK1/SYSMOD/user.sys", "MODULE user(SYSMODULE)\n  PROC Grip()\n"
           "  ENDPROC\nENDMODULE\n")
    _write(backup / "RAPID/TASK1/PROGMOD/Main.mod", "%%%\n  VERSION:1\n  LANGUAGE:ENGLISH\n"
           "%%%\n\nMODULE Main\n  PROC main()\n    Grip;\n  ENDPROC\nENDMODULE\n")
    bad = _write(backup / "RAPID/TASK2/PROGMOD/Other.mod", "MODULE Other\n  PROC main()\n"
                 "    Grip;\n  ENDPROC\nENDMODULE\n")
    _write(backup / "HOME/broken.mod", "not RAPID at all")
    assert main(["rapid", "check", str(backup)]) == 1
    captured = capsys.readouterr()
    assert captured.out == f"{bad}:3:5: unknown: unknown instruction 'Grip' (not in the " \
        "RobotWare tables nor a routine of the modules checked)\n"
    assert "task TASK1: 2 modules, 0 findings" in captured.err
    assert "task TASK2: 1 module, 1 finding" in captured.err
    assert main(["rapid", "check", str(backup / "RAPID" / "TASK1")]) == 0


def test_a_name_only_an_encrypted_module_may_define_is_a_note(tmp_path, capsys):
    """A task with an encrypted library: a routine none of the readable modules defines may be
    the library's: `unverified`, a note naming the encrypted module, not an error."""
    task = tmp_path / "RAPID" / "TASK1" / "PROGMOD"
    _write(task / "Main.mod", "MODULE Main\n  PROC main()\n    r_Lib_Init;\n  ENDPROC\n"
           "ENDMODULE\n")
    (task / "Lib.mod").write_bytes(bytes([0xFE, 0xC0, 0x01, 0x10, 0x3E, 0x1D, 0x09]) * 80)
    assert main(["rapid", "check", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Main.mod:3:5: unverified: unknown instruction 'r_Lib_Init'" in out
    assert "perhaps of the encrypted Lib.mod" in out


def test_a_program_folder_knows_the_system_modules_beside_it(tmp_path, capsys):
    """A controller's HOME without TASKn folders: a program folder calling a routine of a
    system module in another folder (HOME/__MODULI__/UTILITY.sys), as the controller loads
    both; a routine none defines is still unknown."""
    home = tmp_path / "HOME"
    _write(home / "__MODULI__" / "UTILITY.sys", "MODULE UTILITY(SYSMODULE)\n"
           "  PROC USR_Print(string s)\n    TPWrite s;\n  ENDPROC\nENDMODULE\n")
    prog = _write(home / "cell" / "FOUNDRY.mod", "MODULE FOUNDRY\n  PROC main()\n"
                  "    USR_Print \"start\";\n    USR_Nowhere;\n  ENDPROC\nENDMODULE\n")
    assert main(["rapid", "check", str(home)]) == 1
    assert capsys.readouterr().out == f"{prog}:4:5: unknown: unknown instruction " \
        "'USR_Nowhere' (not in the RobotWare tables nor a routine of the modules checked)\n"


def test_an_unknown_option_is_refused_by_name(capsys):
    assert main(["rapid", "check", "x.mod", "--options", "arc,laser"]) == 2
    assert "unknown RobotWare option 'laser'" in capsys.readouterr().err


# What remains on the public modules fetched (14 repositories, 221 modules: controller backups
# of RobotWare 5 and 6 with headers and encrypted libraries, socket servers, a welding cell,
# palletising and foundry cells, the ROS-Industrial driver, open_abb, a motion-program
# executor), each argued above as truly invalid RAPID: (repository, file, line, what).
_EXPECTED = {
    ("Keen1949+ABB_ROBOT_Socket", "Socket_Commands.mod", 34, "Assemble takes 6"),
    ("Keen1949+ABB_ROBOT_Socket", "Socket_Commands.mod", 39, "GoSnap takes 2"),
    ("Keen1949+ABB_ROBOT_Socket", "Socket_Commands.mod", 47, "CaliCam takes 3"),
    ("Keen1949+ABB_ROBOT_Socket", "Socket_Commands.mod", 49, "TranCam takes 2"),
    ("ravenorb+abb-robot-welder", "MainModule.mod", 12, "TPWrite takes 1"),
}
_CELL_OPTIONS = "socket-messaging,pc-interface,multitasking,multimove,collision-detection," \
    "world-zones,arc,egm,sensor-interface,bullseye,production-manager,safemove"


@pytest.mark.skipif(not CORPUS.is_dir(), reason=f"no fetched public modules in {CORPUS}")
def test_public_modules_fetched_have_no_false_finding(capsys):
    repos = sorted(p for p in CORPUS.iterdir() if p.is_dir())
    main(["rapid", "check", *map(str, repos), "--options", _CELL_OPTIONS])
    found = set()
    for line in capsys.readouterr().out.splitlines():
        path, line_no, _, kind, reason = line.split(":", 4)
        if kind.strip() in NOTE_KINDS:
            continue
        repo = Path(path).relative_to(CORPUS).parts[0]
        what = " ".join(reason.split()[:3])
        if Path(path).parent.name != "sample":  # the welding cell's copy of its own program
            found.add((repo, Path(path).name, int(line_no), what))
    assert found <= _EXPECTED, found - _EXPECTED


def test_options_added_to_a_calibration_cells(tmp_path, capsys):
    module = _write(tmp_path / "weld.mod", "MODULE Weld\n  PROC main()\n    MotionSup \\On;\n"
                    "    ArcKill;\n  ENDPROC\nENDMODULE\n")
    assert main(["rapid", "check", str(module), "--options", "+arc"]) == 0
    assert main(["rapid", "check", str(module), "--options", "arc"]) == 1  # no collision
    assert "Collision Detection (613-1)" in capsys.readouterr().out      # detection then


def test_the_tables_are_well_formed():
    """Every row of the base and option tables reads as a signature; no base name is also an
    option's (an option's table would never be consulted for it); every option named in the
    default exists; alternatives are among the options they group."""
    from screwcal.rapid.names import (
        BASE_FUNCTIONS,
        BASE_INSTRUCTIONS,
        BASE_TYPES,
        CALIBRATION_CELL,
        OPTIONS,
        _table,
        option_keys,
    )

    assert set(CALIBRATION_CELL) <= set(option_keys())
    base = set(BASE_INSTRUCTIONS) | set(BASE_FUNCTIONS) | BASE_TYPES
    for option in OPTIONS:
        rows = {**_table(option.instructions or "x 0"), **_table(option.functions or "x 0")}
        rows.pop("x", None)
        overlap = (set(rows) | set(option.types.split())) & base
        assert not overlap, (option.key, overlap)
        for sig in rows.values():
            assert all(group <= (sig.options or group) for group in sig.alternatives)
    for sig in [*BASE_INSTRUCTIONS.values(), *BASE_FUNCTIONS.values()]:
        assert sig.min_positional is None or sig.min_positional <= (sig.max_positional or 0)
        assert all(group <= (sig.options or group) for group in sig.alternatives)
