"""`screwcal rapid check`: what can be found wrong in RAPID modules without a controller.

Classes of finding, each with file:line:col and a one-line reason:
- syntax: the module does not parse;
- unknown: an instruction, function or data type that is neither in the RobotWare tables
  (`names`: the base system and the options selected) nor a routine, record or alias of the
  modules checked together (one task: every file given);
- option: such a name that a RobotWare option not selected brings (the option is named);
- argument: too few or too many positional arguments, an optional `\\Name` the routine
  does not have, or two optional arguments that are alternatives of one another;
- type: what the parser can see, i.e. a literal or a declared datum of num, dnum, string or bool
  where another of these is needed (a declaration's value, an assignment, a condition, an
  operator, an argument of a routine of the checked modules);
- string: a string literal over 80 characters (RAPID's limit).

Three more are notes, not errors: placeholder (`<SMT>`, `<EXP>`...: the controller loads the
module, the program stops with an execution error where it reaches one), encrypted (a module
whose text is not RAPID source: nothing in it can be checked here) and unverified (a name none
of the readable modules defines, in a task with an encrypted module that may define it).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, fields
from pathlib import PurePath

from screwcal.rapid.ast import (
    Argument,
    Assign,
    Binary,
    Call,
    Component,
    DataDecl,
    Expr,
    For,
    If,
    Index,
    Module,
    Name,
    Node,
    Num,
    NumberRow,
    ProcCall,
    Routine,
    Str,
    Unary,
    While,
)
from screwcal.rapid.names import CALIBRATION_CELL, Catalogue, Signature, catalogue
from screwcal.rapid.parser import RapidEncryptedError, RapidSyntaxError, parse_module

MAX_STRING = 80  # characters in a RAPID string
SIMPLE_TYPES = ("num", "dnum", "string", "bool")
# The value types of common built-in functions (the rest: not inferred).
_FUNCTION_TYPES = {
    **dict.fromkeys(("abs", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sqrt", "exp",
                     "pow", "round", "trunc", "max", "min", "strlen", "strfind", "strmatch",
                     "dim", "clkread", "gettime", "distance", "dotprod", "vectmagn",
                     "socketpeek", "rawbyteslen", "readnum", "dinput", "doutput", "ginput",
                     "goutput", "ainput", "aoutput", "bitand", "bitor", "bitxor", "bitneg",
                     "bitlsh", "bitrsh", "hextodec", "eulerzyx"), "num"),
    **dict.fromkeys(("numtostr", "dnumtostr", "strpart", "strmap", "valtostr", "bytetostr",
                     "cdate", "ctime", "getsysinfo", "gettaskname", "readstr", "dectohex",
                     "argname", "strtobyte"), "string"),
    **dict.fromkeys(("strtoval", "strmemb", "strorder", "present", "ispers", "isvar",
                     "testdi", "validio", "bitcheck", "modexist", "issyncmoveon",
                     "isstopmoveact", "ismechunitactive"), "bool"),
}


NOTE_KINDS = frozenset(("placeholder", "encrypted", "unverified"))


@dataclass(frozen=True)
class Finding:
    path: str
    line: int
    col: int
    kind: str  # syntax, unknown, option, argument, type, string; notes: placeholder, encrypted
    reason: str

    @property
    def is_note(self) -> bool:
        """A note: the controller loads the module as it is."""
        return self.kind in NOTE_KINDS

    def __str__(self) -> str:
        return f"{self.path}:{self.line}:{self.col}: {self.kind}: {self.reason}"


def _children(node: Node) -> Iterator[Node]:
    """Every node below `node`, depth first, in source order."""
    for f in fields(node):
        value = getattr(node, f.name)
        stack = [value]
        while stack:
            v = stack.pop(0)
            if isinstance(v, NumberRow):
                yield v
                yield from v.items
            elif isinstance(v, Node):
                yield v
                yield from _children(v)
            elif isinstance(v, tuple):
                stack[0:0] = list(v)


def _signature(routine: Routine) -> Signature:
    required = [p for p in routine.params if not p.optional]
    options = frozenset(a.name.lower() for p in routine.params if p.optional
                        for a in (p, *p.alternatives))
    groups = tuple(frozenset(a.name.lower() for a in (p, *p.alternatives))
                   for p in routine.params if p.optional and p.alternatives)
    return Signature(routine.name, len(required), len(required), options, groups)


def _literal_type(e: Expr) -> str | None:
    if isinstance(e, Num):
        return "num"
    if isinstance(e, Str):
        return "string"
    if isinstance(e, Name) and e.key in ("true", "false"):
        return "bool"
    return None


def _same(a: str, b: str) -> bool:
    return a == b or {a, b} == {"num", "dnum"}


class _Checker:
    def __init__(self, modules: dict[str, Module], known: frozenset[str], names: Catalogue):
        self.modules = modules
        self.known = known
        self.names = names
        self.findings: list[Finding] = []
        self.global_routines: dict[str, Routine] = {}
        self.global_data: dict[str, str] = {}
        self.global_types = {r.name.lower() for m in modules.values() for r in m.records
                             if not r.local} | {a.name.lower() for m in modules.values()
                                                for a in m.aliases if not a.local}
        for m in modules.values():
            for r in m.routines:
                if not r.local:
                    self.global_routines.setdefault(r.key, r)
            for d in m.data:
                if d.scope != "LOCAL" and not d.dims:
                    self.global_data.setdefault(d.key, d.type.lower())

    def add(self, path: str, node: Node, kind: str, reason: str) -> None:
        self.findings.append(Finding(path, node.line, node.col, kind, reason))

    def run(self, reported: Iterable[str], hidden: Sequence[str] = ()) -> list[Finding]:
        """Findings of the modules of `reported` (the others: context, for their names);
        `hidden`: the task's modules that cannot be read (encrypted)."""
        self.hidden = hidden
        for path in reported:
            if path in self.modules:
                self.module(path, self.modules[path])
        return sorted(self.findings, key=lambda f: (f.path, f.line, f.col))

    def module(self, path: str, module: Module) -> None:
        self.path = path
        self.routines = dict(self.global_routines)
        self.routines.update({r.key: r for r in module.routines})
        module_data = dict(self.global_data)
        module_data.update({d.key: d.type.lower() for d in module.data})
        self.scope = module_data
        self.types = self.global_types | {r.name.lower() for r in module.records} | \
            {a.name.lower() for a in module.aliases}
        for p in module.placeholders:
            self.add(path, p, "placeholder", f"<{p.kind}>: a part not yet written; the "
                     "controller loads the module and stops with an error where it reaches it")
        self.data_types(module)
        for d in module.data:
            self.declaration(d)
        for r in module.routines:
            self.scope = dict(module_data)
            self.scope.update({p.name.lower(): p.type.lower() for p in r.params
                               for p in (p, *p.alternatives) if not p.dims})
            self.scope.update({d.key: d.type.lower() for d in r.data})
            self.fn_type = r.type.lower() if r.type else None
            for d in r.data:
                self.declaration(d)
            for node in _children(r):
                self.visit(node)
        for node in _children(module):
            if isinstance(node, Str) and len(node.value) > MAX_STRING:
                self.add(path, node, "string", f"a string of {len(node.value)} characters: "
                         f"RAPID strings hold at most {MAX_STRING}")

    def data_types(self, module: Module) -> None:
        """Every data type the module names (data, parameters, record components, function
        values, aliases) is the system's, an option's, or a record or alias of the task."""
        named: list[tuple[Node, str]] = [(d, d.type) for d in module.data]
        named += [(f, f.type) for r in module.records for f in r.fields]
        named += [(a, a.type) for a in module.aliases]
        for r in module.routines:
            named += [(d, d.type) for d in r.data]
            named += [(p, p.type) for p in r.params for p in (p, *p.alternatives)]
            if r.type:
                named.append((r, r.type))
        for node, type_ in named:
            key = type_.lower()
            if key in self.types or key in self.names.types or key in self.known:
                continue
            options = self.names.elsewhere.get(key)
            if options:
                self.add(self.path, node, "option", f"data type '{type_}' comes with the "
                         f"RobotWare option {' or '.join(options)}, not selected (--options)")
            else:
                self.unknown(node, f"data type '{type_}'", "a RECORD or ALIAS")

    def unknown(self, node: Node, what: str, defined_as: str) -> None:
        if self.hidden:
            names = ", ".join(PurePath(h).name for h in self.hidden)
            self.add(self.path, node, "unverified", f"unknown {what}: not in the RobotWare tables "
                     f"nor {defined_as} of the readable modules; perhaps of the encrypted {names}")
        else:
            self.add(self.path, node, "unknown", f"unknown {what} (not in the RobotWare tables "
                     f"nor {defined_as} of the modules checked)")

    def declaration(self, d: DataDecl) -> None:
        if d.value is None or d.dims:
            return
        want, have = d.type.lower(), self.type_of(d.value)
        if want in SIMPLE_TYPES and have and not _same(want, have):
            self.add(self.path, d.value, "type", f"{d.name} is {want}, its value is {have}")

    def type_of(self, e: Expr) -> str | None:
        lit = _literal_type(e)
        if lit:
            return lit
        if isinstance(e, Name):
            return self.scope.get(e.key)
        if isinstance(e, Index) and isinstance(e.base, Name):
            return self.scope.get(e.base.key)
        if isinstance(e, Call):
            r = self.routines.get(e.key)
            if r is not None and r.kind == "FUNC" and r.type:
                return r.type.lower()
            return _FUNCTION_TYPES.get(e.key)
        if isinstance(e, Unary):
            return "bool" if e.op == "NOT" else self.type_of(e.operand)
        if isinstance(e, Binary):
            if e.op in ("AND", "OR", "XOR", "<", "<=", "=", ">=", ">", "<>"):
                return "bool"
            if e.op == "+":
                left, right = self.type_of(e.left), self.type_of(e.right)
                return left if left == right else None
            return "num"
        return None

    def visit(self, node: Node) -> None:
        if isinstance(node, ProcCall) and node.late is None:
            self.call(node, node.name, node.args, instruction=True)
        elif isinstance(node, Call) and node.late is None:
            self.call(node, node.name, node.args, instruction=False)
        elif isinstance(node, Assign):
            want = self.type_of(node.target) if isinstance(node.target, (Name, Index)) \
                else None
            have = self.type_of(node.value)
            if want in SIMPLE_TYPES and have in SIMPLE_TYPES and not _same(want, have):
                self.add(self.path, node.value, "type", f"{_shown(node.target)} is {want}, "
                         f"the value assigned is {have}")
        elif isinstance(node, (If, While)):
            conditions = [c for c, _ in node.branches] if isinstance(node, If) \
                else [node.condition]
            for c in conditions:
                have = self.type_of(c)
                if have in SIMPLE_TYPES and have != "bool":
                    self.add(self.path, c, "type", f"a condition must be bool, this is {have}")
        elif isinstance(node, For):
            self.scope[node.var.lower()] = "num"
        elif isinstance(node, Binary):
            self.binary(node)

    def binary(self, node: Binary) -> None:
        left, right = self.type_of(node.left), self.type_of(node.right)
        if left not in SIMPLE_TYPES or right not in SIMPLE_TYPES:
            return
        if node.op in ("AND", "OR", "XOR"):
            bad = [t for t in (left, right) if t != "bool"]
            if bad:
                self.add(self.path, node, "type", f"{node.op} takes bool operands, not {bad[0]}")
        elif node.op in ("=", "<>"):
            if not _same(left, right):
                self.add(self.path, node, "type", f"'{node.op}' compares {left} with {right}")
        elif node.op == "+" and "string" in (left, right):
            if left != right:
                self.add(self.path, node, "type", f"'+' joins string with string, not "
                         f"{left} with {right}")
        elif "string" in (left, right) or "bool" in (left, right):
            self.add(self.path, node, "type", f"'{node.op}' takes numbers, not "
                     f"{left} and {right}")

    def call(self, node: Node, name: str, args: tuple[Argument, ...], *,
             instruction: bool) -> None:
        what = "instruction" if instruction else "function"
        routine = self.routines.get(name.lower())
        if routine is not None and (routine.kind == "FUNC") == instruction:
            self.add(self.path, node, "unknown", f"{name} is a {routine.kind} of the module, "
                     f"not a{'n' if instruction else ''} {what}")
            return
        sig = _signature(routine) if routine is not None else \
            (self.names.instructions if instruction else self.names.functions).get(name.lower())
        if sig is None:
            if name.lower() in self.known:
                return
            options = self.names.elsewhere.get(name.lower())
            if options:
                self.add(self.path, node, "option", f"{what} '{name}' comes with the RobotWare "
                         f"option {' or '.join(options)}, not selected (--options)")
                return
            self.unknown(node, f"{what} '{name}'", "a routine")
            return
        positional = [a for a in args if not a.optional]
        if sig.min_positional is not None and not (
                sig.min_positional <= len(positional) <= (sig.max_positional or 0)):
            wanted = str(sig.min_positional) if sig.min_positional == sig.max_positional else \
                f"{sig.min_positional} to {sig.max_positional}"
            self.add(self.path, node, "argument", f"{sig.name} takes {wanted} required "
                     f"argument{'s' if wanted != '1' else ''}, {len(positional)} given")
        if sig.options is not None:
            for a in args:
                if a.optional and a.name and a.name.lower() not in sig.options:
                    self.add(self.path, a, "argument", f"{sig.name} has no optional "
                             f"argument \\{a.name}")
        given = [a for a in args if a.optional and a.name]
        for group in sig.alternatives:
            both = [a for a in given if a.name and a.name.lower() in group]
            if len(both) > 1:
                self.add(self.path, both[1], "argument", f"{sig.name}: \\{both[0].name} and "
                         f"\\{both[1].name} are alternatives of one another: give one")
        if routine is not None:
            required = [p for p in routine.params if not p.optional]
            for a, p in zip(positional, required, strict=False):
                want, have = p.type.lower(), self.type_of(a.value) if a.value else None
                if want in SIMPLE_TYPES and have in SIMPLE_TYPES and not _same(want, have):
                    self.add(self.path, a, "type", f"{p.name} of {routine.name} is {want}, "
                             f"the argument is {have}")


