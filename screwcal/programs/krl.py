"""KUKA KRL programs: the `.dat` declarations, the `.src` motions and `$config.dat`'s tools and
bases, read into a `Program`.

Targets: `E6POS`, `POS` and `FRAME` aggregates (`{X 1000.0,Y 0.0,Z 1200.0,A 0.0,B 90.0,C 0.0,S
2,T 35,E1 0.0}`: mm; A, B, C deg about Z, Y', X''; S and T the branch) declared in a `.dat` or
`.src` (`DECL` and `GLOBAL` optional, arrays and their elements), and inline in a motion
(`PTP {X ...}`). `E6AXIS` / `AXIS` targets are joints: left as they are.

The tool and base of a target: the inline form's fold (`;FOLD PTP P1 ... Tool[1] Base[0]`), else
its motion data (`FDAT_ACT=FP1`, `DECL FDAT FP1={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE}`), else
the last `$TOOL=` / `$BASE=` (or `BAS(#TOOL,n)`) before the motion in the file. Tool 0 is the
flange, base 0 the world (`$ROBROOT` taken as the world: the robot base the calibration used).

Not compensated, listed with the line: the geometric operator (`P1:{X 10}`), relative motions
(`PTP_REL`, `LIN_REL`), a target assigned at run time, a partial aggregate (the missing
components come from the current position), an external TCP (`IPO_FRAME #TCP`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import NamedTuple

from screwcal.programs.program import Flag, Frame, Note, Program, ProgramSyntaxError, Target
from screwcal.programs.program import line_of as _line

POSE_KEYS = ("X", "Y", "Z", "A", "B", "C")
_POSE_TYPES = {"E6POS", "POS", "FRAME"}
_AXIS_TYPES = {"E6AXIS", "AXIS"}
_MOTION_DATA = {"FDAT"}

_DECL = re.compile(r"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?(?:DECL[ \t]+)?([A-Za-z_]\w*)"
                   r"[ \t]+([$A-Za-z_]\w*)(\[[^\]]*\])?[ \t]*=[ \t]*\{", re.I | re.M)
_ARRAY = re.compile(r"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?(E6POS|POS|FRAME)[ \t]+"
                    r"([A-Za-z_]\w*)[ \t]*\[", re.I | re.M)
_ELEMENT = re.compile(r"^[ \t]*([A-Za-z_]\w*)\[([\d, ]+)\][ \t]*=[ \t]*\{", re.I | re.M)
_MOTION = re.compile(r"^[ \t]*(PTP|LIN|CIRC|SPTP|SLIN|SCIRC|SPL|PTP_REL|LIN_REL|"
                     r"CIRC_REL|SPTP_REL|SLIN_REL|SCIRC_REL)[ \t]+([^;\n]*)", re.I | re.M)
_TOOL_SET = re.compile(r"^[ \t]*(?:\$TOOL[ \t]*=[ \t]*(\S[^;\n]*)|BAS[ \t]*\([ \t]*#TOOL[ \t]*,"
                       r"[ \t]*(\d+)[ \t]*\))", re.I | re.M)
_BASE_SET = re.compile(r"^[ \t]*(?:\$BASE[ \t]*=[ \t]*(\S[^;\n]*)|BAS[ \t]*\([ \t]*#BASE[ \t]*,"
                       r"[ \t]*(\d+)[ \t]*\))", re.I | re.M)
_FDAT_ACT = re.compile(r"^[ \t]*FDAT_ACT[ \t]*=[ \t]*(\w+)", re.I | re.M)
_FOLD = re.compile(r"^[ \t]*;FOLD[ \t]+(?:S?PTP|S?LIN|S?CIRC|SPL)\b[^\n]*", re.I | re.M)
_FOLD_TOOL = re.compile(r"\bTool\[(\d+)\]", re.I)
_FOLD_BASE = re.compile(r"\bBase\[(\d+)\]", re.I)
_TYPED = re.compile(r"[ \t]*[A-Za-z_]\w*[ \t]*:(?!:)")
_AXES = re.compile(r"[{,:][ \t]*A[1-6][ \t]", re.I)
_CARTESIAN = re.compile(r"[{,:][ \t]*X[ \t]", re.I)
_AGGREGATE_CHARS = re.compile(r'["{},]')
_ITEM = re.compile(r"\s*([$A-Za-z_]\w*(?:\[\])?)\s+")
# The form a controller writes, {X 1000.0,Y 0.0,Z 1200.0,A 0.0,B 90.0,C 0.0,S 2,T 35,E1 0.0}:
# read in one match (the general scan reads every other form the same way)
_VALUE = r"\s+([^\s,{}\"]+)\s*"
_CANONICAL = re.compile(r"\{\s*" + r",\s*".join(k + _VALUE for k in POSE_KEYS) +
                        r"(?:,\s*S" + _VALUE + r",\s*T" + _VALUE + r")?"
                        r"(?:,\s*E[1-6]\s+[^\s,{}\"]+\s*)*\}", re.I)
_ASSIGN = re.compile(r"^[ \t]*([A-Za-z_]\w*)(?:\[[^\]]*\])?(?:\.[A-Za-z]\w*)?[ \t]*=(?!=)",
                     re.M)


class _Item(NamedTuple):  # (a tuple: 90,000 of them in a program of 10,000 targets)
    text: str
    span: tuple[int, int]


def _aggregate(path: str, text: str, start: int) -> tuple[dict[str, _Item], int]:
    """The items of the aggregate opening at text[start] == '{' (nested ones as raw text), and
    the offset after its '}'. The scan jumps from one of `"{},` to the next."""
    items: dict[str, _Item] = {}
    i, depth, item_start = start + 1, 1, start + 1
    typed = _TYPED.match(text, start + 1)  # {FRAME: X 0.0, ...}: the type named first
    if typed:
        i = item_start = typed.end()
    close = text.find("}", i)
    if close >= 0:
        body = text[i:close]
        if "{" not in body and '"' not in body:  # flat, as most are: its commas split it
            for piece in body.split(","):
                _item(piece, 0, len(piece), items, i)
                i += len(piece) + 1
            return items, close + 1
    skip_to = i  # past a string: its characters are its own
    for found in _AGGREGATE_CHARS.finditer(text, i):
        i = found.start()
        if i < skip_to:
            continue
        c = text[i]
        if c == '"':
            skip_to = text.find('"', i + 1) + 1
            if skip_to == 0:
                raise ProgramSyntaxError(path, _line(text, start), "a string is never closed")
        elif c == "{":
            depth += 1
        elif c == "}" or depth == 1:  # a '}', or a ',' between two items
            if depth == 1:
                _item(text, item_start, i, items)
                item_start = i + 1
            if c == "}":
                depth -= 1
                if depth == 0:
                    return items, i + 1
    raise ProgramSyntaxError(path, _line(text, start), "an aggregate '{' is never closed by "
                             "'}'")


def _item(text: str, a: int, b: int, items: dict[str, _Item], offset: int = 0) -> None:
    """The item in text[a:b] ('X 1000.0'), its value's span `offset` on in the file."""
    m = _ITEM.match(text, a, b)
    if not m:
        return
    value_start = m.end()
    value = text[value_start:b].rstrip()
    value_start += offset
    items[m.group(1).upper()] = _Item(value, (value_start, value_start + len(value)))


