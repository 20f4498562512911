"""URScript programs: pose literals `p[x, y, z, rx, ry, rz]` (m; a rotation vector in rad) in
motions and pose variables, read into a `Program`.

Targets: a literal as the pose of `movel`, `movej`, `movep`, `movec` (its via and end points)
or of `get_inverse_kin` inside one; a pose variable assigned a literal once (`p1 = p[...]`) and
named by a motion; the second pose of `pose_trans(feature, p[...])` where the feature is a
literal or a variable assigned one (the target is then in that feature's frame). The tool: the
last `set_tcp(p[...])` before the motion in the file (else the flange: the installation's TCP
is not in the program). Joint targets (`movej([...])`) are left as they are.

Not compensated, listed with the line: motions to poses computed by `pose_add`, `pose_sub`,
`pose_trans` of computed operands, `interpolate_pose` and the like; variables assigned more than
once or from an expression; a TCP set from an expression.
"""

from __future__ import annotations

import re

from screwcal.programs.program import Frame, Note, Program, Target
from screwcal.programs.program import line_of as _line

# A motion or a TCP (a word of its own: `_WORD` not before it, checked after the match, as a
# leading \b would keep the search from skipping to the words' first letters).
_EVENT = re.compile(r"(movel|movej|movep|movec|set_tcp)[ \t]*\(")
_WORD = re.compile(r"\w")
_VAR = re.compile(r"^[ \t]*(?:global[ \t]+|local[ \t]+)?([A-Za-z_]\w*)[ \t]*=(?!=)[ \t]*",
                  re.M)
_NAME = re.compile(r"[A-Za-z_]\w*")
_BLANKED = re.compile(r"#[^\n]*|\"[^\"]*(?:\"|\Z)|'[^']*(?:'|\Z)")
_NOT_NEWLINE = re.compile(r"[^\n]")
_BRACKETS = {"()": re.compile(r"[()]"), "[]": re.compile(r"[\[\]]")}
_SEPARATORS = re.compile(r"[()\[\],]")
_BRACKET_IN = re.compile(r"[()\[\]]")
_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
# The usual pose literal, read in one match: six numbers on its line, nothing else in it (what
# `_close` and `_split` read the same); anything else is left to them.
_POSE = re.compile(r"p\[[ \t]*" + r"[ \t]*,[ \t]*".join([f"({_NUM.pattern})"] * 6) + r"[ \t]*\]")
# A motion's first argument when it is a literal without brackets inside, followed by the next
# argument or ')' (what `_close` and `_split` find the same).
_FIRST_LITERAL = re.compile(r"[ \t]*(p\[[^\[\]()]*\])[ \t]*[,)]")


def _code(text: str) -> str:
    """The text with comments and strings blanked (offsets kept): a comment whole, a string's
    inside but its newlines (a string never closed: up to the text's last character)."""
    return _BLANKED.sub(_blank, text)


def _blank(m: re.Match[str]) -> str:
    s = m.group()
    if s[0] == "#":
        return " " * len(s)
    if len(s) < 2:
        return s
    return s[0] + _NOT_NEWLINE.sub(" ", s[1:-1]) + s[-1]


def _close(code: str, open_at: int, pair: str = "()") -> int:
    """The offset of the bracket closing the one at open_at."""
    depth = 0
    for m in _BRACKETS[pair].finditer(code, open_at):
        if m.group() == pair[0]:
            depth += 1
        else:
            depth -= 1
            if depth == 0:
                return m.start()
    return len(code)


def _split(code: str, a: int, b: int) -> list[tuple[int, int]]:
    """Top-level comma-separated spans of code[a:b], stripped (none after an unclosed
    bracket)."""
    piece = code[a:b]
    if not _BRACKET_IN.search(piece):  # no brackets (a pose literal's numbers): its commas
        out, start = [], a
        for part in piece.split(","):
            kept = part.strip()
            if kept:
                lead = start + len(part) - len(part.lstrip())
                out.append((lead, lead + len(kept)))
            else:
                out.append((start + len(part), start + len(part)))
            start += len(part) + 1
        return out
    out, depth, start = [], 0, a
    for m in _SEPARATORS.finditer(code, a, b):
        c = m.group()
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif depth == 0:
            out.append(_stripped(code, start, m.start()))
            start = m.end()
    if depth == 0:
        out.append(_stripped(code, start, b))
    return out


def _stripped(code: str, s: int, e: int) -> tuple[int, int]:
    """The span code[s:e] without its leading and trailing white space."""
    piece = code[s:e]
    kept = piece.strip()
    if not kept:
        return e, e
    lead = len(piece) - len(piece.lstrip())
    return s + lead, s + lead + len(kept)


def _literal(path: str, text: str, code: str, at: int, name: str) -> Target:
    """The pose literal whose 'p[' starts at `at`."""
    usual = _POSE.match(code, at)
    if usual is not None:
        return Target(path, _line(text, at), name, tuple(map(float, usual.groups())),
                      (usual.span(1), usual.span(2), usual.span(3), usual.span(4),
                       usual.span(5), usual.span(6)))
    open_at = at + 1
    close = _close(code, open_at, "[]")
    parts = _split(code, open_at + 1, close)
    line = _line(text, at)
    if len(parts) != 6:
        return Target(path, line, name, (), (), problem=f"a pose of {len(parts)} numbers, not 6")
    if not all(_NUM.fullmatch(code[s:e]) for s, e in parts):
        return Target(path, line, name, (), (), problem="a number of the pose is an expression, "
                      "computed when the program runs")
    return Target(path, line, name, tuple(float(code[s:e]) for s, e in parts), tuple(parts))


