"""The RAPID task: a program module's data and routines executed statement by statement, with
the controller's error handling (RAPID reference, "Error recovery"):

- an error in a routine runs its ERROR handler with ERRNO set; there RETRY executes the failing
  instruction again (at most MAX_RETRIES times, then ERR_EXCRTYMAX), TRYNEXT goes on after it,
  RETURN leaves the routine, RAISE (or reaching the handler's end) propagates the error to the
  caller's instruction, and so on up the call chain; an error nobody handles stops the program
  with its event-log message, as does an error inside an error handler;
- a handled error still writes a warning to the event log, unless the handler runs SkipWarn;
- UNDO handlers run when a routine is left early: PP to Main (`pp_to_main`), ExitCycle, or an
  error propagated out of it;
- an instruction or function the interpreter does not have, or a name nothing declares, is a
  LoadError naming its line when the module loads: nothing is ever skipped.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable, Sequence
from typing import Any

from screwcal.rapid import RapidSyntaxError, parse_expression, parse_module
from screwcal.rapid import ast as A  # noqa: N812 - the node classes, as A.If, A.Call
from simulators.rapid import worldzones
from simulators.rapid.builtins import BUILTINS, predefined
from simulators.rapid.control import (
    ExitCycle,
    Fatal,
    Jump,
    Propagate,
    Retry,
    Return,
    Stopped,
    TryNext,
)
from simulators.rapid.errors import LONG_JMP_ALL_ERR, LoadError, RapidError
from simulators.rapid.evaluation import Evaluator
from simulators.rapid.frame import Frame
from simulators.rapid.operator import EventLog, Pendant
from simulators.rapid.program import RapidText
from simulators.rapid.storage import LiveVar, Var
from simulators.rapid.values import (
    SYSTEM_TYPES,
    WORLD_ZONE_TYPES,
    convert,
    copy,
    declare_types,
    default,
    known_type,
    num,
)

MAX_RETRIES = 4  # the controller's "No Of Retry"


@functools.lru_cache(maxsize=16)
def loaded_module(text: str, path: str = "<module>") -> A.Module:
    """A program module's tree, parsed once per text and path: the tree is immutable, every
    task (an emulated cell each) runs the same one. Raises RapidSyntaxError as parse_module."""
    return parse_module(text, path)


# The (text, path) of the modules a task has loaded: what a controller refuses at load
# (`Task._check`) depends on nothing else (the built-ins and system data are fixed); 64 at most.
_CHECKED: set[tuple[str, str]] = set()


class Task(Evaluator):
    """One RAPID task running its program modules (`text` at `path`, then `modules`, pairs of
    text and path: a task of several modules shares their global data and routines).
    `services` are the controller's other parts the built-ins use (sockets, motion);
    `overrides` replace data declarations' values (the cell's own constants: a port, a bind
    address, joint limits)."""

    def __init__(self, text: str, path: str = "<module>", *, log: EventLog | None = None,
                 pendant: Pendant | None = None, services: dict[str, Any] | None = None,
                 overrides: dict[str, Any] | None = None,
                 modules: Sequence[tuple[str, str]] = ()):
        from simulators.rapid import (  # noqa: F401 - register built-ins
            library,
            motion,
            rawbytes,
            sockets,
        )

        super().__init__()
        sources = [(text, path), *modules]
        self.modules = [(loaded_module(t, p), p) for t, p in sources]
        self.module = self.modules[0][0]
        self.log = log or EventLog()
        self.pendant = pendant or Pendant()
        self.services = services or {}
        self.overrides = {k.lower(): v for k, v in (overrides or {}).items()}
        self.routines, self.declared, self._paths = _task_names(self.modules)
        self.types = _task_types(self.modules)
        main = self.routines.get("main")
        self.path = path if main is None else self._paths[id(main)]
        self.system = {k: Var("any", v, const=True) for k, v in predefined().items()}
        self.errno = 0.0
        self.stop_requested = threading.Event()
        self._stop = False
        self.state = "stopped"  # running, stopped
        self.stop_reason = ""
        self._unwound: list[Frame] = []
        self._skip = False
        self._stack: list[Frame] = []
        self._kept: list[Any] = []
        for (t, p), (module, _) in zip(sources, self.modules, strict=True):
            if (t, p) not in _CHECKED or len(sources) > 1:  # the same text passes the same checks
                self._check(module, p)
                if len(_CHECKED) >= 64:
                    _CHECKED.clear()
                _CHECKED.add((t, p))
        unknown = set(self.overrides) - set(self.declared)
        if unknown:
            raise LoadError(path, 1, f"no data named {', '.join(sorted(unknown))} to set")
        self._exec: dict[type, Callable[[Any, Frame], None]] = {
            A.Assign: self._assign, A.ProcCall: self._proc_call, A.If: self._if,
            A.While: self._while, A.For: self._for, A.Test: self._test,
            A.Return: self._return, A.Raise: self._raise, A.Simple: self._simple,
            A.Goto: self._goto, A.Label: _label,
        }
        self.data: dict[str, Any] = {}
        self.reset_data()
        if any(d.type.lower() in WORLD_ZONE_TYPES for m, _ in self.modules
               for d in (*m.data, *(x for r in m.routines for x in r.data))):
            worldzones.note_once(self)

    def path_of(self, routine: A.Routine) -> str:
        """The file of the module a routine is declared in."""
        return self._paths.get(id(routine), self.path)

    # ------------------------------------------------------------------ loading
    def _check(self, module: A.Module, path: str) -> None:
        """What a controller refuses at load: unknown instructions, functions, names, types."""
        module_names = set(self.declared)
        own = self.types
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
            names = local | module_names | set(self.system) | {"true", "false", "errno"}
            for node in _walk(r):
                self._check_node(node, names, path)
            for section in (r.body, r.error, r.undo, r.backward):
                if section:
                    _check_gotos(path, section, frozenset())

    def _check_node(self, node: Any, names: set[str], path: str) -> None:
        where = node.line if isinstance(node, A.Node) else 0
        if isinstance(node, A.ProcCall):
            if node.late is not None:
                raise LoadError(path, where, "late-bound procedure calls are not supported")
            r = self.routines.get(node.key)
            b = BUILTINS.get(node.key)
            if (r is None or r.kind != "PROC") and (b is None or b.kind != "proc"):
                raise LoadError(path, where,
                                f"instruction {node.name} is unknown to this controller")
            if r is None or r.kind != "PROC":
                _check_options(path, node, BUILTINS[node.key])
        elif isinstance(node, A.Call):
            r = self.routines.get(node.key)
            b = BUILTINS.get(node.key)
            if (r is None or r.kind != "FUNC") and (b is None or b.kind != "func"):
                raise LoadError(path, where,
                                f"function {node.name} is unknown to this controller")
            if r is None or r.kind != "FUNC":
                _check_options(path, node, BUILTINS[node.key])
        elif isinstance(node, A.Name) and node.key not in names:
            raise LoadError(path, where, f"no data named {node.name}")
        elif isinstance(node, A.Connect):
            raise LoadError(path, where, f"{type(node).__name__.upper()} is not supported")
        elif isinstance(node, A.Str) and len(node.value) > 80:
            raise LoadError(path, where, "string literal longer than 80 characters")

    def reset_data(self) -> None:
        """The modules' data at their declared values (load, PP to Main), overrides applied.
        A declaration whose value names data of a module further on is evaluated after it."""
        frame = Frame(A.Routine(0, 0, 0, 0, "PROC", "<load>", False, None, (), (), ()), {})
        self.data = {}
        waiting = list(self.declared.values())
        while waiting:
            later: list[A.DataDecl] = []
            for d in waiting:
                try:
                    self.data[d.key] = self._initial(d, frame)
                except RapidError as err:
                    if err.name != "ERR_REFUNKDAT":
                        raise
                    later.append(d)
            if len(later) == len(waiting):  # nothing more resolves: the first one's error
                self.data[later[0].key] = self._initial(later[0], frame)
            waiting = later

    def _initial(self, d: A.DataDecl, frame: Frame) -> Any:
        """A declared datum at its initial value (an override's, its own, or the default)."""
        dims = tuple(int(self.eval(e, frame)) for e in d.dims)
        if d.key in self.overrides and callable(self.overrides[d.key]):
            return LiveVar(d.type, self.overrides[d.key])
        if isinstance(self.overrides.get(d.key), RapidText):
            value = convert(d.type, self._set_value(d, self.overrides[d.key], frame), dims)
        elif d.key in self.overrides:
            value = convert(d.type, self.overrides[d.key], dims)
        elif d.value is not None:
            value = convert(d.type, self.eval(d.value, frame), dims)
        else:
            value = default(d.type, dims)
        return Var(d.type, value, dims, const=d.storage == "CONST")

    def _set_value(self, d: A.DataDecl, text: str, frame: Frame) -> Any:
        """The value of `--set NAME=VALUE` as the datum's type (a string's quotes optional)."""
        if d.type.lower() == "string" and not text.startswith('"'):
            text = '"' + text.replace('"', '""') + '"'
        try:
            e = parse_expression(text, "--set")
            self._kept.append(e)  # evaluation keeps closures by node: the node lives on
            return self.eval(e, frame)
        except (RapidSyntaxError, RapidError) as err:
            raise LoadError("--set", 0, f"{d.name}={text}: not a {d.type} value ({err})") \
                from None

    # ------------------------------------------------------------------ running
    def run(self, routine: str = "main") -> None:
        """Execute `routine` until the program stops (returns then; `stop_reason` says why)."""
        self.stop_requested.clear()
        self._stop = False
        self.state = "running"
        self.stop_reason = ""
        try:
            while True:
                try:
                    self.call(self.routines[routine.lower()], [], {}, 0)
                    self._stopped("program ended (main returned)", kind="info")
                    return
                except ExitCycle:
                    self.log.write("info", "ExitCycle", "main starts again")
                    continue
        except Stopped as s:
            self._stopped(s.reason, kind="info")
        except Fatal as f:
            self._stopped(self._unhandled(f.error), kind="error")
        except RapidError as e:
            self._stopped(self._unhandled(e), kind="error")
        except Propagate as p:
            self._stopped(self._unhandled(p.error), kind="error")

    def _unhandled(self, e: RapidError) -> str:
        return f"execution error {e.name} at {e.path or self.path}:{e.origin or e.line}: " \
            f"{e.detail}"

    def _stopped(self, reason: str, kind: str) -> None:
        self.state = "stopped"
        self.stop_reason = reason
        self.log.write(kind, "Program stopped", reason)

    def request_stop(self) -> None:
        self.stop_requested.set()
        self._stop = True

    def stopping(self) -> bool:
        return self._stop

    def pp_to_main(self) -> None:
        """PP to Main after a stop: the UNDO handlers of the routines the stop left (innermost
        first). The module's data keep their values (they are set at load)."""
        unwound, self._unwound = self._unwound, []
        self.stop_requested.clear()
        self._stop = False
        for frame in unwound:
            self._undo(frame)
        self.errno = 0.0

    def _undo(self, frame: Frame) -> None:
        if frame.routine.undo is None:
            return
        try:
            self.exec_block(frame.routine.undo, frame)
        except Return:
            pass
        except (RapidError, Propagate, Fatal) as err:
            error = err if isinstance(err, RapidError) else err.error
            self.log.write("error", "UNDO handler failed", self._unhandled(error))

    # ------------------------------------------------------------------ routines
    def call(self, r: A.Routine, pos: list[Any], opt: dict[str, Any], line: int) -> Any:
        """Run a routine: `pos` values or references (VAR/INOUT parameters), `opt` by name."""
        required, optional = self.parameters(r)
        if len(pos) != len(required):
            raise RapidError("ERR_ARGVALERR", f"{r.name} takes {len(required)} arguments",
                             line)
        local: dict[str, Any] = {}
        frame = Frame(r, local)
        for (key, by_ref, type_), v in zip(required, pos, strict=True):
            local[key] = v if by_ref else Var(type_, copy(v))
        if opt:
            for key, by_ref, type_ in optional:
                if key in opt:
                    v = opt[key]
                    local[key] = v if by_ref else Var(type_, copy(v))
        for d in r.data:
            dims = tuple(int(self.eval(e, frame)) for e in d.dims) if d.dims else ()
            value = convert(d.type, self.eval(d.value, frame), dims) if d.value is not None \
                else default(d.type, dims)
            frame.vars[d.key] = Var(d.type, value, dims, const=d.storage == "CONST")
        self._stack.append(frame)
        try:
            self.exec_block(r.body, frame)
            if r.kind == "FUNC":
                raise RapidError("ERR_NORETURN", f"{r.name} ended without RETURN", r.line)
            return None
        except Return as ret:
            return ret.value
        except Propagate as p:
            self._undo(frame)
            error = RapidError(p.error.errno, p.error.detail, line)
            error.origin = p.error.origin or p.error.line
            error.path = p.error.path
            raise error from None
        except ExitCycle:
            self._undo(frame)
            raise
        except Stopped:
            self._unwound.append(frame)
            raise
        finally:
            self._stack.pop()

    def exec_block(self, stmts: tuple[Any, ...], frame: Frame) -> None:
        """The statements in turn; a GOTO to a label of this list goes on from there (one to
        an enclosing list's label leaves it: the load checked that there is one)."""
        execs = self._exec
        while True:
            try:
                for st in stmts:
                    retries = 0
                    while True:
                        if self._stop:
                            raise Stopped("stopped by the controller")
                        try:
                            execs[type(st)](st, frame)
                            break
                        except RapidError as e:
                            if e.line is None:
                                e.line = st.line
                            if e.origin is None:
                                e.origin = e.line
                            if e.path is None:
                                e.path = self.path_of(frame.routine)
                            if self._handle(e, frame):  # RETRY
                                retries += 1
                                if retries > MAX_RETRIES:
                                    raise Propagate(RapidError("ERR_EXCRTYMAX",
                                                               line=st.line)) from None
                                continue
                            break  # TRYNEXT
                return
            except Jump as jump:
                at = _label_index(stmts, jump.label)
                if at is None:
                    raise
                stmts = stmts[at:]

    def _handle(self, e: RapidError, frame: Frame) -> bool:
        """The routine's ERROR handler for `e`: True for RETRY, False for TRYNEXT; raises to
        leave the routine (RETURN) or to propagate."""
        r = frame.routine
        if frame.in_handler:
            raise Fatal(e)
        if r.error is None or (r.error_numbers and not any(
                self.eval(n, frame) in (e.errno, LONG_JMP_ALL_ERR) for n in r.error_numbers)):
            raise Propagate(e)
        self.errno = float(e.errno)
        saved, self._skip = self._skip, False
        frame.in_handler, frame.error = True, e
        try:
            self.exec_block(r.error, frame)
        except Retry:
            return True
        except TryNext:
            return False
        finally:
            frame.in_handler = False
            if not self._skip:  # a recovered error still leaves its warning, unless SkipWarn
                self.log.write("warning", f"Execution error {e.name}",
                               f"{self.path_of(r)}:{e.line}: {e.detail} (recovered in {r.name})")
            self._skip = saved
        raise Propagate(e)  # the handler's end: as RAISE

    def skip_warning(self) -> None:
        """SkipWarn: the error being handled leaves no warning in the event log."""
        self._skip = True

    # ------------------------------------------------------------------ statements
    def _assign(self, st: A.Assign, frame: Frame) -> None:
        value = self.fn(st.value)(frame)
        target = self.ref(st.target, frame)
        if isinstance(target, Var) and target.const:
            raise RapidError("ERR_ARGVALERR", "a CONST cannot be assigned", st.line)
        target.set(value)

    def _proc_call(self, st: A.ProcCall, frame: Frame) -> None:
        self.invoke(st, frame, "PROC")

    def _if(self, st: A.If, frame: Frame) -> None:
        for cond, body in st.branches:
            if self._bool(cond, frame):
                self.exec_block(body, frame)
                return
        if st.orelse:
            self.exec_block(st.orelse, frame)

    def _while(self, st: A.While, frame: Frame) -> None:
        while self._bool(st.condition, frame):
            self.exec_block(st.body, frame)

    def _for(self, st: A.For, frame: Frame) -> None:
        start = self.eval(st.start_value, frame)
        stop = self.eval(st.stop_value, frame)
        step = self.eval(st.step, frame) if st.step is not None else \
            (1.0 if start <= stop else -1.0)
        key = st.var.lower()
        saved = frame.vars.get(key)
        var = frame.vars[key] = Var("num", start, const=True)
        i = start
        try:
            while (step > 0 and i <= stop) or (step < 0 and i >= stop):
                var.value = i
                self.exec_block(st.body, frame)
                i = num(i + step)
        finally:
            if saved is None:
                del frame.vars[key]
            else:
                frame.vars[key] = saved

    def _test(self, st: A.Test, frame: Frame) -> None:
        fn = self.fn
        subject = fn(st.subject)(frame)
        for case in st.cases:
            for label in case.labels:
                if fn(label)(frame) == subject:
                    self.exec_block(case.body, frame)
                    return
        if st.default is not None:
            self.exec_block(st.default, frame)

    def _return(self, st: A.Return, frame: Frame) -> None:
        value = None
        if st.value is not None:
            value = self.eval(st.value, frame)
            if frame.routine.type is not None:
                value = convert(frame.routine.type, value)
        raise Return(value)

    def _raise(self, st: A.Raise, frame: Frame) -> None:
        if frame.in_handler:
            if st.value is None and frame.error is not None:
                raise Propagate(frame.error)
            if st.value is None:
                raise RapidError("ERR_ILLRAISE", "RAISE without an error being handled", st.line)
            raise Propagate(RapidError(int(self.eval(st.value, frame)), "raised", st.line))
        if st.value is None:
            raise RapidError("ERR_ILLRAISE", "RAISE without an error number", st.line)
        n = self.eval(st.value, frame)
        raise RapidError(int(n), "raised by the program", st.line)

    def _simple(self, st: A.Simple, frame: Frame) -> None:
        kw = st.keyword.upper()
        if kw in ("RETRY", "TRYNEXT") and not frame.in_handler:
            raise RapidError("ERR_ARGVALERR", f"{kw} outside an error handler", st.line)
        if kw == "RETRY":
            raise Retry()
        if kw == "TRYNEXT":
            raise TryNext()
        raise Stopped(f"EXIT at {self.path_of(frame.routine)}:{st.line}")

    def _goto(self, st: A.Goto, frame: Frame) -> None:
        raise Jump(st.label.lower())

    def _bool(self, e: Any, frame: Frame) -> bool:
        v = self.fn(e)(frame)
        if v is not True and v is not False:
            raise RapidError("ERR_ARGVALERR", "a condition must be a bool", e.line)
        return v


def _task_names(modules: list[tuple[A.Module, str]]) -> tuple[
        dict[str, A.Routine], dict[str, A.DataDecl], dict[int, str]]:
    """A task's routines and data by name, and each routine's file. A name declared in two
    modules is refused (its second declaration's line), but for a PERS declared alike in
    both (persistents are shared: the one with a value initialises it)."""
    routines: dict[str, A.Routine] = {}
    data: dict[str, A.DataDecl] = {}
    paths: dict[int, str] = {}
    where: dict[str, str] = {}
    for module, path in modules:
        for d in module.data:
            first = data.get(d.key)
            if first is not None or d.key in routines:
                if first is not None and first.storage == d.storage == "PERS" and \
                        first.type.lower() == d.type.lower():
                    if first.value is None:
                        data[d.key] = d
                    continue
                raise LoadError(path, d.line, f"{d.name} is declared again (first in "
                                f"{where[d.key]})")
            data[d.key], where[d.key] = d, path
        for r in module.routines:
            if r.key in routines or r.key in data:
                raise LoadError(path, r.line, f"{r.name} is declared again (first in "
                                f"{where[r.key]})")
            routines[r.key], where[r.key], paths[id(r)] = r, path, path
    return routines, data, paths


def _check_options(path: str, node: A.Call | A.ProcCall, b: Any) -> None:
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


def _task_types(modules: list[tuple[A.Module, str]]) -> frozenset[str]:
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


def _label(st: A.Label, frame: Frame) -> None:
    """A label does nothing where it stands."""


def _label_index(stmts: tuple[Any, ...], label: str) -> int | None:
    for i, st in enumerate(stmts):
        if isinstance(st, A.Label) and st.name.lower() == label:
            return i
    return None


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


__all__ = ["LoadError", "RapidError", "Stopped", "Task"]
