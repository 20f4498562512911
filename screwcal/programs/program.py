"""What a program reader finds: targets as literals in the text, the frames and tools they are
used with, and notes on what a static filter cannot compensate."""

from __future__ import annotations

import bisect
import functools
from dataclasses import dataclass, field
from typing import Literal, NamedTuple

Language = Literal["krl", "fanuc", "urscript"]
Span = tuple[int, int]  # [start, end) character offsets into the file's text


@functools.lru_cache(maxsize=16)
def _newlines(text: str) -> list[int]:
    """The offsets of a text's line ends, once per text (a str keeps its hash)."""
    out, at = [], text.find("\n")
    while at >= 0:
        out.append(at)
        at = text.find("\n", at + 1)
    return out


def line_of(text: str, offset: int) -> int:
    """The 1-based line of a character offset."""
    return bisect.bisect_left(_newlines(text), offset) + 1


class ProgramSyntaxError(ValueError):
    """A program the reader cannot read: names the file, line and what was expected."""

    def __init__(self, path: str, line: int, message: str) -> None:
        super().__init__(f"{path}, line {line}: {message}")
        self.path, self.line = path, line


@dataclass(frozen=True)
class Frame:
    """A tool or a frame as six numbers in the program's own units and angles (x, y, z, then
    the three orientation numbers), or why it cannot be used statically."""

    values: tuple[float, ...] | None  # six
    problem: str = ""


class Flag(NamedTuple):  # (a tuple: one or two a target, thousands in a program)
    """A configuration flag as written: its name ("S", "T", "CONFIG"), text and span."""

    name: str
    text: str
    span: Span


@dataclass
class Target:
    """A Cartesian target written as a literal: its six numbers (program units) and their
    spans, the tool and frame it is used with (keys of `Program.tools`/`frames`; None: the
    flange / the robot base), and its flags."""

    path: str
    line: int
    name: str
    values: tuple[float, ...]
    spans: tuple[Span, ...]
    tool: str | None = None
    frame: str | None = None
    flags: dict[str, Flag] = field(default_factory=dict)
    problem: str = ""  # why it cannot be compensated, when it cannot


@dataclass(frozen=True)
class Note:
    """Something not compensated: where, what, why."""

    path: str
    line: int
    name: str
    reason: str


@dataclass
class Program:
    """The targets of one program (one or several files of one language), in file order."""

    language: Language
    texts: dict[str, str]  # by path: the files' texts
    targets: list[Target] = field(default_factory=list)
    tools: dict[str, Frame] = field(default_factory=dict)
    frames: dict[str, Frame] = field(default_factory=dict)
    notes: list[Note] = field(default_factory=list)
    joint_targets: int = 0  # targets written in joints: left as they are
    joint_names: set[str] = field(default_factory=set)  # global joint targets (KUKA's XHOME)