def _frame_of(items: dict[str, _Item]) -> Frame:
    if not all(k in items for k in POSE_KEYS):
        missing = [k for k in POSE_KEYS if k not in items]
        return Frame(None, f"a partial frame (no {', '.join(missing)})")
    try:
        values = tuple(float(items[k].text) for k in POSE_KEYS)
    except ValueError:
        return Frame(None, "a component of the frame is not a number")
    return Frame(values)


def read_config(path: str, text: str, program: Program) -> None:
    """The tools and bases `$config.dat` declares (`TOOL_DATA[n]`, `BASE_DATA[n]`), and its
    global joint targets (`DECL GLOBAL E6AXIS XHOME`)."""
    program.joint_names.update(m.group(2).upper() for m in _DECL.finditer(text)
                               if m.group(1).upper() in _AXIS_TYPES)
    for m in _ELEMENT.finditer(text):
        name = m.group(1).upper()
        if name not in ("TOOL_DATA", "BASE_DATA"):
            continue
        items, _ = _aggregate(path, text, m.end() - 1)
        key = f"{name}[{int(m.group(2))}]"
        (program.tools if name == "TOOL_DATA" else program.frames)[key] = _frame_of(items)


def _target(path: str, text: str, name: str, brace: int, kind: str) -> Target:
    canonical = _CANONICAL.match(text, brace)
    if canonical:
        try:
            values = tuple(map(float, canonical.group(1, 2, 3, 4, 5, 6)))
        except ValueError:
            pass  # an expression: the general reading says so
        else:
            flags = {} if canonical.start(7) < 0 else {
                "S": Flag("S", canonical[7], canonical.span(7)),
                "T": Flag("T", canonical[8], canonical.span(8))}
            return Target(path, _line(text, brace), name, values,
                          tuple(map(canonical.span, range(1, 7))), flags=flags)
    items, _ = _aggregate(path, text, brace)
    line = _line(text, brace)
    missing = [k for k in POSE_KEYS if k not in items]
    values = ()
    problem = ""
    if missing:
        problem = (f"a partial {kind} (no {', '.join(missing)}): the missing components come "
                   "from the robot's position when it runs")
    else:
        try:
            values = tuple(float(items[k].text) for k in POSE_KEYS)
        except ValueError:
            problem = "a component is an expression, computed when the program runs"
    flags = {k: Flag(k, items[k].text, items[k].span) for k in ("S", "T") if k in items}
    spans = tuple(items[k].span for k in POSE_KEYS) if not missing else ()
    return Target(path, line, name, values, spans, flags=flags, problem=problem)


