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
- `ERROR (LONG_JMP_ALL_ERR)` handles every error that reaches the routine (from it or its
  callees: intermediate routines' own handlers still see an error first);
- GOTO goes on from its label in the same statement list or one around it;
- a task may have several modules (their global data and routines shared, LOCAL ones each
  module's own, a PERS declared in several one datum; `loading`);
- an instruction or function the interpreter does not have, one of their optional arguments it
  does not implement, or a name nothing declares, is a LoadError naming its line when the
  module loads: nothing is ever skipped.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Any

from screwcal.rapid import RapidSyntaxError, parse_expression
from screwcal.rapid import ast as A  # noqa: N812 - the node classes, as A.If, A.Call
from simulators.rapid import worldzones
from simulators.rapid.builtins import predefined
from simulators.rapid.control import (
    ExitCycle,
    Fatal,
    Jump,
    Propagate,
    Retry,
    Return,
    Stopped,
    TryNext,
    at_label,
    label_index,
)
from simulators.rapid.errors import LONG_JMP_ALL_ERR, LoadError, RapidError, SettingError
from simulators.rapid.evaluation import Evaluator
from simulators.rapid.frame import Frame
from simulators.rapid.loading import (
    CHECKED,
    TaskScope,
    check_module,
    loaded_module,
    local_names,
    task_names,
    task_types,
)
from simulators.rapid.operator import EventLog, Pendant
from simulators.rapid.program import RapidText
from simulators.rapid.storage import LiveVar, Var
from simulators.rapid.values import (
    WORLD_ZONE_TYPES,
    convert,
    copy,
    default,
    num,
)

MAX_RETRIES = 4  # the controller's "No Of Retry"


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
        from simulators.rapid import library, motion, rawbytes, sockets, strings  # noqa: F401

        super().__init__()
        sources = [(text, path), *modules]
        self.modules = [(loaded_module(t, p), p) for t, p in sources]
        self.module = self.modules[0][0]
        self.log = log or EventLog()
        self.pendant = pendant or Pendant()
        self.services = services or {}
        self.overrides = {k.lower(): v for k, v in (overrides or {}).items()}
        self.routines, self.declared, self._paths = task_names(self.modules)
        self.types = task_types(self.modules)
        self.local_names = local_names(self.modules, self.routines, self.declared)
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
            if (t, p) not in CHECKED or len(sources) > 1:  # the same text passes the same checks
                check_module(module, p, TaskScope(self.routines, self.declared, self.types,
                                                  frozenset(self.system)))
                if len(CHECKED) >= 64:
                    CHECKED.clear()
                CHECKED.add((t, p))
        unknown = sorted(set(self.overrides) - set(self.declared))
        if unknown:
            given = self.overrides[unknown[0]]
            raise SettingError(f"{unknown[0]}={given}" if isinstance(given, str) else unknown[0],
                               f"no data named {', '.join(unknown)} to set in {path}")
        self._exec: dict[type, Callable[[Any, Frame], None]] = {
            A.Assign: self._assign, A.ProcCall: self._proc_call, A.If: self._if,
            A.While: self._while, A.For: self._for, A.Test: self._test,
            A.Return: self._return, A.Raise: self._raise, A.Simple: self._simple,
            A.Goto: self._goto, A.Label: at_label,
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
    def reset_data(self) -> None:
        """The modules' data at their declared values (load, PP to Main), overrides applied.
        A declaration whose value names data of a module further on is evaluated after it."""
        frame = Frame(A.Routine(0, 0, 0, 0, "PROC", "<load>", False, None, (), (), ()), {})
        self.data = {}
        waiting = list(self.declared.items())
        while waiting:
            later: list[tuple[str, A.DataDecl]] = []
            for key, d in waiting:
                try:
                    self.data[key] = self._initial(d, frame)
                except RapidError as err:
                    if err.name != "ERR_REFUNKDAT":
                        raise
                    later.append((key, d))
            if len(later) == len(waiting):  # nothing more resolves: the first one's error
                self.data[later[0][0]] = self._initial(later[0][1], frame)
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
        except RapidSyntaxError as err:
            why = f"{err.reason} at character {err.col}"
        except RapidError as err:
            why = err.detail
        raise SettingError(f"{d.name}={self.overrides[d.key]}",
                           f"not a {d.type} value ({why})") from None

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
                at = label_index(stmts, jump.label)
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


__all__ = ["LoadError", "RapidError", "Stopped", "Task"]
