"""FANUC LS programs (the ASCII form of a TP program): the `/POS` section's positions and the
`/MN` section's motions, read into a `Program`.

A position: `P[1]{ GP1: UF : 0, UT : 1, CONFIG : 'N U T, 0, 0, 0', X = 500.000 mm, Y = ...,
Z = ..., W = -180.000 deg, P = ..., R = ... };` (mm; W, P, R deg fixed angles about X, Y, Z,
so R = Rz(R) Ry(P) Rx(W)). Its user frame and tool frame are the numbers it carries (UF 0: the
world, the robot base; UT 0: the faceplate); their values come from a frames file
(`read_frames`: `UF,1,x,y,z,w,p,r` / `UT,1,...` lines). A position in joints (`J1 = ... deg`)
is left as it is; groups other than GP1 (positioners) too.

Not compensated, listed with the line: a position a motion uses with `INC` (an increment, not a
pose); motions to position registers (`PR[n]`: their values live in the controller); offsets
(`Offset,PR[n]`, `Tool_Offset`, `VOFFSET`) applied in the nominal frame, noted.

A controller set to German writes `KONFIG` for CONFIG and `WKZ_Offset` for Tool_Offset: read as
those (the rest of an LS file's words that matter here are the same in every language).
"""

from __future__ import annotations

import re

from screwcal.programs.program import Flag, Frame, Note, Program, ProgramSyntaxError, Target
from screwcal.programs.program import line_of as _line

_SECTION_POS = re.compile(r"/POS", re.I)  # found in the text itself: an upper-cased copy
# is longer where a letter's capital is two ('ß': 'SS'), its offsets past it not the text's
_GROUP = re.compile(r"GP(\d+)[ \t]*:", re.I)
# A field: \b(UF|UT|CONFIG|X|Y|Z|W|P|R|J\d)[ \t]*[:=][ \t]*(value). Searched as a word whose
# first letter may start a field's name (a character set the search skips to), the name and
# the word boundary checked after (`_fields`): a third of the time of the alternation.
# (Both cases spelt out, not re.I: a case-blind pattern loses the skip.)
_FIELD_WORD = re.compile(r"([UCKXYZWPRJuckxyzwprj]\w*)[ \t]*[:=][ \t]*"
                         r"('[^']*'|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|\*+|[Ff])")
_FIELD_NAMES = frozenset(("UF", "UT", "CONFIG", "KONFIG", "X", "Y", "Z", "W", "P", "R"))
_WORD_CHAR = re.compile(r"\w")
_MOTION = re.compile(r"^[ \t]*\d+:[ \t]*([JLCA])[ \t]+([^;]*);", re.M)
_REF = re.compile(r"\b(P|PR)\[(\d+)(?::[^\]]*)?\]", re.I)
_OFFSETS = re.compile(r"\b(Offset|Tool_Offset|WKZ_Offset|VOFFSET|INC)\b", re.I)
# What makes a motion worth a closer look: a position register or an offset (most name a P[n]).
_NOTABLE = re.compile(r"\bPR\[|\b(?:Offset|Tool_Offset|WKZ_Offset|VOFFSET|INC)\b", re.I)
# A position, `P[n]{` (a comment may follow n), and its body when in the usual form, read in
# the same match: GP1 first, its UF, UT, CONFIG, X, Y, Z (mm), W, P, R (deg) once each in that
# order, extended axes (E1 = ... mm) after, then `};` or the other groups. No '}' before the
# `};` (the first closes it), no '{' (no position starts inside) and no ':' in CONFIG (no group
# starts inside): what it reads, the field scan (`_fields`) reads the same; other bodies are
# left to that scan.
_SP, _NL = r"[ \t]*", r"[ \t\r\n]*"
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_POS = re.compile(
    r"^[ \t]*P\[(?P<n>\d+)(?::[^\]]*)?\][ \t]*\{(?P<body>)(?:"
    rf"{_NL}GP1{_SP}:{_NL}UF{_SP}:{_SP}(?P<UF>\d+){_SP},{_NL}UT{_SP}:{_SP}(?P<UT>\d+){_SP},"
    rf"{_NL}(?:CONFIG|KONFIG){_SP}:{_SP}'(?P<CONFIG>[^'\n:{{}}]*)'{_SP}," +
    "".join(rf"{_NL}{k}{_SP}={_SP}(?P<{k}>{_NUMBER}){_SP}{unit}{_SP}" + ("," if k != "R" else "")
            for k, unit in (("X", "mm"), ("Y", "mm"), ("Z", "mm"), ("W", "deg"), ("P", "deg"),
                            ("R", "deg"))) +
    rf"(?:,{_NL}E\d+{_SP}={_SP}{_NUMBER}{_SP}(?:mm|deg){_SP})*{_NL}(?:GP\d+{_SP}:[^{{}}]*)?\}};"
    r")?", re.M)