def read_krl(files: dict[str, str], program: Program) -> None:
    """Every target of the `.dat` and `.src` texts (by path) into `program`."""
    declared: dict[str, Target] = {}  # by upper-case name (array elements with their index)
    fdat: dict[str, dict[str, _Item]] = {}
    arrays: set[str] = set()
    axes = set(program.joint_names)  # E6AXIS / AXIS names: joints, nothing to compensate
    for path, text in files.items():
        _declarations(path, text, program, declared, fdat, arrays, axes)
    for path, text in files.items():
        _motions(path, text, program, declared, fdat, axes)
    program.targets.sort(key=lambda t: (t.path, t.line))


def _declarations(path: str, text: str, program: Program, declared: dict[str, Target],
                  fdat: dict[str, dict[str, _Item]], arrays: set[str], axes: set[str]) -> None:
    for m in _DECL.finditer(text):
        kind, name = m.group(1).upper(), m.group(2).upper()
        if kind in _AXIS_TYPES:
            program.joint_targets += 1
            axes.add(name)
        elif kind in _MOTION_DATA:
            fdat[name] = _aggregate(path, text, m.end() - 1)[0]
        elif kind in _POSE_TYPES:
            if m.group(3):
                arrays.add(name)
            t = _target(path, text, m.group(2), m.end() - 1, kind)
            declared[name] = t
            program.targets.append(t)
    arrays.update(m.group(2).upper() for m in _ARRAY.finditer(text))
    for m in _ELEMENT.finditer(text):
        name = m.group(1).upper()
        if name not in arrays:
            continue
        index = ",".join(p.strip() for p in m.group(2).split(","))
        t = _target(path, text, f"{m.group(1)}[{index}]", m.end() - 1, "E6POS")
        declared[f"{name}[{index}]"] = t
        program.targets.append(t)


@dataclass
class _State:
    tool: str | None = None
    base: str | None = None


def _motions(path: str, text: str, program: Program, declared: dict[str, Target],
             fdat: dict[str, dict[str, _Item]], axes: set[str]) -> None:
    """Bind each target a motion names to the tool and base in effect there; note what a
    static filter cannot compensate."""
    events = sorted([(m.start(), "tool", m) for m in _TOOL_SET.finditer(text)] +
                    [(m.start(), "base", m) for m in _BASE_SET.finditer(text)] +
                    [(m.start(), "fdat", m) for m in _FDAT_ACT.finditer(text)] +
                    [(m.start(), "fold", m) for m in _FOLD.finditer(text)] +
                    [(m.start(), "move", m) for m in _MOTION.finditer(text)],
                    key=lambda e: e[0])
    state, fold, active_fdat = _State(), _State(), ""
    uses: dict[str, set[tuple[str | None, str | None]]] = {}
    for offset, kind, m in events:
        line = _line(text, offset)
        if kind in ("tool", "base"):
            key = _frame_key(path, line, kind, m, program)
            setattr(state, kind, key)
        elif kind == "fdat":
            active_fdat = m.group(1).upper()
        elif kind == "fold":
            tm, bm = _FOLD_TOOL.search(m.group(0)), _FOLD_BASE.search(m.group(0))
            fold = _State(_key("TOOL_DATA", tm.group(1)) if tm else None,
                          _key("BASE_DATA", bm.group(1)) if bm else None)
            if not tm and not bm:
                fold = _State()
        else:
            binding = _binding(state, fold, fdat.get(active_fdat), program, path, line)
            _motion(path, text, line, m, binding, program, declared, uses, axes)
            fold, active_fdat = _State(), ""
    _runtime_assignments(path, text, program, declared)
    for name, combos in uses.items():
        t = declared[name]
        if len(combos) > 1:
            t.problem = t.problem or ("used with several tools or bases: one static value "
                                      "cannot serve them all")
        else:
            (t.tool, t.frame), = combos


def _key(kind: str, number: str) -> str | None:
    return None if int(number) == 0 else f"{kind}[{int(number)}]"