def read_urscript(path: str, text: str, program: Program) -> None:
    """The targets of one URScript file into `program`."""
    code = _code(text)
    variables: dict[str, Target] = {}
    assigned: dict[str, int] = {}
    for m in _VAR.finditer(code):
        name = m.group(1)
        assigned[name] = assigned.get(name, 0) + 1
        if code.startswith("p[", m.end()):
            variables[name] = _literal(path, text, code, m.end(), name)
    for name, count in assigned.items():
        if count > 1 and name in variables:
            variables[name].problem = f"assigned {count} times: its value depends on the run"
    tool: str | None = None
    uses: dict[str, set[tuple[str | None, str | None]]] = {}
    for m in _EVENT.finditer(code):
        if m.start() and _WORD.match(code, m.start() - 1):
            continue
        verb = m.group(1)
        # one argument read (the pose; set_tcp's TCP) unless movec's two
        first = _FIRST_LITERAL.match(code, m.end()) if verb != "movec" else None
        args = [first.span(1)] if first is not None else \
            _split(code, m.end(), _close(code, m.end() - 1))
        if verb == "set_tcp":
            tool = _tcp(path, text, code, _line(text, m.start()), args, variables, program)
            continue
        for s, e in args[:2 if verb == "movec" else 1]:
            _pose_argument(path, text, code, s, e, verb, tool, variables, program, uses)
    for name, combos in uses.items():
        t = variables[name]
        if len(combos) > 1:
            t.problem = t.problem or "used with several TCPs or features: one value cannot " \
                "serve them all"
        else:
            (t.tool, t.frame), = combos
        program.targets.append(t)
    program.targets.sort(key=lambda t: (t.path, t.line))


def _tcp(path: str, text: str, code: str, line: int, args: list[tuple[int, int]],
         variables: dict[str, Target], program: Program) -> str | None:
    key = f"{path}:{line}:tcp"
    arg = code[args[0][0]:args[0][1]] if args else ""
    source = variables.get(arg) if _NAME.fullmatch(arg) else \
        _literal(path, text, code, args[0][0], "set_tcp") if arg.startswith("p[") else None
    if source is None or source.problem or len(source.values) != 6:
        why = source.problem if source is not None and source.problem else \
            f"set_tcp({arg[:30]}): computed when the program runs"
        program.tools[key] = Frame(None, why)
    else:
        program.tools[key] = Frame(source.values)
    return key


def _pose_argument(path: str, text: str, code: str, s: int, e: int, verb: str,
                   tool: str | None, variables: dict[str, Target], program: Program,
                   uses: dict[str, set[tuple[str | None, str | None]]]) -> None:
    arg = code[s:e]
    if arg.startswith("["):
        program.joint_targets += 1
    elif arg.startswith("p["):
        t = _literal(path, text, code, s, f"{verb} pose")
        t.tool = tool
        program.targets.append(t)
    elif _NAME.fullmatch(arg) and arg in variables:
        uses.setdefault(arg, set()).add((tool, None))
    elif arg.startswith("get_inverse_kin(") and code.startswith("p[", s + 16):
        t = _literal(path, text, code, s + 16, f"{verb} pose")
        t.tool = tool
        program.targets.append(t)
    elif arg.startswith("pose_trans("):
        _feature_target(path, text, code, s, verb, tool, variables, program, uses)
    else:
        program.notes.append(Note(path, _line(text, s), arg[:40], "computed when the program "
                                  "runs"))


def _feature_target(path: str, text: str, code: str, s: int, verb: str, tool: str | None,
                    variables: dict[str, Target], program: Program,
                    uses: dict[str, set[tuple[str | None, str | None]]]) -> None:
    """pose_trans(feature, pose): the pose in the feature's frame, both literals (or
    variables assigned one); anything else is noted."""
    open_at = s + len("pose_trans")
    parts = _split(code, open_at + 1, _close(code, open_at))
    line = _line(text, s)
    if len(parts) != 2:
        program.notes.append(Note(path, line, "pose_trans", "computed when the program runs"))
        return
    (fs, fe), (ps, pe) = parts
    feature, pose = code[fs:fe], code[ps:pe]
    key = f"{path}:{line}:feature"
    ft: Target | None
    if feature.startswith("p["):
        ft = _literal(path, text, code, fs, "feature")
    else:
        ft = variables.get(feature) if _NAME.fullmatch(feature) else None
    if ft is None or ft.problem or not ft.values:
        program.notes.append(Note(path, line, f"pose_trans({feature[:20]}, ...)",
                                  "its frame is computed when the program runs"))
        return
    program.frames[key] = Frame(ft.values)
    if pose.startswith("p["):
        t = _literal(path, text, code, ps, f"{verb} pose")
        t.tool, t.frame = tool, key
        program.targets.append(t)
    elif _NAME.fullmatch(pose) and pose in variables:
        uses.setdefault(pose, set()).add((tool, key))
    else:
        program.notes.append(Note(path, line, pose[:40], "computed when the program runs"))