def _shown(e: Expr) -> str:
    if isinstance(e, Name):
        return e.name
    if isinstance(e, Index):
        return _shown(e.base) + "{...}"
    if isinstance(e, Component):
        return f"{_shown(e.base)}.{e.name}"
    return "the target"


def check_modules(sources: Sequence[tuple[str, str]], known: Iterable[str] = (),
                  options: Iterable[str] = CALIBRATION_CELL,
                  context: Sequence[tuple[str, str]] = ()) -> list[Finding]:
    """Findings for (path, text) pairs checked together as one task's modules: a syntax error
    stops that file's other checks. `known`: routines and data types defined elsewhere (other
    modules of the task, a gripper's package), not reported as unknown; `options`: the
    RobotWare options of the controller (keys of `names.OPTIONS`); `context`: more modules the
    task loads (a controller's system modules), read for their names, not reported on."""
    findings: list[Finding] = []
    modules: dict[str, Module] = {}
    hidden: list[str] = []
    for path, text in [*sources, *context]:
        try:
            modules[path] = parse_module(text, path)
        except RapidEncryptedError as err:
            hidden.append(path)
            if (path, text) in sources:
                findings.append(Finding(path, err.line, err.col, "encrypted", err.reason))
        except RapidSyntaxError as err:
            if (path, text) in sources:
                findings.append(Finding(path, err.line, err.col, "syntax", err.reason))
    checker = _Checker(modules, frozenset(k.lower() for k in known), catalogue(options))
    return findings + checker.run([p for p, _ in sources], hidden)
