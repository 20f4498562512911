"""`screwcal rapid check`: what can be found wrong in RAPID modules without a controller.

Four classes of finding, each with file:line:col and a one-line reason:
- syntax: the module does not parse;
- unknown: an instruction or function that is neither in the RAPID reference's table
  (`names`) nor a routine of the modules checked together (one task: every file given);
- argument: too few or too many positional arguments, or an optional `\\Name` the routine
  does not have;
- type: what the parser can see, i.e. a literal or a declared datum of num, dnum, string or bool
  where another of these is needed (a declaration's value, an assignment, a condition, an
  operator, an argument of a routine of the checked modules);
- string: a string literal over 80 characters (RAPID's limit).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, fields

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
from screwcal.rapid.names import FUNCTIONS, INSTRUCTIONS, Signature
from screwcal.rapid.parser import RapidSyntaxError, parse_module

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


@dataclass(frozen=True)
class Finding:
    path: str
    line: int
    col: int
    kind: str  # syntax, unknown, argument, type, string
    reason: str

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
    return Signature(routine.name, len(required), len(required), options)


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
    def __init__(self, modules: dict[str, Module], known: frozenset[str]):
        self.modules = modules
        self.known = known
        self.findings: list[Finding] = []
        self.global_routines: dict[str, Routine] = {}
        self.global_data: dict[str, str] = {}
        for m in modules.values():
            for r in m.routines:
                if not r.local:
                    self.global_routines.setdefault(r.key, r)
            for d in m.data:
                if d.scope != "LOCAL" and not d.dims:
                    self.global_data.setdefault(d.key, d.type.lower())

    def add(self, path: str, node: Node, kind: str, reason: str) -> None:
        self.findings.append(Finding(path, node.line, node.col, kind, reason))

    def run(self) -> list[Finding]:
        for path, module in self.modules.items():
            self.module(path, module)
        return sorted(self.findings, key=lambda f: (f.path, f.line, f.col))

    def module(self, path: str, module: Module) -> None:
        self.path = path
        self.routines = dict(self.global_routines)
        self.routines.update({r.key: r for r in module.routines})
        module_data = dict(self.global_data)
        module_data.update({d.key: d.type.lower() for d in module.data})
        self.scope = module_data
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
            (INSTRUCTIONS if instruction else FUNCTIONS).get(name.lower())
        if sig is None:
            if name.lower() in self.known:
                return
            self.add(self.path, node, "unknown", f"unknown {what} '{name}' (not in the RAPID "
                     "reference table nor a routine of the modules checked)")
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


def check_modules(sources: Sequence[tuple[str, str]],
                  known: Iterable[str] = ()) -> list[Finding]:
    """Findings for (path, text) pairs checked together as one task's modules: a syntax error
    stops that file's other checks. `known`: routines defined elsewhere (other modules of the
    task, options), not reported as unknown."""
    findings: list[Finding] = []
    modules: dict[str, Module] = {}
    for path, text in sources:
        try:
            modules[path] = parse_module(text, path)
        except RapidSyntaxError as err:
            findings.append(Finding(path, err.line, err.col, "syntax", err.reason))
    return findings + _Checker(modules, frozenset(k.lower() for k in known)).run()
