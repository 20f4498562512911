"""Reading a RAPID module's source as far as a static filter needs, through the RAPID parser
(`screwcal.rapid`): the declarations of `robtarget`, `tooldata` and `wobjdata` data (CONST,
PERS, VAR, with LOCAL or TASK, arrays, values over several lines, comments between them, in the
module or in a routine), every number of their values with its place in the text (so that a
rewrite changes those characters and nothing else), and the motion instructions that use them
(which tool and work object each target is reached with).

No RAPID is executed: what only the running program knows (a target computed with `Offs`,
`RelTool`, `CRobT`, a value assigned at run time) is reported as such, with its line.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from dataclasses import dataclass, field, replace
from functools import partial
from operator import add
from typing import NamedTuple

from screwcal.errors import DataFileError
from screwcal.rapid import RapidSyntaxError, parse_module
from screwcal.rapid import ast as rapid

# A number as RAPID writes it (with its sign): where the filter's numbers are in a text.
# Every part taken possessively (no part of a number gives back what it read: the same
# matches, a third less time checking 10,000 robtargets' numbers).
NUMBER = re.compile(r"[-+]?+(?:\d++(?:\.\d*+)?+|\.\d++)(?:[eE][-+]?+\d++)?+")
# Instructions that move to robtargets (the base system's and the process options'): which
# positional arguments are targets, and where the tool is (None: the last positional). The
# Move family has its tool after the speed and the zone (a signal and its value may follow).
_MOVE_SUFFIXES = ("", "DO", "AO", "GO", "Sync")
MOTIONS: dict[str, tuple[tuple[int, ...], int | None]] = {
    **{f"move{a}{s}".lower(): ((0, 1), 4) if a == "C" else ((0,), 3)
       for a in "JLC" for s in _MOVE_SUFFIXES},
    **{f"trigg{a}".lower(): ((0, 1) if a == "C" else (0,), None) for a in "JLC"},
    "triggjios": ((0,), None), "trigglios": ((0,), None),
    "searchl": ((2,), None), "searchj": ((2,), None), "searchc": ((2, 3), None),
    **{f"arc{a}{s}".lower(): ((0, 1) if a == "C" else (0,), None)
       for a in "LC" for s in ("", "1", "2", "Start", "End")},
    "arcrepl": ((0,), None), "capl": ((0,), None), "capc": ((0, 1), None),
    "spotl": ((0,), None), "spotj": ((0,), None), "spotml": ((0,), None),
    "paintl": ((0,), None), "paintc": ((0, 1), None), "displ": ((0,), None),
    "dispc": ((0, 1), None), "cssdeactmovel": ((0,), None),
}
RUNTIME_FUNCTIONS = frozenset(("offs", "reltool", "crobt", "calcrobt", "mirpos"))
DECLARED_KINDS = ("robtarget", "tooldata", "wobjdata")


class Token(NamedTuple):
    """A number (or TRUE/FALSE, or a string, or an expression's text) of a value, and where it
    is in the text (a tuple: a module holds hundreds of thousands)."""

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
    kind: str  # robtarget, tooldata, wobjdata, record (one holding robtargets; lower case)
    name: str
    line: int
    value: Aggregate | Token | None  # None: declared without a value; a Token: not a literal
    type: str = ""  # the declared type (lower case): a record's name for kind "record"
    dims: int = 0  # array dimensions


@dataclass
class Motion:
    """One motion instruction: the targets it names (as written), its tool and work object."""

    line: int
    instruction: str
    targets: list[str]
    tool: str
    wobj: str
    routine: str = ""  # the routine it is in (lower case)
    template: bool = False  # its target is a parameter of its routine: moved at each call


@dataclass(frozen=True)
class RoutineCall:
    """A call of a routine of the task, with its arguments as written (where a routine that
    moves to a robtarget parameter is called: `rapid_task`)."""

    line: int
    routine: str  # lower case
    caller: str  # the routine the call is in (lower case)
    positional: tuple[str, ...]
    optional: tuple[tuple[str, str], ...]  # (lower-case name, value as written)


@dataclass
class RapidModule:
    path: str
    text: str
    declarations: list[Declaration] = field(default_factory=list)
    motions: list[Motion] = field(default_factory=list)
    runtime: list[tuple[int, str]] = field(default_factory=list)  # (line, what)
    # RECORD types that hold robtargets (in a component, or a component's record):
    # lower-case name -> (component name, lower-case type) in order
    records: dict[str, list[tuple[str, str]]] = field(default_factory=dict)
    # routines: lower-case name -> its parameters (lower-case name, optional) in order
    params: dict[str, list[tuple[str, bool]]] = field(default_factory=dict)
    calls: list[RoutineCall] = field(default_factory=list)
    unreadable: str = ""  # why the module's text cannot be read (an encrypted module)
    # data the program writes (`p := ...`, `p.trans.z := ...`, a search's result): lower-case
    # declared name -> (line, how), the first place
    assigned: dict[str, tuple[int, str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._lines = _Lines(self.text)

    def line_of(self, pos: int) -> int:
        """The 1-based line of a position in the text."""
        return self._lines.of(pos)


class _Lines:
    """Line numbers (1-based) of positions in a text."""

    def __init__(self, text: str):
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def of(self, pos: int) -> int:
        return bisect_right(self.starts, pos)


class NumberTokens(list[Token]):
    """The tokens of a row of numbers the parser read in one match (`rapid.NumberRow`): each
    one a literal as NUMBER has it, by construction (the filter need not check them again)."""


def _row(node: rapid.NumberRow) -> NumberTokens:
    """A row of numbers as tokens (built in C: 110,000 for 10,000 robtargets)."""
    texts, starts = node.texts, node.starts
    return NumberTokens(map(_token, zip(texts, starts, map(add, starts, map(len, texts)),
                                        strict=True)))


def _value(node: rapid.Expr, text: str) -> Aggregate | Token:
    """A data value as nested lists of tokens: literals as written (strings with their
    quotes), anything else (an expression) as its text."""
    if isinstance(node, rapid.Aggregate):
        items = node.items
        if len(items) == 4:
            trans, rot, conf, extax = items
            if type(trans) is type(rot) is type(conf) is type(extax) is rapid.NumberRow and \
                    len(trans.texts) == 3 and len(rot.texts) == 4 == len(conf.texts):
                # a robtarget (most values): its external axes are never rewritten
                return [_row(trans), _row(rot), _row(conf), []]
        return [_value(i, text) for i in items]
    if isinstance(node, rapid.NumberRow):
        return _row(node)
    if isinstance(node, (rapid.Num, rapid.Str)):
        return _token((node.text, node.start, node.end))
    return _token((text[node.start:node.end], node.start, node.end))


_LEAVES = (rapid.Num, rapid.Str, rapid.Name, rapid.NumberRow)


def _calls(nodes: tuple) -> list[rapid.ProcCall | rapid.Call]:
    """The procedure and function calls below `nodes`, depth first."""
    out: list[rapid.ProcCall | rapid.Call] = []
    stack = list(nodes)
    while stack:
        node = stack.pop()
        if type(node) is tuple:
            stack.extend(node)
        elif type(node) is rapid.ProcCall or type(node) is rapid.Call:
            out.append(node)
            if node.late is not None:
                stack.append(node.late)
            # arguments: only their values can hold calls; names and literals cannot
            stack.extend([a.value for a in node.args if not isinstance(a.value, _LEAVES)])
        elif isinstance(node, rapid.Node) and not isinstance(node, _LEAVES):
            stack.extend([getattr(node, f) for f in node.__slots__])
    return out


def _motion(call: rapid.ProcCall, key: str, text: str, line: int) -> Motion:
    """The motion instruction `call` (`key`: its lower-case name, a key of MOTIONS)."""
    positional = [text[a.value.start:a.value.end].strip() for a in call.args
                  if not a.optional and a.value is not None]
    wobj = "wobj0"
    for a in call.args:
        if a.optional and a.name and a.value is not None and a.name.lower() == "wobj":
            wobj = text[a.value.start:a.value.end].strip()
            break
    places, tool_at = MOTIONS[key]
    at = len(positional) - 1 if tool_at is None else tool_at
    tool = positional[at] if max(places) < at < len(positional) else "tool0"
    return Motion(line, call.name, [positional[k] for k in places if k < len(positional)],
                  tool, wobj)


def target_records(parsed: list[rapid.Module]) -> dict[str, list[tuple[str, str]]]:
    """The RECORD types of modules that hold a robtarget, directly or in a component's
    record."""
    records = {r.name.lower(): [(f.name, f.type.lower()) for f in r.fields]
               for m in parsed for r in m.records}
    holding: set[str] = set()
    changed = True
    while changed:
        changed = False
        for name, fields in records.items():
            if name not in holding and any(t == "robtarget" or t in holding for _, t in fields):
                holding.add(name)
                changed = True
    return {name: fields for name, fields in records.items() if name in holding}


def parse_rapid(path: str, text: str) -> rapid.Module:
    """The parsed module; a syntax error as DataFileError naming the file and line."""
    try:
        return parse_module(text, path)
    except RapidSyntaxError as err:
        raise DataFileError(path, f"{err.reason} (column {err.col})", line=err.line) from None


def read_rapid_module(path: str, text: str) -> RapidModule:
    """The module's data declarations, motion instructions and run-time targets (a large
    module's single-threaded caller pauses the cyclic collector around this and the filter:
    `screwcal.runtime.policy.collection_paused`); a task of several modules: `rapid_task`.
    A routine moving to its robtarget parameter moves to each call's argument
    (`resolve_routine_motions`)."""
    parsed = parse_rapid(path, text)
    module = module_of(parsed, path, text, target_records([parsed]))
    resolve_routine_motions([module])
    return module


def module_of(parsed: rapid.Module, path: str, text: str,
              records: dict[str, list[tuple[str, str]]]) -> RapidModule:
    """What the filter reads of a parsed module; `records`: the task's RECORD types that
    hold robtargets."""
    module = RapidModule(path, text, records=records)
    line_of = module._lines.of
    data = [*parsed.data, *(d for r in parsed.routines for d in r.data)]
    for d in sorted(data, key=lambda d: d.start):
        kind = d.type.lower()
        if kind in DECLARED_KINDS or kind in module.records:
            value = None if d.value is None else _value(d.value, text)
            module.declarations.append(Declaration(
                kind if kind in DECLARED_KINDS else "record", d.name, d.line, value, kind,
                len(d.dims)))
    # calls in data values (`:= Offs(...)`): only where the value's text holds a parenthesis
    values = tuple(d.value for d in data if d.value is not None
                   and text.find("(", d.value.start, d.value.end) >= 0)
    found = [(n, "") for n in _calls(values)]
    for r in parsed.routines:
        found += [(n, r.key) for n in _calls((r,))]
        if r.params:
            module.params[r.key] = [(p.name.lower(), p.optional) for p in r.params]
    for r in parsed.routines:
        for target, node in _assignments(r.body):
            module.assigned.setdefault(target, (node.line, "assigned"))
    found.sort(key=lambda f: f[0].start)
    for node, routine in found:
        key = node.key
        if isinstance(node, rapid.Call):
            if key in RUNTIME_FUNCTIONS:
                module.runtime.append((line_of(node.start), node.name))
        elif key in MOTIONS:
            motion = _motion(node, key, text, line_of(node.start))
            motion.routine = routine
            module.motions.append(motion)
            if key.startswith("search"):
                result = [a.value for a in node.args if not a.optional and a.value is not None]
                name = _base_name(result[1]) if len(result) > 1 else ""
                if name:
                    module.assigned.setdefault(name, (node.line, f"{node.name}'s result"))
        elif node.args:
            module.calls.append(RoutineCall(
                line_of(node.start), key, routine,
                tuple(text[a.value.start:a.value.end].strip() for a in node.args
                      if not a.optional and a.value is not None),
                tuple((a.name.lower(), text[a.value.start:a.value.end].strip())
                      for a in node.args if a.optional and a.name and a.value is not None)))
    return module


def _base_name(e: rapid.Expr) -> str:
    """The datum an expression writes to (`p`, `p{2}`, `p.trans.z`: p), lower case; else ''."""
    while isinstance(e, (rapid.Index, rapid.Component)):
        e = e.base
    return e.key if isinstance(e, rapid.Name) else ""


def _assignments(body: tuple) -> list[tuple[str, rapid.Node]]:
    """(written datum, statement) of the assignments in a routine's statements."""
    out: list[tuple[str, rapid.Node]] = []
    stack = list(body)
    while stack:
        stmt = stack.pop()
        kind = type(stmt)
        if kind is rapid.ProcCall:
            continue
        if kind is rapid.Assign:
            name = _base_name(stmt.target)
            if name:
                out.append((name, stmt))
        elif kind is rapid.If:
            stack += [s for _, branch in stmt.branches for s in branch] + list(stmt.orelse)
        elif kind in (rapid.While, rapid.For):
            stack += list(stmt.body)
        elif kind is rapid.Test:
            stack += [s for c in stmt.cases for s in c.body] + list(stmt.default or ())
    return sorted(out, key=lambda a: a[1].start)


