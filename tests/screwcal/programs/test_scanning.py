"""The readers' scanners at their edges: strings, comments, brackets and names next to other
words, in each language; what each finds, line and span, stays as written."""

from screwcal.programs import read_program
from screwcal.programs.urscript import _code, _split


def _one(texts):
    return read_program(texts)


def test_urscript_blanks_comments_and_strings_keeping_offsets_and_newlines():
    text = 'a = "x # y\nz" # p[1,2,3,4,5,6]\nb = \'q\'\nc = "never closed\nXY'
    code = _code(text)
    assert len(code) == len(text)
    assert code == ('a = "' + " " * 5 + '\n "' + " " * 17 + "\nb = ' '\nc = \"" + " " * 12
                    + "\n Y")  # never closed: up to the last character


def test_urscript_split_keeps_nested_brackets_and_strips_spaces():
    code = "f( a, p[1, 2], (b, c) ,  , d )"
    spans = _split(code, 2, len(code) - 1)
    assert [code[s:e] for s, e in spans] == ["a", "p[1, 2]", "(b, c)", "", "d"]
    assert _split("x, (y", 0, 5) == [(0, 1)]  # an unclosed bracket: nothing after it


def test_urscript_targets_inside_comments_and_strings_are_not_read():
    text = ("def prog():\n"
            "  # movel(p[9, 9, 9, 0, 0, 0])\n"
            "  popup(\"movel(p[8, 8, 8, 0, 0, 0])\")\n"
            "  movel( p[0.4, -0.1, 0.3, 0.0, 3.14, 0.0] , a=1.2)\n"
            "end\n")
    program = _one({"a.script": text})
    (t,) = program.targets
    assert t.line == 4 and t.values == (0.4, -0.1, 0.3, 0.0, 3.14, 0.0)
    assert [text[a:b] for a, b in t.spans] == ["0.4", "-0.1", "0.3", "0.0", "3.14", "0.0"]


def test_krl_aggregate_with_strings_nested_braces_and_names_in_several_motions():
    dat = ('DEFDAT d\n'
           'DECL E6POS XP1={X 1.5,Y -2,Z 3, A 4,B 5,C 6,S 2,T 35,E1 0.0}\n'
           'DECL FDAT FP1={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,NAME[] "a,}{b"}\n'
           'DECL E6POS XP2={X 7,Y 8,Z 9,A 0,B 0,C 0,S 6,T 2,E1 {0}}\n'
           'ENDDAT\n')
    src = "DEF d()\nFDAT_ACT=FP1\nPTP XP1\nLIN  XP2 , C_DIS\nCIRC XP1, XP2\nEND\n"
    program = _one({"d.dat": dat, "d.src": src})
    t1, t2 = program.targets
    assert (t1.name, t1.line, t1.values) == ("XP1", 2, (1.5, -2.0, 3.0, 4.0, 5.0, 6.0))
    assert [dat[a:b] for a, b in t1.spans] == ["1.5", "-2", "3", "4", "5", "6"]
    assert (t1.flags["S"].text, t1.flags["T"].text) == ("2", "35")
    assert (t2.name, t2.line, t2.values) == ("XP2", 4, (7.0, 8.0, 9.0, 0.0, 0.0, 0.0))
    # XP1 is moved to with tool 1 (FP1) and then without it (CIRC): one value cannot serve
    assert "several tools" in t1.problem


def test_krl_the_controller_form_and_every_other_form_of_a_target_read_alike():
    forms = ["{X 1.5,Y -2,Z 3,A 4,B 5,C 6,S 2,T 35,E1 0.0,E2 0.0}",  # as a controller writes it
             "{x 1.5 , y -2,  z 3,\n A 4,B 5,C 6,S 2,T 35}",  # other case and spacing
             "{E6POS: X 1.5,Y -2,Z 3,A 4,B 5,C 6,S 2,T 35}",  # the type named first
             "{Y -2,X 1.5,Z 3,A 4,B 5,C 6,T 35,S 2}",  # another order
             "{X 1.5,Y -2,Z 3,A 4,B 5,C 6,S 2,T 35,E1 {0}}"]  # a nested aggregate
    for form in forms:
        dat = f"DEFDAT d\nDECL E6POS XP1={form}\nENDDAT\n"
        (t,) = _one({"d.dat": dat, "d.src": "DEF d()\nPTP XP1\nEND\n"}).targets
        assert (t.line, t.values, t.problem) == (2, (1.5, -2.0, 3.0, 4.0, 5.0, 6.0), ""), form
        assert [dat[a:b] for a, b in t.spans] == ["1.5", "-2", "3", "4", "5", "6"], form
        assert {k: dat[slice(*f.span)] for k, f in t.flags.items()} == {"S": "2", "T": "35"}


def test_krl_an_expression_in_the_controller_form_is_listed_not_read():
    dat = ("DEFDAT d\nDECL E6POS XP1={X 10+2,Y 0,Z 0,A 0,B 0,C 0,S 'B010',T 3}\n"
           "DECL POS XP2={X 1,Y 2,Z 3,A 0,B 0,C 0}\nENDDAT\n")
    t1, t2 = _one({"d.dat": dat, "d.src": "DEF d()\nPTP XP1\nLIN XP2\nEND\n"}).targets
    assert "expression" in t1.problem and t1.flags["S"].text == "'B010'"
    assert t2.values == (1.0, 2.0, 3.0, 0.0, 0.0, 0.0) and not t2.flags