_POSE = ("X", "Y", "Z", "W", "P", "R")


def read_frames(path: str, text: str, program: Program) -> None:
    """User and tool frames from a frames file: `UF,n,x,y,z,w,p,r` and `UT,n,...` (mm, deg;
    '#' starts a comment)."""
    for k, raw in enumerate(text.splitlines(), 1):
        row = raw.split("#", 1)[0].strip()
        if not row:
            continue
        parts = [p.strip() for p in row.split(",")]
        if len(parts) != 8 or parts[0].upper() not in ("UF", "UT") or not parts[1].isdigit():
            raise ProgramSyntaxError(path, k, "expected 'UF,n,x,y,z,w,p,r' or 'UT,n,x,y,z,w,p,"
                                     f"r' (mm, deg), got {row[:60]!r}")
        try:
            values = tuple(float(v) for v in parts[2:])
        except ValueError:
            raise ProgramSyntaxError(path, k, "the six values must be numbers (mm, deg)") \
                from None
        store = program.frames if parts[0].upper() == "UF" else program.tools
        store[f"{parts[0].upper()}[{int(parts[1])}]"] = Frame(values)


def read_ls(path: str, text: str, program: Program) -> None:
    """The positions and motions of one LS file into `program`."""
    section = _SECTION_POS.search(text)
    pos_at = section.start() if section is not None else -1
    positions: dict[int, Target] = {}
    line, counted = 1, 0  # the line of offset `counted`, counted on as the positions come
    for m in _POS.finditer(text, max(pos_at, 0)) if pos_at >= 0 else ():
        start = m.end("body")
        end = m.end() - 2 if m["X"] is not None else text.find("};", start)
        if end < 0:
            raise ProgramSyntaxError(path, _line(text, m.start()), "a position's '{' is never "
                                     "closed by '};'")
        line += text.count("\n", counted, start)
        counted = start
        target = _position(path, text, m, end, line, program)
        if target is not None:
            positions[int(m["n"])] = target
            program.targets.append(target)
    used_inc: set[int] = set()
    # The motions start before /POS; the last may end at the first ';' after it: the search
    # stops there, not at the end of the positions.
    last_end = text.find(";", pos_at) + 1 if pos_at >= 0 else 0
    for m in _MOTION.finditer(text, 0, last_end or len(text)):
        if pos_at >= 0 and m.start() > pos_at:
            break
        body = m.group(2)
        if _NOTABLE.search(body) is None:  # to a P[n] as it is: nothing to note
            continue
        line = _line(text, m.start())
        offset = _OFFSETS.search(body)
        inc = offset is not None and offset.group(1).upper() == "INC"
        for ref in _REF.finditer(body):
            if ref.group(1).upper() == "PR":
                if offset is None or ref.start() < offset.start():  # the motion's own target
                    program.notes.append(Note(path, line, ref.group(0), "a position register: "
                                              "its value lives in the controller"))
            elif inc:
                used_inc.add(int(ref.group(2)))
        if offset is not None and not inc:
            program.notes.append(Note(path, line, offset.group(1), "an offset applied when the "
                                      "program runs, in the nominal frame"))
    for n in used_inc:
        if n in positions:
            positions[n].problem = "used with INC: an increment from where the robot stands"


