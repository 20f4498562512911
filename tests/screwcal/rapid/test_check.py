"""`screwcal rapid check`: no finding on the shipped module nor on RAPID in the forms public ABB
code uses; each class of error named with file:line:col and a one-line reason."""

import subprocess
import sys
from pathlib import Path

import pytest

from protocol.rapid import module_text
from screwcal.commands.main import main
from screwcal.rapid.check import check_modules

DATA = Path(__file__).parent / "data"
GOOD = sorted(DATA.glob("*.mod")) + sorted(DATA.glob("*.sys"))


def _check(body: str, data: str = "", path: str = "m.mod"):
    text = f"MODULE M\n{data}  PROC main()\n{body}  ENDPROC\nENDMODULE\n"
    return check_modules([(path, text)])


def test_the_shipped_module_and_the_public_forms_have_no_finding():
    sources = [("ScrewcalServer.mod", module_text())]
    sources += [(str(p), p.read_text()) for p in GOOD]
    assert check_modules(sources) == []


def test_routines_of_another_module_of_the_task_are_known():
    caller = ("a.mod", "MODULE A\n  PROC main()\n    CountPart;\n  ENDPROC\nENDMODULE\n")
    assert [f.kind for f in check_modules([caller])] == ["unknown"]
    assert check_modules([caller, (str(DATA / "common.sys"),
                                   (DATA / "common.sys").read_text())]) == []
    assert check_modules([caller], known=["countpart"]) == []


@pytest.mark.parametrize("body, data, kind, line, col, says", [
    ("    MoveL p10 v100, z10, tool0;\n", "", "syntax", 3, 15, "expected ',' or ';'"),
    ("    MoveQ p10, v100, z10, tool0;\n", "", "unknown", 3, 5, "unknown instruction 'MoveQ'"),
    ("    x := Sqr(2);\n", "  VAR num x;\n", "unknown", 4, 10, "unknown function 'Sqr'"),
    ("    MoveL p10, v100, tool0;\n", "", "argument", 3, 5, "MoveL takes 4 required arguments, "
     "3 given"),
    ("    MoveL p10, v100, z10, tool0 \\Wobj:=w \\Speed:=1;\n", "", "argument", 3, 42,
     "MoveL has no optional argument \\Speed"),
    ("    x := NumToStr(1);\n", "  VAR string x;\n", "argument", 4, 10, "NumToStr takes 2"),
    ("    x := \"ten\";\n", "  VAR num x;\n", "type", 4, 10, "x is num, the value assigned is "
     "string"),
    ("", "  CONST bool B := 1;\n", "type", 2, 19, "B is bool, its value is num"),
    ("    IF 1 THEN\n    ENDIF\n", "", "type", 3, 8, "a condition must be bool, this is num"),
    ("    TPWrite \"n=\" + 5;\n", "", "type", 3, 13, "'+' joins string with string"),
    ("    TPWrite \"" + "x" * 81 + "\";\n", "", "string", 3, 13,
     "a string of 81 characters: RAPID strings hold at most 80"),
])
def test_each_error_class_is_named_with_its_place(body, data, kind, line, col, says):
    findings = _check(body, data)
    assert [f.kind for f in findings] == [kind], findings
    f = findings[0]
    assert (f.line, f.col) == (line, col) and says in f.reason, str(f)
    assert str(f) == f"m.mod:{line}:{col}: {kind}: {f.reason}"


def test_arguments_and_types_of_the_modules_own_routines():
    text = ("MODULE M\n  PROC Go(num n, \\switch Fast)\n  ENDPROC\n  PROC main()\n"
            "    Go 1, 2;\n    Go \"one\";\n    Go 1 \\Slow;\n    Go 1 \\Fast;\n"
            "  ENDPROC\nENDMODULE\n")
    findings = check_modules([("m.mod", text)])
    assert [(f.line, f.kind) for f in findings] == [(5, "argument"), (6, "type"),
                                                   (7, "argument")]


def test_the_command_exits_0_only_when_clean(tmp_path, capsys):
    good = [str(p) for p in GOOD]
    assert main(["rapid", "check", *good]) == 0
    bad = tmp_path / "bad.mod"
    bad.write_text("MODULE Bad\n  PROC main()\n    MoveL p10, v100, tool0;\n  ENDPROC\nENDMODULE\n")
    assert main(["rapid", "check", *good, str(bad)]) == 1
    out = capsys.readouterr()
    assert out.out == f"{bad}:3:5: argument: MoveL takes 4 required arguments, 3 given\n"
    assert "1 finding in 1" in out.err
    assert main(["rapid", "check", str(tmp_path / "missing.mod")]) == 2


def test_the_console_script_checks_a_system_module():
    done = subprocess.run([sys.executable, "-m", "screwcal", "rapid", "check",
                           str(DATA / "common.sys")], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