def test_fanuc_fields_are_whole_words_of_any_case():
    ls = ("/PROG  T\n/MN\n   1:J P[1] 100% FINE    ;\n/POS\n"
          "P[1]{\n   GP1:\n\tuf : 0, UT : 0,\tconfig : 'N U T, 0, 0, 0',\n"
          "\tAX = 99.0 mm, X = 1.0  mm,\tY = 2.0  mm,\tz = 3.0  mm,\n"
          "\tw = 4.0 deg,\tP = 5.0 deg,\tR = 6.0 deg\n};\n/END\n")
    program = _one({"t.ls": ls})
    (t,) = program.targets
    assert t.values == (1.0, 2.0, 3.0, 4.0, 5.0, 6.0)
    assert [ls[a:b] for a, b in t.spans] == ["1.0", "2.0", "3.0", "4.0", "5.0", "6.0"]
    assert t.flags["CONFIG"].text == "N U T, 0, 0, 0"
    joints = ls.replace("X = 1.0  mm", "J1 = 1.0 deg")
    assert _one({"t.ls": joints}).joint_targets == 1


USUAL_LS = ("/PROG  T\n/MN\n   1:L P[1] 100mm/sec FINE    ;\n/POS\nP[1]{\n   GP1:\n"
            "\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',\n"
            "\tX =   400.000  mm,\tY =    -.384  mm,\tZ =   300.000  mm,\n"
            "\tW =   180.000 deg,\tP =      .881 deg,\tR =     0.000 deg\n};\n/END\n")


def test_fanuc_a_position_reads_the_same_in_the_controllers_layout_and_in_others():
    """The controller's own layout and the same fields laid out otherwise: the values, their
    spans, the CONFIG flag, the frame and the tool are the same."""
    layouts = {
        "controller": USUAL_LS,
        "CR LF": USUAL_LS.replace("\n", "\r\n"),
        "on one line": USUAL_LS.replace(",\n\t", ", ").replace(":\n\t", ": "),
        "other order": USUAL_LS.replace("UF : 1, UT : 2", "UT : 2, UF : 1"),
        "':' for '='": USUAL_LS.replace("X =", "X :"),
        "lower case": USUAL_LS.replace("UF :", "uf :").replace("GP1:", "gp1:"),
        "extended axis": USUAL_LS.replace("0.000 deg\n};", "0.000 deg,\n\tE1=  12.500  mm\n};"),
        "other group": USUAL_LS.replace("0.000 deg\n};", "0.000 deg\n   GP2:\n\tUF : 0, UT : 0,\t"
                                        "\n\tJ1=   200.000  mm,\tJ2=   1.000 deg\n};"),
        "other group first": USUAL_LS.replace("   GP1:", "   GP2:\n\tUF : 0, UT : 0,\n\tJ1= 2 mm"
                                              "\n   GP1:"),
        "number with zeros, comment": USUAL_LS.replace("P[1]{", 'P[001:"approach"]{'),
    }
    for layout, ls in layouts.items():
        (t,) = _one({"t.ls": ls}).targets
        assert t.name == "P[1]", layout
        assert t.values == (400.0, -0.384, 300.0, 180.0, 0.881, 0.0), layout
        assert [ls[a:b] for a, b in t.spans] == [
            "400.000", "-.384", "300.000", "180.000", ".881", "0.000"], layout
        config = t.flags["CONFIG"]
        assert (config.text, ls[config.span[0]:config.span[1]]) == ("N U T, 0, 0, 0",) * 2
        assert (t.line, t.frame, t.tool, t.problem) == (5, "UF[1]", "UT[2]", ""), layout


def test_fanuc_a_motion_missing_its_semicolon_before_pos_still_counts():
    """A motion runs to the first ';', even past /POS: its position register is noted."""
    ls = USUAL_LS.replace("FINE    ;\n/POS", "FINE    ;\n   2:L PR[3] 100mm/sec FINE\n/POS")
    (note,) = _one({"t.ls": ls}).notes
    assert (note.line, note.name) == (4, "PR[3]")


def test_urscript_motion_names_inside_longer_names_are_not_motions():
    text = ("def prog():\n"
            "  my_movel(p[9, 9, 9, 0, 0, 0])\n"
            "  xset_tcp(p[0, 0, 0.5, 0, 0, 0])\n"
            "  movel\t(p[0.4, -0.1, 0.3, 0.0, 3.14, 0.0]\t, a=1.2)\n"
            "  movec(p[0.5, 0.1, 0.3, 0, 3.14, 0], p[0.6, 0.2, 0.3, 0, 3.14, 0], r=0)\n"
            "  movej(p[0.4, 0.1,\n          0.3, 0, 3.14, 0])\n"
            "end\n")
    program = _one({"a.script": text})
    assert [(t.line, t.name, t.values[:3], t.tool) for t in program.targets] == [
        (4, "movel pose", (0.4, -0.1, 0.3), None), (5, "movec pose", (0.5, 0.1, 0.3), None),
        (5, "movec pose", (0.6, 0.2, 0.3), None), (6, "movej pose", (0.4, 0.1, 0.3), None)]
    assert [text[a:b] for a, b in program.targets[-1].spans] == [
        "0.4", "0.1", "0.3", "0", "3.14", "0"]
    assert not program.tools and not program.notes


def test_fanuc_letters_whose_capital_is_two_letters_do_not_move_the_positions():
    """A German comment before /POS ('Schweißen'; 'ß' upper-cased is 'SS'): the positions
    are still found where they start, none left out."""
    comments = "".join(f"  {k + 1:2d}:  ! Schweißen, Schweißen, Schweißen ;\n" for k in range(3))
    ls = USUAL_LS.replace("/MN\n", "/MN\n" + comments)
    (t,) = _one({"t.ls": ls}).targets
    assert (t.name, t.line) == ("P[1]", 8)