def _argument(call: RoutineCall, params: list[tuple[str, bool]], name: str,
              default: str) -> str:
    """What `call` passes for parameter `name`, or `default` when it passes nothing."""
    positional = [p for p, optional in params if not optional]
    if name in positional:
        k = positional.index(name)
        return call.positional[k] if k < len(call.positional) else default
    return dict(call.optional).get(name, default)


_WORD = re.compile(r"(?<![\w.])[A-Za-z]\w*")  # a name in an expression (not a component)


def _passed(call: RoutineCall, params: list[tuple[str, bool]], target: str) -> str:
    """A target of a routine's motion (`p`, `Offs(p, 0, 0, 10)`) with the routine's
    parameters replaced by what `call` passes."""
    names = {p for p, _ in params}
    if target.lower() in names:
        return _argument(call, params, target.lower(), target)
    return _WORD.sub(lambda w: _argument(call, params, w.group().lower(), w.group())
                     if w.group().lower() in names else w.group(), target)


def resolve_routine_motions(modules: list[RapidModule]) -> None:
    """Mark the motions to a routine's own parameter (`p`, or `Offs(p, ...)`) as templates,
    and add to each calling module one motion per call of such a routine, its targets, tool and
    work object those the call passes (repeated through routines that pass their parameter
    on)."""
    params = {k: v for m in modules for k, v in m.params.items()}
    names_of = {k: {p for p, _ in v} for k, v in params.items()}  # a routine's parameters
    templates: dict[str, list[Motion]] = {}
    done: set[tuple[str, int, int]] = set()
    pending = True
    while pending:
        pending = False
        for m in modules:
            for motion in m.motions:
                names = names_of.get(motion.routine)  # None: a routine without parameters
                if names and not motion.template and any(w.lower() in names
                                                         for t in motion.targets
                                                         for w in _WORD.findall(t)):
                    motion.template = True
                    templates.setdefault(motion.routine, []).append(motion)
                    pending = True
        for m in modules:
            for call in m.calls:
                for t in templates.get(call.routine, []):
                    key = (m.path, call.line, id(t))
                    if key in done:
                        continue
                    done.add(key)
                    own = params[call.routine]
                    m.motions.append(replace(
                        t, line=call.line, instruction=f"{t.instruction} in {call.routine}",
                        targets=[_passed(call, own, x) for x in t.targets],
                        tool=_argument(call, own, t.tool.lower(), "tool0"
                                       if (t.tool.lower(), True) in own else t.tool),
                        wobj=_argument(call, own, t.wobj.lower(), "wobj0"
                                       if (t.wobj.lower(), True) in own else t.wobj),
                        routine=call.caller, template=False))
                    pending = True
