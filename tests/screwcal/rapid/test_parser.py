"""The RAPID parser: the shipped server module, every statement and declaration form (modules
written in the forms public ABB code uses), positions, and syntax errors with line and column."""

from dataclasses import FrozenInstanceError
from pathlib import Path

import pytest

from protocol.rapid import module_text
from screwcal.rapid import RapidSyntaxError, parse_expression, parse_module
from screwcal.rapid import ast as rapid_ast
from screwcal.rapid.ast import (
    Aggregate,
    Assign,
    Binary,
    Call,
    Connect,
    For,
    Goto,
    If,
    Index,
    Label,
    Num,
    ProcCall,
    Raise,
    Return,
    Simple,
    Str,
    Unary,
    While,
)
from screwcal.rapid.check import _children

DATA = Path(__file__).parent / "data"


def _parse(name: str):
    return parse_module((DATA / name).read_text(), name)


def _all(node, kind):
    return [n for n in _children(node) if isinstance(n, kind)]


def test_the_shipped_server_module_parses():
    module = parse_module(module_text(), "ScrewcalServer.mod")
    assert module.name == "ScrewcalServer"
    names = {r.name for r in module.routines}
    assert {"main", "Dispatch", "PoseJoints", "InLimits"} <= names
    pose_joints = next(r for r in module.routines if r.name == "PoseJoints")
    assert pose_joints.kind == "FUNC" and pose_joints.error  # an ERROR handler in a FUNC
    assert pose_joints.params[1].mode == "INOUT"
    main = next(r for r in module.routines if r.name == "main")
    assert main.undo  # an UNDO handler
    dispatch = next(r for r in module.routines if r.name == "Dispatch")
    test = next(s for s in dispatch.body if isinstance(s, rapid_ast.Test))
    assert test.default and [c.labels[0].value for c in test.cases][:3] == ["HELO", "STAT",
                                                                            "LOAD"]
    # expressions as array indices: tok{first + i - 1}
    assert any(isinstance(i.indices[0], Binary) for i in _all(module, Index))


def test_server_forms():
    m = _parse("server.mod")
    main = m.routines[0]
    assert main.error_numbers and [n.name for n in main.error_numbers] == ["ERR_SOCK_TIMEOUT",
                                                                          "ERR_SOCK_CLOSED"]
    assert main.undo and isinstance(main.error[0], If) and len(main.error[0].branches) == 2
    assert any(isinstance(s, Connect) and s.trap == "OnStop" for s in main.body)
    accept = next(s for s in main.body if isinstance(s, ProcCall) and s.name == "SocketAccept")
    assert [(a.name, a.optional) for a in accept.args] == [(None, False), (None, False),
                                                           ("Time", True)]
    serve = m.routines[1]
    test = serve.body[0]
    assert [len(c.labels) for c in test.cases] == [3, 1]  # CASE 1, 2, 3:
    compact = serve.body[1]
    assert compact.compact and isinstance(compact.branches[0][1][0], Goto)
    assert any(isinstance(s, Label) and s.name == "done" for s in serve.body)
    assert isinstance(serve.error[0], Simple) and serve.error[0].keyword == "TRYNEXT"
    checked = m.routines[2]
    low = checked.params[1]
    assert low.optional and low.alternatives[0].name == "Positive"
    assert isinstance(checked.error[0], Return)
    late = m.routines[3].body[0]
    assert late.name == "" and isinstance(late.late, Binary)
    trap = m.routines[-1]
    assert trap.kind == "TRAP" and trap.name == "OnStop"
    assert any(c.text.startswith("! A socket server") for c in m.comments)
    assert _all(m, Raise) and _all(m, While)


