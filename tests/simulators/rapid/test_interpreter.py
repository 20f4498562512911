"""The RAPID interpreter, semantic by semantic (RAPID reference: data types num and string,
error recovery, UNDO, the string functions, the operator interface)."""

from __future__ import annotations

import threading

import pytest

from simulators.rapid.errors import ERRNUMS, LoadError
from simulators.rapid.interpreter import Task
from simulators.rapid.values import num


def run(body: str, data: str = "", routines: str = "", **kw) -> Task:
    """A module whose main runs `body`; the task after main ended or the program stopped."""
    task = Task(f"MODULE T\n{data}\nPROC main()\n{body}\nENDPROC\n{routines}\nENDMODULE\n",
                "T.mod", **kw)
    task.run()
    return task


def value(task: Task, name: str):
    v = task.data[name.lower()].value
    return v.items if hasattr(v, "items") and not isinstance(v, dict) else v


# -- num, string, bool -------------------------------------------------------------------------
def test_num_is_a_32_bit_float():
    t = run("x := 0.1; y := 16777216 + 1; z := 1 / 3;", "VAR num x; VAR num y; VAR num z;")
    assert value(t, "x") == num(0.1) != 0.1
    assert value(t, "y") == 16777216.0  # 2^24 + 1 is not a float32
    assert value(t, "z") == pytest.approx(1 / 3, rel=1e-7) and value(t, "z") != 1 / 3


def test_a_string_past_80_characters_is_err_strtoolng():
    t = run('s := StrPart("' + "x" * 60 + '", 1, 60); s := s + s;', "VAR string s;")
    assert t.state == "stopped" and "ERR_STRTOOLNG" in t.stop_reason
    assert "T.mod:4" in t.stop_reason  # the line of the concatenation


def test_array_bounds_and_division_by_zero_are_errors():
    t = run("a{4} := 1;", "VAR num a{3};")
    assert "ERR_OUTOFBND" in t.stop_reason
    t = run("x := 1 / 0;", "VAR num x;")
    assert "ERR_DIVZERO" in t.stop_reason
    t = run("x := 7 DIV 2; y := -7 MOD 2;", "VAR num x; VAR num y;")
    assert (value(t, "x"), value(t, "y")) == (3.0, -1.0)


def test_records_and_arrays_have_value_semantics():
    t = run("p := [1, 2, 3]; q := p; q.x := 9; a{1} := p; a{1}.y := 7;",
            "VAR pos p; VAR pos q; VAR pos a{2};")
    assert value(t, "p").f == {"x": 1.0, "y": 2.0, "z": 3.0}
    assert value(t, "q").f["x"] == 9.0 and value(t, "a")[0].f["y"] == 7.0


# -- error recovery ----------------------------------------------------------------------------
def test_retry_executes_the_failing_instruction_again():
    t = run("x := 10 / d;", "VAR num x; VAR num d := 0;",
            ).stop_reason  # no handler: stops
    assert "ERR_DIVZERO" in t
    t = run("Divide;", "VAR num x; VAR num d := 0; VAR num tries := 0;",
            "PROC Divide()\n x := 10 / d;\nERROR\n Incr tries; d := 2; RETRY;\nENDPROC")
    assert (value(t, "x"), value(t, "tries")) == (5.0, 1.0)


def test_retry_is_limited():
    t = run("Divide;", "VAR num x; VAR num d := 0;",
            "PROC Divide()\n x := 10 / d;\nERROR\n RETRY;\nENDPROC")
    assert "ERR_EXCRTYMAX" in t.stop_reason


def test_trynext_goes_on_after_the_failing_instruction():
    t = run("Divide;", "VAR num x := 1; VAR num y; VAR num d := 0;",
            "PROC Divide()\n x := 10 / d;\n y := 2;\nERROR\n TRYNEXT;\nENDPROC")
    assert (value(t, "x"), value(t, "y")) == (1.0, 2.0)


def test_an_error_propagates_to_the_callers_handler_with_its_errno():
    t = run("Outer;", "VAR num got; VAR num after;",
            "PROC Outer()\n Inner;\n after := 1;\nERROR\n got := ERRNO; TRYNEXT;\nENDPROC\n"
            "PROC Inner()\n VAR num a{2};\n a{3} := 1;\nENDPROC")
    assert value(t, "got") == ERRNUMS["ERR_OUTOFBND"] and value(t, "after") == 1.0


def test_raise_and_the_handlers_end_propagate():
    t = run("Outer;", "VAR num got;",
            "PROC Outer()\n Inner;\nERROR\n got := ERRNO; RETURN;\nENDPROC\n"
            "PROC Inner()\n RAISE 42;\nERROR\n IF ERRNO = 1 RETURN;\nENDPROC")
    assert value(t, "got") == 42.0  # Inner's handler ended without RETURN: propagated


def test_return_from_a_functions_handler():
    t = run("ok := Safe(0);", "VAR bool ok := TRUE;",
            "FUNC bool Safe(num d)\n VAR num x;\n x := 1 / d;\n RETURN TRUE;\n"
            "ERROR\n RETURN FALSE;\nENDFUNC")
    assert value(t, "ok") is False


def test_an_error_in_an_error_handler_stops_the_program():
    t = run("Bad;", "VAR num a{1};",
            "PROC Bad()\n a{2} := 1;\nERROR\n a{3} := 1; TRYNEXT;\nENDPROC")
    assert t.state == "stopped" and "ERR_OUTOFBND" in t.stop_reason


