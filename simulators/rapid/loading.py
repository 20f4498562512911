"""What a controller refuses when it loads a task's modules (`check_module`), and the task's
names: its routines and data across its modules (`task_names`: a name declared twice refused,
a PERS shared) and its RECORD and ALIAS types (`task_types`).

Nothing the interpreter does not implement is ever skipped: an unknown instruction, function,
data type or name, an optional argument a built-in does not implement, a TRAP, CONNECT, a
late-bound call, a GOTO into a block is a LoadError naming its file and line.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

from screwcal.rapid import ast as A  # noqa: N812 - the node classes, as A.If, A.Call
from screwcal.rapid import parse_module
from simulators.rapid.builtins import BUILTINS, Builtin
from simulators.rapid.errors import LoadError
from simulators.rapid.values import SYSTEM_TYPES, declare_types, known_type


@functools.lru_cache(maxsize=16)
def loaded_module(text: str, path: str = "<module>") -> A.Module:
    """A program module's tree, parsed once per text and path: the tree is immutable, every
    task (an emulated cell each) runs the same one. Raises RapidSyntaxError as parse_module."""
    return parse_module(text, path)


# The (text, path) of the modules a task has loaded: what a controller refuses at load
# (`check_module`) depends on nothing else (the built-ins and system data are fixed); 64 at most.
CHECKED: set[tuple[str, str]] = set()


@dataclass(frozen=True)
class TaskScope:
    """What a module's names may refer to: the task's routines, data and types, the system's
    data."""

    routines: dict[str, A.Routine]
    data: dict[str, A.DataDecl]
    types: frozenset[str]
    system: frozenset[str]


def check_module(module: A.Module, path: str, scope: TaskScope) -> None:
    """What a controller refuses when it loads a module of the task: unknown instructions,
    functions, names, types, optional arguments; a GOTO to no label around it."""
    module_names, routines = module_view(module, scope)
    own = scope.types
    for rec in module.records:
        for f in rec.fields:
            if not known_type(f.type, own):
                raise LoadError(path, f.line, f"unknown data type {f.type}")
    for d in module.data:
        if not known_type(d.type, own):
            raise LoadError(path, d.line, f"unknown data type {d.type}")
    for r in module.routines:
        if r.kind == "TRAP":
            raise LoadError(path, r.line, "TRAP routines are not supported")
        local = {p.name.lower() for p in r.params} | {d.key for d in r.data}
        for d in r.data:
            if not known_type(d.type, own):
                raise LoadError(path, d.line, f"unknown data type {d.type}")
        for node in _walk(r):
            if isinstance(node, A.For):
                local.add(node.var.lower())
        names = local | module_names | set(scope.system) | {"true", "false", "errno"}
        for node in _walk(r):
            _check_node(node, names, path, routines)
        for section in (r.body, r.error, r.undo, r.backward):
            if section:
                _check_gotos(path, section, frozenset())

def _check_node(node: Any, names: set[str], path: str,
                routines: dict[str, A.Routine]) -> None:
    where = node.line if isinstance(node, A.Node) else 0
    if isinstance(node, A.ProcCall | A.Call):
        proc = isinstance(node, A.ProcCall)
        if isinstance(node, A.ProcCall) and node.late is not None:
            raise LoadError(path, where, "late-bound procedure calls are not supported")
        kind = "PROC" if proc else "FUNC"
        r = routines.get(node.key)
        if r is None or r.kind != kind:  # a built-in, or nothing
            b = BUILTINS.get(node.key)
            if b is None or b.kind != kind.lower():
                raise LoadError(path, where, f"{'instruction' if proc else 'function'} "
                                f"{node.name} is unknown to this controller")
            _check_options(path, node, b)
    elif isinstance(node, A.Name) and node.key not in names:
        raise LoadError(path, where, f"no data named {node.name}")
    elif isinstance(node, A.Connect):
        raise LoadError(path, where, f"{type(node).__name__.upper()} is not supported")
    elif isinstance(node, A.Str) and len(node.value) > 80:
        raise LoadError(path, where, "string literal longer than 80 characters")



def local_key(module: A.Module, key: str) -> str:
    """Where a module's LOCAL datum or routine is kept among the task's names ("module:name":
    no RAPID name holds a colon)."""
    return f"{module.name.lower()}:{key}"


def task_names(modules: list[tuple[A.Module, str]]) -> tuple[
        dict[str, A.Routine], dict[str, A.DataDecl], dict[int, str]]:
    """A task's routines and data by name (a LOCAL one under `local_key`), and each routine's
    file. A global name declared in two modules, or any name twice in one, is refused (its
    second declaration's line), but for a PERS declared alike in both (persistents are
    shared: the one with a value initialises it); a LOCAL name hides a global one in its
    module."""
    routines: dict[str, A.Routine] = {}
    data: dict[str, A.DataDecl] = {}
    paths: dict[int, str] = {}
    where: dict[str, str] = {}

    def clash(key: str, plain: str, module: A.Module, path: str) -> bool:
        other = local_key(module, plain) if key == plain else plain
        return key in routines or (other in where and where[other] == path)

    for module, path in modules:
        for d in module.data:
            key = local_key(module, d.key) if d.scope == "LOCAL" else d.key
            first = data.get(key)
            if first is not None or clash(key, d.key, module, path):
                if first is not None and first.storage == d.storage == "PERS" and \
                        first.type.lower() == d.type.lower():
                    if first.value is None:
                        data[key] = d
                    continue
                raise LoadError(path, d.line, f"{d.name} is declared again (first in "
                                f"{where.get(key) or path})")
            data[key], where[key] = d, path
        for r in module.routines:
            key = local_key(module, r.key) if r.local else r.key
            if key in data or clash(key, r.key, module, path):
                raise LoadError(path, r.line, f"{r.name} is declared again (first in "
                                f"{where.get(key) or path})")
            routines[key], where[key], paths[id(r)] = r, path, path
    return routines, data, paths


def local_names(modules: list[tuple[A.Module, str]], routines: dict[str, A.Routine],
                data: dict[str, A.DataDecl]) -> dict[int, str]:
    """The task's keys of the names its modules use for their LOCAL data and routines, by
    the id of the using node (a routine's own parameters and data hide them)."""
    out: dict[int, str] = {}
    for module, _ in modules:
        prefix = local_key(module, "")
        mine = {k[len(prefix):] for k in (*routines, *data) if k.startswith(prefix)}
        if not mine:
            continue
        tops: list[Any] = [*(e for d in module.data for e in (d.value, *d.dims) if e)]
        tops.extend(module.routines)
        for top in tops:
            hidden = {p.name.lower() for p in top.params} | {d.key for d in top.data} \
                if isinstance(top, A.Routine) else set()
            for node in _walk(top):
                if isinstance(node, A.Name | A.Call | A.ProcCall) and node.key in mine \
                        and node.key not in hidden:
                    out[id(node)] = prefix + node.key
    return out


def module_view(module: A.Module, scope: TaskScope) -> tuple[set[str], dict[str, A.Routine]]:
    """The data names and routines a module sees: the task's global ones, its own LOCAL ones
    over them."""
    prefix = local_key(module, "")
    names = {k for k in scope.data if ":" not in k} | \
        {k[len(prefix):] for k in scope.data if k.startswith(prefix)}
    routines = {k: r for k, r in scope.routines.items() if ":" not in k} | \
        {k[len(prefix):]: r for k, r in scope.routines.items() if k.startswith(prefix)}
    return names, routines


def _check_options(path: str, node: A.Call | A.ProcCall, b: Builtin) -> None:
    """A built-in's optional arguments are those it implements; a required one given by name
    is not supported."""
    for a in node.args:
        if a.name is None:
            continue
        if not a.optional:
            raise LoadError(path, a.line, f"{node.name}: an argument given by name "
                            f"({a.name}:=) is not supported")
        if b.opts is not None and a.name.lower() not in b.opts:
            raise LoadError(path, a.line, f"{node.name} \\{a.name} is not implemented by this "
                            "controller")


def task_types(modules: list[tuple[A.Module, str]]) -> frozenset[str]:
    """The task's RECORD and ALIAS types (lower case), made known to its values; a system
    type's name declared again, or one declared twice, is refused with its line."""
    records: dict[str, tuple[tuple[str, str], ...]] = {}
    aliases: dict[str, str] = {}
    for module, path in modules:
        decls: list[A.RecordDecl | A.AliasDecl] = [*module.records, *module.aliases]
        for decl in decls:
            key = decl.name.lower()
            if key in SYSTEM_TYPES or key in records or key in aliases:
                raise LoadError(path, decl.line, f"data type {decl.name} is declared again")
            if isinstance(decl, A.RecordDecl):
                records[key] = tuple((f.name.lower(), f.type.lower()) for f in decl.fields)
            else:
                aliases[key] = decl.type.lower()
    declare_types(records, aliases)
    return frozenset(records) | frozenset(aliases)


def _nested(st: Any) -> list[tuple[Any, ...]]:
    """The statement lists inside a statement (IF's branches, loops' bodies, TEST's cases)."""
    if isinstance(st, A.If):
        return [body for _, body in st.branches] + [st.orelse]
    if isinstance(st, A.While | A.For):
        return [st.body]
    if isinstance(st, A.Test):
        return [c.body for c in st.cases] + ([st.default] if st.default else [])
    return []


def _check_gotos(path: str, stmts: tuple[Any, ...], outer: frozenset[str]) -> None:
    """Every GOTO names a label of its own statement list or of one around it (RAPID: a GOTO
    never jumps into an IF, a loop or a TEST); a label is declared once per list."""
    here = [st.name.lower() for st in stmts if isinstance(st, A.Label)]
    for st in stmts:
        if isinstance(st, A.Label) and here.count(st.name.lower()) > 1:
            raise LoadError(path, st.line, f"label {st.name} declared twice")
    labels = outer | frozenset(here)
    for st in stmts:
        if isinstance(st, A.Goto) and st.label.lower() not in labels:
            raise LoadError(path, st.line, f"GOTO {st.label}: no label {st.label} in this "
                            "statement list or one around it")
        for body in _nested(st):
            _check_gotos(path, body, labels)


def _walk(node: Any):  # noqa: ANN202
    """Every AST node below `node` (statements, expressions, arguments)."""
    stack = [node]
    while stack:
        n = stack.pop()
        yield n
        if isinstance(n, A.NumberRow):
            continue
        if isinstance(n, A.Node):
            for name in n.__slots__ if hasattr(n, "__slots__") else ():
                stack.extend(_children(getattr(n, name, None)))


def _children(v: Any) -> list[Any]:
    if isinstance(v, A.Node):
        return [v]
    if isinstance(v, tuple):
        out: list[Any] = []
        for x in v:
            out.extend(_children(x))
        return out
    return []