def test_motion_forms():
    m = _parse("motion.mod")
    seams = next(d for d in m.data if d.name == "pSeam")
    assert len(seams.dims) == 2 and len(seams.value.items) == 2
    first = seams.value.items[0].items[0]
    assert first.items[0].items[0].text == "10" and first.items[0].items[0].line == 10
    torch = m.data[0]
    assert torch.storage == "PERS" and torch.value.items[1].items[0].items[0].text == "10.5"
    wfix = m.data[1]
    assert wfix.scope == "TASK"
    approach = next(d for d in m.data if d.name == "pApproach")
    assert approach.scope == "LOCAL" and approach.value.items[3].items[0].text == "9E+09"
    loops = _all(m.routines[0], For)
    assert loops[1].step is not None and loops[1].step.text == "-2"  # a signed literal
    weld = m.routines[1]
    movec = next(s for s in weld.body if isinstance(s, ProcCall) and s.name == "MoveC")
    reltool = movec.args[0].value
    assert isinstance(reltool, Call) and reltool.args[-1].name == "Rz"
    search = next(s for s in weld.body if isinstance(s, ProcCall) and s.name == "SearchL")
    assert search.args[0].name == "Stop" and search.args[0].value is None
    shift = m.routines[-1]
    assert [p.mode for p in shift.params] == ["INOUT", "PERS", "VAR"] and shift.params[2].dims
    assert isinstance(shift.body[1], Assign)


def test_system_module_forms():
    m = _parse("common.sys")
    assert m.attributes == ("SYSMODULE", "NOSTEPIN")
    record = m.records[0]
    assert record.name == "partinfo" and [f.name for f in record.fields] == ["name", "weight",
                                                                             "centre"]
    assert m.aliases[0].type == "num" and m.aliases[0].name == "partcount"
    assert m.routines[-1].local and m.routines[-1].type == "num"
    value = m.data[0].value
    assert isinstance(value, Aggregate) and isinstance(value.items[0], Str)


def test_nodes_are_frozen_and_know_their_place():
    text = "MODULE m\n  VAR num x := -1.5;\nENDMODULE\n"
    m = parse_module(text)
    value = m.data[0].value
    assert isinstance(value, Num) and value.value == -1.5
    assert (value.line, value.col) == (2, 16) and text[value.start:value.end] == "-1.5"
    with pytest.raises(FrozenInstanceError):
        value.text = "2"  # type: ignore[misc]


def test_every_node_is_built_as_its_dataclass_declares():
    """The node classes' constructors (slots set directly, for speed) take the dataclass's
    fields in order with their defaults, and store what they are given; the dataclass's own
    constructor, which they replace, is never compiled (a tenth of loading the parser)."""
    import dataclasses
    import inspect

    for cls in [c for c in vars(rapid_ast).values() if isinstance(c, type)
                and issubclass(c, rapid_ast.Node)]:
        fields = dataclasses.fields(cls)
        assert not cls.__dataclass_params__.init, cls
        params = list(inspect.signature(cls.__init__).parameters.values())[1:]
        assert [(p.name, p.default) for p in params] == [
            (f.name, inspect.Parameter.empty if f.default is dataclasses.MISSING else f.default)
            for f in fields], cls
        given = {f.name: object() for f in fields}
        node = cls(**given)
        assert all(getattr(node, name) is value for name, value in given.items()), cls
    arg = rapid_ast.Argument(1, 2, 3, 4, None)
    assert (arg.name, arg.optional, arg.conditional) == (None, False, False)
    assert arg == rapid_ast.Argument(1, 2, 3, 4, None, None, False, False)
    assert hash(arg) == hash(rapid_ast.Argument(1, 2, 3, 4, None))


@pytest.mark.parametrize("text, value", [
    ("1 + 2 * 3", ("+", "1", ("*", "2", "3"))),
    ("a OR b AND c", ("OR", "a", ("AND", "b", "c"))),
    ("NOT ok OR n < 2", ("OR", ("NOT", "ok"), ("<", "n", "2"))),
    ("-x + 1", ("+", ("-", "x"), "1")),
    ("a DIV 2 MOD 3", ("MOD", ("DIV", "a", "2"), "3")),
])
def test_operator_precedence(text, value):
    def shape(e):
        if isinstance(e, Binary):
            return (e.op, shape(e.left), shape(e.right))
        if isinstance(e, Unary):
            return (e.op, shape(e.operand))
        return getattr(e, "text", None) or e.name

    assert shape(parse_expression(text)) == value


def test_a_number_after_an_instruction_is_an_argument_not_a_component():
    m = parse_module("MODULE m\n  PROC p()\n    WaitTime .01;\n    a.b := 1;\n  ENDPROC\n"
                     "ENDMODULE\n")
    wait, assign = m.routines[0].body
    assert isinstance(wait, ProcCall) and wait.args[0].value.text == ".01"
    assert isinstance(assign, Assign)