def test_an_unhandled_error_stops_with_its_event_log_message():
    t = run("x := 1;\nx := x / 0;", "VAR num x;")
    last = list(t.log)[-1]
    assert last.kind == "error" and "ERR_DIVZERO" in last.text and "T.mod:5" in last.text


def test_a_recovered_error_leaves_a_warning_unless_skipwarn():
    t = run("Quiet; Loud;", "VAR num d := 0; VAR num x;",
            "PROC Quiet()\n x := 1 / d;\nERROR\n SkipWarn; TRYNEXT;\nENDPROC\n"
            "PROC Loud()\n x := 1 / d;\nERROR\n TRYNEXT;\nENDPROC")
    warnings = [e for e in t.log if e.kind == "warning"]
    assert len(warnings) == 1 and "Loud" in warnings[0].text


def test_undo_runs_on_pp_to_main():
    task = Task("MODULE T\nVAR num undone := 0;\nPROC main()\n Work;\nENDPROC\n"
                "PROC Work()\n WHILE TRUE DO\n  WaitTime 0.01;\n ENDWHILE\n"
                "UNDO\n undone := undone + 1;\nENDPROC\nENDMODULE\n", "T.mod")
    thread = threading.Thread(target=task.run)
    thread.start()
    task.request_stop()
    thread.join(5)
    assert task.state == "stopped" and value(task, "undone") == 0.0  # stopped: no UNDO yet
    task.pp_to_main()
    assert value(task, "undone") == 1.0


# -- loading --------------------------------------------------------------------------------------
def test_an_instruction_the_controller_lacks_is_a_load_error_naming_its_line():
    with pytest.raises(LoadError, match=r"T.mod:5: instruction SetDO"):
        run("x := 1;\nSetDO do1, 1;", "VAR num x;")
    with pytest.raises(LoadError, match=r"T.mod:4: function Nope"):
        run("x := Nope(1);", "VAR num x;")
    with pytest.raises(LoadError, match=r"no data named y"):
        run("x := y;", "VAR num x;")


# -- built-ins ------------------------------------------------------------------------------------
def test_string_functions():
    t = run('a := StrFind("ab cd", 1, " "); b := StrFind("abc", 1, STR_DIGIT \\NotInSet);'
            ' c := StrFind("123", 1, STR_DIGIT \\NotInSet); s := StrPart("hello", 2, 3);'
            ' ok := StrToVal("-1.5", v); bad := StrToVal("1,5", w); n := NumToStr(2.34567, 2);'
            ' m := StrMemb("a#", 2, "#");',
            "VAR num a; VAR num b; VAR num c; VAR string s; VAR bool ok; VAR bool bad;"
            " VAR num v; VAR num w := 7; VAR string n; VAR bool m;")
    assert (value(t, "a"), value(t, "b"), value(t, "c")) == (3.0, 1.0, 4.0)
    assert value(t, "s") == "ell" and value(t, "ok") and value(t, "v") == -1.5
    assert value(t, "bad") is False and value(t, "w") == 7.0  # unchanged on failure
    assert value(t, "n") == "2.35" and value(t, "m") is True


def test_strpart_outside_the_string_is_an_error():
    t = run('s := StrPart("abc", 3, 2);', "VAR string s;")
    assert "ERR_ARGVALERR" in t.stop_reason


def test_euler_zyx_and_orient_zyx_are_inverse():
    t = run("o := OrientZYX(30, -20, 10); z := EulerZYX(\\Z, o); y := EulerZYX(\\Y, o);"
            " x := EulerZYX(\\X, o);", "VAR orient o; VAR num x; VAR num y; VAR num z;")
    assert (value(t, "z"), value(t, "y"), value(t, "x")) == pytest.approx((30, -20, 10),
                                                                         abs=1e-4)


def test_the_pendant_shows_tpwrite_and_answers_tpreadfk():
    task = Task('MODULE T\nVAR num key;\nVAR errnum e;\nPROC main()\n TPErase;\n'
                ' TPWrite "offsets?";\n TPReadFK key, "Go on?", "Done", stEmpty, stEmpty,'
                ' stEmpty, "Cancel";\n TPReadFK key, "again", "Done", stEmpty, stEmpty,'
                ' stEmpty, stEmpty \\MaxTime:=0.05 \\BreakFlag:=e;\nENDPROC\nENDMODULE\n',
                "T.mod")
    thread = threading.Thread(target=task.run)
    thread.start()
    prompt = task.pendant.wait_prompt(5)
    assert prompt.screen == ("offsets?",) and prompt.keys[4] == "Cancel"
    task.pendant.press(5)
    thread.join(5)
    assert value(task, "key") == 0.0  # the second prompt timed out
    assert value(task, "e") == ERRNUMS["ERR_TP_MAXTIME"]
    assert task.pendant.prompts[0].text == "Go on?"


def test_stop_and_exit_cycle():
    t = run("x := 1; Stop; x := 2;", "VAR num x;")
    assert value(t, "x") == 1.0 and "Stop" in t.stop_reason
    t = run("Incr n; IF n < 3 ExitCycle; x := n;", "VAR num n; VAR num x;")
    assert value(t, "x") == 3.0  # main ran three times, its data kept