def _frame_key(path: str, line: int, kind: str, m: re.Match[str], program: Program
               ) -> str | None:
    """The key of what a $TOOL/$BASE assignment or BAS call sets (None: flange / world)."""
    store = program.tools if kind == "tool" else program.frames
    data = "TOOL_DATA" if kind == "tool" else "BASE_DATA"
    if m.group(2) is not None:
        return _key(data, m.group(2))
    value = m.group(1).strip()
    indexed = re.fullmatch(rf"{data}\[(\d+)\]", value, re.I)
    if indexed:
        return _key(data, indexed.group(1))
    if value.upper() in ("$NULLFRAME", "$WORLD"):
        return None
    key = f"{path}:{line}:${kind.upper()}"
    if value.startswith("{"):
        store[key] = _frame_of(_aggregate(path, m.string, m.start(1))[0])
    else:
        store[key] = Frame(None, f"${kind.upper()} := {value[:30]}: computed when the program "
                           "runs")
    return key


def _binding(state: _State, fold: _State, fd: dict[str, _Item] | None, program: Program,
             path: str, line: int) -> tuple[str | None, str | None]:
    if fd is not None:
        ipo = fd.get("IPO_FRAME")
        if ipo is not None and ipo.text.upper() == "#TCP":
            key = f"{path}:{line}:external"
            program.tools[key] = Frame(None, "an external (stationary) TCP, IPO_FRAME #TCP: "
                                       "the robot holds the work piece")
            return key, None
        tool = _key("TOOL_DATA", fd["TOOL_NO"].text) if "TOOL_NO" in fd else state.tool
        base = _key("BASE_DATA", fd["BASE_NO"].text) if "BASE_NO" in fd else state.base
        return tool, base
    if fold.tool is not None or fold.base is not None:
        return fold.tool, fold.base
    return state.tool, state.base


def _motion(path: str, text: str, line: int, m: re.Match[str],
            binding: tuple[str | None, str | None], program: Program,
            declared: dict[str, Target], uses: dict[str, set[tuple[str | None, str | None]]],
            axes: set[str]) -> None:
    verb, args = m.group(1).upper(), m.group(2)
    if verb.endswith("_REL"):
        program.notes.append(Note(path, line, verb, "a relative motion: an offset from where "
                                  "the robot stands, not a pose; applied in the nominal frame"))
        return
    for arg, start in _arguments(args, m.start(2), 2 if verb in ("CIRC", "SCIRC") else 1):
        if arg.startswith("{") and _AXES.search(arg) and not _CARTESIAN.search(arg):
            program.joint_targets += 1  # {A1 0, A2 -90, ...}: joints, as the controller's
        elif arg.startswith("{"):
            t = _target(path, text, f"{verb} inline", start, "inline target")
            t.tool, t.frame = binding
            program.targets.append(t)
        elif ":" in arg:
            program.notes.append(Note(path, line, arg[:40], "computed with the geometric "
                                      "operator ':' when the program runs"))
        else:
            name = arg.upper().replace(" ", "")
            if name in declared:
                uses.setdefault(name, set()).add(binding)
            elif name in axes or name.split("[")[0] in axes:
                continue
            elif name not in ("$POS_ACT", "$AXIS_ACT") and re.fullmatch(r"[$\w\[\],]+", name):
                program.notes.append(Note(path, line, arg[:40], "not declared in the files "
                                          "given (give its .dat too), or computed at run time"))


def _arguments(args: str, offset: int, count: int) -> list[tuple[str, int]]:
    """The first `count` comma-separated arguments of a motion (braces kept whole), with the
    offset of each in the text."""
    if "{" not in args and "}" not in args:  # names only (PTP XP1): the commas split them
        plain: list[tuple[str, int]] = []
        at = 0
        for raw in args.split(","):
            stripped = raw.strip()
            if stripped:
                plain.append((stripped.split()[0], offset + at + len(raw) - len(raw.lstrip())))
                if len(plain) == count:
                    break
            at += len(raw) + 1
        return plain
    out, depth, start = [], 0, 0
    for i, c in enumerate(args + ","):
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
        elif c == "," and depth == 0:
            raw = args[start:i]
            stripped = raw.strip()
            if stripped:
                out.append((stripped if "{" in stripped else stripped.split()[0],
                            offset + start + len(raw) - len(raw.lstrip())))
            start = i + 1
            if len(out) == count:
                break
    return out


def _runtime_assignments(path: str, text: str, program: Program,
                         declared: dict[str, Target]) -> None:
    """A declared target assigned in a .src (XP1 = ..., XP1.X = ...) changes at run time."""
    if not path.lower().endswith(".src"):
        return
    for m in _ASSIGN.finditer(text):
        name = m.group(1).upper()
        if name in declared and not text[m.start():m.end()].lstrip().upper().startswith("DECL"):
            t = declared[name]
            t.problem = t.problem or (f"assigned when the program runs ({path}:"
                                      f"{_line(text, m.start())})")
