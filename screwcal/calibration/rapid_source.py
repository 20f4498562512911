"""Reading a RAPID module's source as far as a static filter needs: the declarations of
`robtarget`, `tooldata` and `wobjdata` data (CONST, PERS, VAR, with LOCAL or TASK, arrays,
values over several lines, comments between them), every number of their values with its place
in the text (so that a rewrite changes those characters and nothing else), and the motion
instructions that use them (which tool and work object each target is reached with).

No RAPID is executed: what only the running program knows (a target computed with `Offs`,
`RelTool`, `CRobT`, a value assigned at run time) is reported as such, with its line.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

from screwcal.errors import DataFileError

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
DECLARATION = re.compile(
    r"^[ \t]*(?:(?:LOCAL|TASK)[ \t]+)?(?:CONST|PERS|VAR)[ \t]+(robtarget|tooldata|wobjdata)"
    r"[ \t]+([A-Za-z]\w*)[ \t]*(\{[^}]*\})?[ \t]*(:=)?", re.M | re.I)
# Motion instructions whose first positional argument (two for the circular ones) is a
# robtarget and whose last positional argument is the tool.
MOTION = re.compile(
    r"\b(Move(?:J|L|C)(?:DO|AO|GO|Sync)?|Trigg(?:J|L|C))\b([^;]*);", re.I)
_END = re.compile(r"\s*;")
_N = rf"\s*({NUMBER.pattern})\s*"
# One plain robtarget value, whitespace (and blanked comments) anywhere: the common case,
# matched in one go; anything else goes through the general parser.
_ROBTARGET = re.compile(rf"\s*\[\s*\[{_N},{_N},{_N}\]\s*,\s*\[{_N},{_N},{_N},{_N}\]\s*,"
                        rf"\s*\[{_N},{_N},{_N},{_N}\]\s*,\s*\[([^\[\]]*)\]\s*\]")
# A module's first statement (comments and blank lines before it; a UTF-8 byte-order mark as
# read in latin-1 too): `MODULE name` with optional attributes in parentheses
MODULE_HEADER = re.compile(r"\A(?:\xef\xbb\xbf|\ufeff)?\s*MODULE[ \t]+[A-Za-z]\w*", re.I)
RUNTIME_TARGETS = re.compile(r"\b(Offs|RelTool|CRobT|CalcRobT|MirPos)\s*\(", re.I)


class Token(NamedTuple):
    """A number (or TRUE/FALSE, or a string) of a value, and where it is in the text (a tuple:
    a module holds hundreds of thousands)."""

    text: str
    start: int
    end: int

    @property
    def number(self) -> float:
        return float(self.text)


Aggregate = list  # nested lists of Token
# A Token from a (text, start, end) tuple without NamedTuple's Python-level __new__: a module
# of 10,000 targets holds 170,000 of them.
_token = partial(tuple.__new__, Token)


@dataclass
class Declaration:
    kind: str  # robtarget, tooldata, wobjdata (lower case)
    name: str
    line: int
    value: Aggregate | None  # None: declared without a value


@dataclass
class Motion:
    """One motion instruction: the targets it names (as written), its tool and work object."""

    line: int
    instruction: str
    targets: list[str]
    tool: str
    wobj: str


@dataclass
class RapidModule:
    path: str
    text: str
    declarations: list[Declaration] = field(default_factory=list)
    motions: list[Motion] = field(default_factory=list)
    runtime: list[tuple[int, str]] = field(default_factory=list)  # (line, what)

    def __post_init__(self) -> None:
        self._lines = _Lines(self.text)

    def line_of(self, pos: int) -> int:
        """The 1-based line of a position in the text."""
        return self._lines.of(pos)


_COMMENT_OR_STRING = re.compile(r'"[^"\n]*"?|![^\n]*')


def _blank_comments_and_strings(text: str) -> str:
    """The text with comments (`!` to the end of the line) and string contents replaced by
    spaces: positions and lines unchanged, nothing in them mistaken for code."""
    def blank(m: re.Match[str]) -> str:
        s = m.group(0)
        if s.startswith('"'):  # keep the quotes, blank what is between them
            return '"' + " " * (len(s) - 2) + '"' if len(s) > 1 and s.endswith('"') else \
                '"' + " " * (len(s) - 1)
        return " " * len(s)

    return _COMMENT_OR_STRING.sub(blank, text)


class _Lines:
    """Line numbers (1-based) of positions in a text."""

    def __init__(self, text: str):
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def of(self, pos: int) -> int:
        return bisect_right(self.starts, pos)


_TOKEN = re.compile(rf'(\[)|(\])|("[^"]*"|{NUMBER.pattern}|[A-Za-z]\w*)|([^\s,])')


def _aggregate(code: str, text: str, pos: int, path: str, lines: _Lines) -> tuple[Aggregate, int]:
    """Parse `[ ... ]` starting at `pos` (in the blanked code, where a value cannot hold a
    `;`): nested lists of tokens; returns the value and the position after its closing
    bracket."""
    end = code.find(";", pos)
    stack: list[Aggregate] = []
    for m in _TOKEN.finditer(code, pos, len(code) if end < 0 else end):
        opening, closing, atom, other = m.groups()
        if opening:
            stack.append([])
        elif closing:
            if not stack:
                raise DataFileError(path, "unbalanced ']' in a data value",
                                    line=lines.of(m.start()))
            done = stack.pop()
            if not stack:
                return done, m.end()
            stack[-1].append(done)
        elif atom and stack:
            start, stop = m.span()
            stack[-1].append(Token(text[start:stop] if atom[0] == '"' else atom, start, stop))
        else:
            raise DataFileError(path, f"unexpected '{other or atom}' in a data value",
                                line=lines.of(m.start()))
    raise DataFileError(path, "a data value that never closes (missing ']')", line=lines.of(pos))


def _split_arguments(args: str) -> list[str]:
    """Top-level comma-separated arguments (brackets and parentheses kept together)."""
    if "(" not in args and "[" not in args:
        return [a.strip() for a in args.split(",")]
    out, depth, start = [], 0, 0
    for i, c in enumerate(args):
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
        elif c == "," and depth == 0:
            out.append(args[start:i])
            start = i + 1
    out.append(args[start:])
    return [a.strip() for a in out]


# `MoveL p10, v100, z10, tool1 \WObj:=wobj1;` and the like: most instructions, in one match.
_SIMPLE_MOTION = re.compile(
    r"\s*([A-Za-z]\w*)\s*,\s*[A-Za-z]\w*\s*,\s*[A-Za-z]\w*\s*,\s*([A-Za-z]\w*)"
    r"(?:\s*\\WObj\s*:=\s*([A-Za-z]\w*))?\s*$")


def _motion(match: re.Match[str], lines: _Lines) -> Motion:
    name = match.group(1)
    simple = None if name.lower().startswith(("movec", "triggc")) else \
        _SIMPLE_MOTION.match(match.group(2))
    if simple:
        return Motion(lines.of(match.start()), name, [simple.group(1)], simple.group(2),
                      simple.group(3) or "wobj0")
    positional, wobj = [], "wobj0"
    for arg in _split_arguments(match.group(2)):
        head, *options = re.split(r"\s*\\", arg)  # `v100 \V:=500`: positional, then options
        for option in options:
            key, _, value = option.partition(":=")
            if key.strip().lower() == "wobj":
                wobj = value.strip()
        if head:
            positional.append(head)
    n_targets = 2 if name.lower().startswith(("movec", "triggc")) else 1
    return Motion(lines.of(match.start()), name, positional[:n_targets],
                  positional[-1] if len(positional) > n_targets else "tool0", wobj)


def read_rapid_module(path: str, text: str) -> RapidModule:
    """The module's data declarations, motion instructions and run-time targets."""
    code = _blank_comments_and_strings(text)
    if not MODULE_HEADER.match(code):
        first = next((line.strip() for line in text.splitlines() if line.strip()), "")
        raise DataFileError(path, "not a RAPID module: it must begin with 'MODULE <name>' "
                            f"(comments before it allowed), not '{first[:40]}'", line=1)
    module = RapidModule(path, text)
    lines = module._lines
    for m in DECLARATION.finditer(code):
        value = None
        if m.group(4):
            plain = None if m.group(3) else _ROBTARGET.match(code, m.end())
            if plain:  # [[x,y,z],[q1..q4],[cf1,cf4,cf6,cfx],[extax]] in one match
                tokens = [_token((text, *span))  # the groups and their spans, in one go
                          for text, span in zip(plain.groups()[:11], plain.regs[1:12],
                                                strict=True)]
                # the external axes are never rewritten: not tokenised
                value, end = [tokens[:3], tokens[3:7], tokens[7:11], []], plain.end()
            else:
                value, end = _aggregate(code, text, m.end(), path, lines)
            if not _END.match(code, end):
                raise DataFileError(path, f"the declaration of {m.group(2)} does not end with "
                                    "';'", line=lines.of(end))
        module.declarations.append(Declaration(m.group(1).lower(), m.group(2),
                                               lines.of(m.start()), value))
    for m in MOTION.finditer(code):
        module.motions.append(_motion(m, lines))
    for m in RUNTIME_TARGETS.finditer(code):
        module.runtime.append((lines.of(m.start()), m.group(1)))
    return module