def test_a_call_of_plain_names_reads_as_any_call():
    """The one-line fast path for `MoveJ p, v, z, tool;` gives the nodes the general path
    gives (here forced by a comment inside the statement)."""
    fast = parse_module("MODULE m\n  PROC p()\n    MoveJ p1, v1000,z50 , tool0 ;\n"
                        "  ENDPROC\nENDMODULE\n").routines[0].body[0]
    slow = parse_module("MODULE m\n  PROC p()\n    MoveJ p1, v1000,z50 , ! c\ntool0 ;\n"
                        "  ENDPROC\nENDMODULE\n").routines[0].body[0]
    assert (fast.line, fast.col, fast.start, fast.end) == (3, 5, 24, 53)
    assert fast.args[:3] == slow.args[:3]
    assert [a.value.name for a in fast.args] == [a.value.name for a in slow.args]
    assert (fast.args[3].value.line, fast.args[3].value.col) == (3, 27)
    keyword = parse_module("MODULE m\n  PROC p()\n    Foo a, NOT b;\n  ENDPROC\nENDMODULE\n")
    assert isinstance(keyword.routines[0].body[0].args[1].value, Unary)


def test_backward_handler_late_bound_function_conditional_and_named_arguments():
    m = parse_module(
        "MODULE m(NOSTEPIN)\n"
        "  PROC Walk(\\num Speed)\n"
        "    Move2 \\Speed?Speed, ToPoint:=p10;\n"
        "    x := %\"Get\" + kind%(1, \\Opt);\n"
        "  BACKWARD\n"
        "    MoveL p5, v100, fine, tool0;\n"
        "  ERROR (ERR_DIVZERO)\n"
        "    RAISE ERR_DIVZERO;\n"
        "  ENDPROC\n"
        "ENDMODULE\n")
    walk = m.routines[0]
    call, assign = walk.body
    assert call.args[0].conditional and call.args[0].name == "Speed"
    assert call.args[1].name == "ToPoint" and not call.args[1].optional
    late = assign.value
    assert isinstance(late, Call) and late.name == "" and isinstance(late.late, Binary)
    assert late.args[1].name == "Opt" and late.args[1].value is None
    assert isinstance(walk.backward[0], ProcCall) and isinstance(walk.error[0], Raise)
    assert walk.error_numbers[0].name == "ERR_DIVZERO"


def test_string_escapes():
    s = parse_expression('"say ""hi"" \\\\ \\41"')
    assert isinstance(s, Str) and s.value == 'say "hi" \\ A'


@pytest.mark.parametrize("text, line, col, says", [
    ("PROC main()\nENDPROC\n", 1, 1, "must begin with 'MODULE"),
    ("MODULE m\n  VAR num x := 1\n  VAR num y;\nENDMODULE\n", 3, 3, "does not end with ';'"),
    ("MODULE m\n  PROC p()\n    IF x THEN\n      y := 1;\n  ENDPROC\nENDMODULE\n", 5, 3,
     "expected ELSE or ELSEIF or ENDIF"),
    ("MODULE m\n  PROC p()\n    MoveL p1 v100, z10, tool0;\n  ENDPROC\nENDMODULE\n", 3, 14,
     "expected ',' or ';' between arguments"),
    ("MODULE m\n  CONST robtarget p:=[[1,2,3],[1,0,0,0];\nENDMODULE\n", 2, 40,
     "expected ',' or ']'"),
    ('MODULE m\n  VAR string s := "open;\nENDMODULE\n', 2, 19, "never closes"),
    ("MODULE m\n  PROC p()\n    WHILE TRUE DO\n  ENDPROC\nENDMODULE\n", 4, 3,
     "expected ENDWHILE"),
    ("MODULE m\n  PROC p()\n  ENDFUNC\nENDMODULE\n", 3, 3,
     "expected BACKWARD or ENDPROC or ERROR or UNDO in PROC p (line 2), found 'ENDFUNC'"),
    ("MODULE m\n  PROC p()\n    IF x WHILE y DO ENDWHILE\n  ENDPROC\nENDMODULE\n", 3, 10,
     "compact IF takes one simple statement"),
    ("MODULE m\nENDMODULE\nMODULE n\nENDMODULE\n", 3, 1, "text after ENDMODULE"),
    ("MODULE m\n  PROC Step()\n  ENDPROC\nENDMODULE\n", 2, 8,
     "expected the PROC's name, found 'STEP'"),  # a reserved word
    ("MODULE m\n  PROC p()\n", 3, 1, "the file ends inside PROC p (line 2)"),
])
def test_syntax_errors_name_line_and_column(text, line, col, says):
    with pytest.raises(RapidSyntaxError) as caught:
        parse_module(text, "bad.mod")
    err = caught.value
    assert (err.line, err.col) == (line, col), str(err)
    assert says in err.reason and str(err).startswith(f"bad.mod:{line}:{col}: ")


