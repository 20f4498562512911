"""Loading a module once per text (every emulated cell runs the same tree), and the call paths
made once per call node and routine: what a controller refuses is refused every time, and the
argument passing and StrFind keep their definitions."""

from __future__ import annotations

import random
import string

import pytest

from protocol.rapid import MODULE_NAME, module_text
from simulators.rapid.errors import LoadError
from simulators.rapid.interpreter import Task, loaded_module
from simulators.rapid.strings import _strfind


def test_tasks_of_one_module_share_its_tree():
    text = module_text()
    first, second = Task(text, MODULE_NAME), Task(text, MODULE_NAME)
    assert first.module is second.module is loaded_module(text, MODULE_NAME)
    assert first.data is not second.data  # each cell its own data


def test_a_refused_module_is_refused_every_time():
    bad = "MODULE T\nPROC main()\nSetDO do1, 1;\nENDPROC\nENDMODULE\n"
    for _ in range(2):
        with pytest.raises(LoadError, match=r"T.mod:3: instruction SetDO"):
            Task(bad, "T.mod")
    with pytest.raises(LoadError, match=r"no data named nope to set"):  # after a clean load
        Task(module_text(), MODULE_NAME, overrides={"NOPE": 1.0})


def test_arguments_by_value_by_reference_and_switches_on_every_call():
    task = Task("MODULE T\nVAR num x := 1;\nVAR num y := 0;\nVAR num n := 0;\n"
                "PROC main()\nFOR i FROM 1 TO 3 DO\nAdd x, i \\Extra:=i;\n"
                "Add x, i \\Extra:=y;\ny := y + Twice(x);\nENDFOR\nENDPROC\n"
                "PROC Add(INOUT num a, num b, \\num Extra)\nb := b * 10;\n"
                "Extra := Extra * 2;\na := a + b + Extra;\nIncr n;\nENDPROC\n"
                "FUNC num Twice(num v)\nv := 2 * v;\nRETURN v;\nENDFUNC\nENDMODULE\n",
                "T.mod")
    task.run()
    assert "main returned" in task.stop_reason, task.stop_reason
    x, y = 1.0, 0.0
    for i in (1, 2, 3):  # b and Extra by value: the caller's i and y unchanged
        x += 10 * i + 2 * i
        x += 10 * i + 2 * y
        y += 2 * x
    assert (task.data["x"].value, task.data["y"].value, task.data["n"].value) == (x, y, 6.0)


def test_strfind_is_the_first_position_in_or_not_in_the_set():
    def definition(s: str, start: int, chars: str, outside: bool) -> float:
        for k in range(start - 1, len(s)):
            if (s[k] in chars) != outside:
                return float(k + 1)
        return float(len(s) + 1)

    rng = random.Random(7)
    alphabet = string.printable + "]^-\\[\x7f"
    for _ in range(3000):
        s = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 20)))
        chars = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 6)))
        start = rng.randint(1, len(s) + 1)
        for outside in (False, True):
            got = _strfind(None, [s, float(start), chars], {"notinset": True} if outside else {})
            assert got == definition(s, start, chars, outside), (s, start, chars, outside)


def test_a_local_record_starts_at_its_default_on_every_call():
    task = Task("MODULE T\nVAR num seen{3};\nPROC main()\nFOR i FROM 1 TO 3 DO\nBump i;\n"
                "ENDFOR\nENDPROC\nPROC Bump(num i)\nVAR jointtarget jt;\n"
                "seen{i} := jt.robax.rax_2 + jt.extax.eax_a;\njt.robax.rax_2 := 7;\n"
                "jt.extax.eax_a := 9;\nENDPROC\nENDMODULE\n", "T.mod")
    task.run()
    assert [v for v in task.data["seen"].value.items] == [0.0, 0.0, 0.0], task.stop_reason


def test_an_overflowing_literal_fails_after_the_operands_before_it():
    task = Task("MODULE T\nVAR num calls := 0;\nVAR num x;\nPROC main()\n"
                "x := Count() + 1E40;\nENDPROC\nFUNC num Count()\nIncr calls;\nRETURN 1;\n"
                "ENDFUNC\nENDMODULE\n", "T.mod")
    task.run()
    assert "ERR_NUMOVERFLOW" in task.stop_reason and "T.mod:5" in task.stop_reason
    assert task.data["calls"].value == 1.0  # Count ran first, as RAPID evaluates


def test_euler_angles_of_each_orient_asked_in_turn():
    task = Task("MODULE T\nVAR num a{9};\nVAR orient o;\nPROC main()\n"
                "o := OrientZYX(30, -20, 10);\na{1} := EulerZYX(\\X, o);\n"
                "a{2} := EulerZYX(\\Y, o);\na{3} := EulerZYX(\\Z, o);\n"
                "o := OrientZYX(-150, 80, 0);\na{4} := EulerZYX(\\X, o);\n"
                "a{5} := EulerZYX(\\Y, o);\na{6} := EulerZYX(\\Z, o);\n"
                "o := [1, 0, 0, 0];\na{7} := EulerZYX(\\Z, o);\no.q1 := 2;\n"
                "a{8} := EulerZYX(\\X, o);\nENDPROC\nENDMODULE\n", "T.mod")
    task.run()
    a = task.data["a"].value.items
    assert a[:3] == pytest.approx([10, -20, 30], abs=1e-3)
    assert a[3:6] == pytest.approx([0, 80, -150], abs=1e-3)
    assert a[6] == 0.0
    assert "ERR_ARGVALERR" in task.stop_reason and "not normalised" in task.stop_reason