def _fields(text: str, a: int, b: int) -> dict[str, re.Match[str]]:
    """The fields in text[a:b] by upper-case name (the last of a name wins)."""
    out: dict[str, re.Match[str]] = {}
    at = a
    while True:
        m = _FIELD_WORD.search(text, at, b)
        if m is None:
            return out
        name = m.group(1).upper()
        start = m.start()
        if (name in _FIELD_NAMES or (len(name) == 2 and name[0] == "J" and
                                     name[1].isdecimal())) and \
                not (start and _WORD_CHAR.match(text, start - 1)):
            out[name] = m
            at = m.end()
        else:
            at = start + 1


def _position(path: str, text: str, m: re.Match[str], end: int, line: int, program: Program
              ) -> Target | None:
    """The GP1 Cartesian position `m` (`_POS`) found, its body up to `end` (on `line`), or
    None for joints."""
    name = f"P[{int(m['n'])}]"
    if m["X"] is not None:  # the usual form, read whole
        target = Target(path, line, name, tuple(map(float, m.group(*_POSE))),
                        (m.span("X"), m.span("Y"), m.span("Z"), m.span("W"), m.span("P"),
                         m.span("R")), flags={"CONFIG": Flag("CONFIG", m["CONFIG"],
                                                             m.span("CONFIG"))})
        _frames(target, m["UF"], m["UT"], program)
        return target
    start = body_start = m.end("body")
    groups = list(_GROUP.finditer(text, start, end))
    if groups:
        gp1 = [g for g in groups if g.group(1) == "1"]
        if not gp1:
            return None
        body_start = gp1[0].end()
        later = [g.start() for g in groups if g.start() > body_start]
        end = min(later) if later else end
    fields = _fields(text, body_start, end)
    if "J1" in fields:
        program.joint_targets += 1
        return None
    missing = [k for k in _POSE if k not in fields]
    if missing:
        found = sorted(set(re.findall(r"\b([A-Z]{1,3})[ \t]*=", text[body_start:end])))
        return Target(path, line, name, (), (), problem="its coordinates are not X, Y, Z, W, P, "
                      f"R (found {', '.join(found) or 'none'}): a form this filter does not read")
    if any(fields[k].group(2).startswith("*") for k in _POSE):
        return Target(path, line, name, (), (), problem="not taught (its values are ********)")
    values = tuple(float(fields[k].group(2)) for k in _POSE)
    spans = tuple(fields[k].span(2) for k in _POSE)
    flags = {}
    c = fields.get("CONFIG", fields.get("KONFIG"))
    if c is not None:
        flags["CONFIG"] = Flag("CONFIG", c.group(2)[1:-1], (c.start(2) + 1, c.end(2) - 1))
    target = Target(path, line, name, values, spans, flags=flags)
    _frames(target, fields["UF"].group(2) if "UF" in fields else "0",
            fields["UT"].group(2) if "UT" in fields else "0", program)
    return target


def _frames(target: Target, uf: str, ut: str, program: Program) -> None:
    """The user frame and the tool frame a position names (as written), into the target and,
    when not yet there, the program's frames and tools."""
    if uf == ut == "0":  # the world and the faceplate
        return
    for key, raw, store, kind in (("UF", uf, program.frames, "user frame"),
                                  ("UT", ut, program.tools, "tool frame")):
        if not raw.isdigit():
            target.problem = f"its {kind} is {raw!r}: not a frame number"
        elif int(raw):
            k = f"{key}[{int(raw)}]"
            store.setdefault(k, Frame(None, f"{key} {int(raw)} is not in the frames file "
                                      "given (--frames)"))
            if key == "UF":
                target.frame = k
            else:
                target.tool = k