def test_parsing_leaves_the_cycle_collector_as_it_finds_it():
    """The collector is the whole process's (a service parses beside other threads): parsing
    neither switches it off nor on, also when the text does not parse (the command line's
    pace for it: screwcal/runtime/policy.py)."""
    import gc

    parse_module("MODULE m\nENDMODULE\n")
    assert gc.isenabled()
    with pytest.raises(RapidSyntaxError):
        parse_module("MODULE m\n  PROC p(\nENDMODULE\n")
    assert gc.isenabled()
    gc.disable()
    try:
        parse_module("MODULE m\nENDMODULE\n")
        assert not gc.isenabled()
    finally:
        gc.enable()


@pytest.mark.parametrize("head", ["CONST robtarget p10 :=", "CONST  robtarget\tp10:=",
                                  "CONST robtarget ! a comment\n  p10 :=",
                                  "CONST robtarget\n    p10\n    :="])
def test_a_declaration_reads_the_same_on_one_line_or_several(head):
    """`CONST type name :=` on one line is read in one match; across lines or comments, token
    by token: the same declaration either way."""
    value = "[[1,2,3],[1,0,0,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
    decl = parse_module(f"MODULE m\n{head} {value};\nENDMODULE\n").data[0]
    assert (decl.storage, decl.type, decl.name, decl.dims) == ("CONST", "robtarget", "p10", ())
    assert [row.texts for row in decl.value.items] == [
        ("1", "2", "3"), ("1", "0", "0", "0"), ("0", "0", "0", "0"), ("9E+09",) * 6]


_NUMBER_FORMS = ["1", ".5", "5.", "-2", "+3", "1E-3", "9E+09", "1.5e+2", "-.25", "0"]


def test_numbers_read_in_one_match_read_as_token_by_token():
    """A value of plain numbers on one line (every robtarget) is read in one match: each form
    of a RAPID number reads as it does token by token, where the value spans lines."""
    rows = [_NUMBER_FORMS[:3], _NUMBER_FORMS[3:7], _NUMBER_FORMS[7:]]
    one_line = "[" + ",".join("[" + ",".join(r) + "]" for r in rows) + "]"
    spread = "[" + ",\n".join("[" + " , ".join(r) + "]" for r in rows) + "]"
    fast = parse_module(f"MODULE m\nCONST num a{{3}} := {one_line};\nENDMODULE\n").data[0]
    slow = parse_module(f"MODULE m\nCONST num a{{3}} := {spread};\nENDMODULE\n").data[0]
    assert [row.texts for row in fast.value.items] == [row.texts for row in slow.value.items] \
        == [tuple(r) for r in rows]
    assert [n.value for n in fast.value.items[2].items] == [150.0, -0.25, 0.0]


@pytest.mark.parametrize("value", ["[1e,2]", "[1.2.3]", "[[1,2],[3,,4]]", "[1 2]", "[-,1]"])
def test_malformed_numbers_are_not_taken_by_the_one_match_reading(value):
    with pytest.raises(RapidSyntaxError):
        parse_module(f"MODULE m\nCONST num a{{2}} := {value};\nENDMODULE\n")


@pytest.mark.parametrize("text, where", [("VAR num TO := 1;", "the data's name"),
                                         ("VAR IF x := 1;", "a data type")])
def test_a_keyword_as_a_declared_name_or_type_is_refused(text, where):
    with pytest.raises(RapidSyntaxError, match=f"expected {where}"):
        parse_module(f"MODULE m\n{text}\nENDMODULE\n")


# A module as a controller saves it (RobotWare 6): a UTF-8 byte-order mark, the %%% header
# with CRLF line ends, then the module. Written here in that form.
_SAVED = ("\ufeff%%%\r\n  VERSION:1\r\n  LANGUAGE:ENGLISH\r\n%%%\r\n\r\nMODULE Saved\r\n"
          "  CONST robtarget p10:=[[500,0,600],[0,0,1,0],[0,0,0,0],"
          "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\r\n"
          "  PROC main()\r\n    MoveL p10, v100, fine, tool0;\r\n  ENDPROC\r\nENDMODULE\r\n")


@pytest.mark.parametrize("text", [_SAVED, _SAVED[1:], _SAVED.encode("utf-8").decode("latin-1"),
                                  _SAVED[1:].replace("\r\n", "\n")])
def test_a_saved_module_header_and_byte_order_mark_are_read_and_kept(text):
    """The header is not part of the module: kept as written in `header`; positions stay
    those of the text given (a rewrite of a number leaves the header byte for byte)."""
    module = parse_module(text, "saved.mod")
    assert module.name == "Saved"
    assert module.header.replace("\r\n", "\n") == "%%%\n  VERSION:1\n  LANGUAGE:ENGLISH\n%%%"
    assert text[module.start:module.start + 12] == "MODULE Saved"
    row = module.data[0].value.items[0]
    assert text[row.starts[0]:row.starts[0] + 3] == "500"
    assert (module.line, module.data[0].line) == (6, 7)


@pytest.mark.parametrize("text, line, col, says", [
    ("%%%\n  VERSION:1\nMODULE m\nENDMODULE\n", 1, 1, "header (%%%) that does not close"),
    ("%%%\n  VERSION:1\n%%%\nPROC p()\nENDPROC\n", 4, 1, "not a RAPID module"),
])
def test_a_broken_header_is_named(text, line, col, says):
    with pytest.raises(RapidSyntaxError) as caught:
        parse_module(text, "h.mod")
    assert (caught.value.line, caught.value.col) == (line, col) and says in caught.value.reason


def test_placeholders_parse_as_the_program_editor_leaves_them():
    """`<SMT>` in an empty routine (no ';'), `<EXP>` for a condition or an argument, `<ARG>`
    after the arguments, `<VAR> := <EXP>;`, `<PAR>` for a parameter, `<DDN>` for a
    declaration: the module loads (RAPID kernel reference, placeholders); each is a node, and
    the module lists them all in text order."""
    from screwcal.rapid.ast import Placeholder

    text = ("MODULE Unfinished\n  <DDN>\n  PROC Empty()\n    <SMT>\n  ENDPROC\n"
            "  PROC Half(<PAR>)\n    IF <EXP> THEN\n      MoveL <EXP>, v100, z10, tool0 <ARG>;\n"
            "    ENDIF\n    <VAR> := <EXP>;\n  ENDPROC\nENDMODULE\n")
    module = parse_module(text, "u.mod")
    assert [(p.kind, p.line, p.col) for p in module.placeholders] == [
        ("DDN", 2, 3), ("SMT", 4, 5), ("PAR", 6, 13), ("EXP", 7, 8), ("EXP", 8, 13),
        ("ARG", 8, 37), ("VAR", 10, 5), ("EXP", 10, 14)]
    empty, half = module.routines
    assert empty.body == (module.placeholders[1],) and half.params == ()
    assert isinstance(half.body[1], Assign) and isinstance(half.body[1].target, Placeholder)
    move = half.body[0].branches[0][1][0]
    assert isinstance(move.args[0].value, Placeholder) and move.args[-1].value.kind == "ARG"
    # not a placeholder: a comparison of names written without blanks
    assert isinstance(parse_expression("a<b"), Binary)


@pytest.mark.parametrize("text", [
    "\x13\x8b\x02\x00\xffMODULE" * 40,  # binary from the first byte
    "%%%\n  VERSION:1\n%%%\n" + "\x93\xa1\xe8\x07\x1b\x9f\xc3" * 80,  # after the header
    "MODULE m\n" + "\x93\xa1\xe8\x07\x1b\x9f\xc3" * 80,
])
def test_an_encrypted_module_is_named_as_such(text):
    from screwcal.rapid import RapidEncryptedError

    with pytest.raises(RapidEncryptedError, match="encrypted"):
        parse_module(text, "secret.sys")


def test_a_last_comment_without_a_line_end_stays_a_comment():
    """A notice after ENDMODULE on the file's last line, with no line end after it: its `|`
    was read as a token ("text after ENDMODULE") when the comment gave back characters."""
    module = parse_module("MODULE m\nENDMODULE\n\n!  https://example.org | @x.com |", "m.mod")
    assert module.comments[-1].text.endswith("@x.com |")
