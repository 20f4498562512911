"""Expressions and arguments of the RAPID task: what a value is (`eval`), what storage an
expression names (`ref`, for VAR, PERS and INOUT parameters and assignments), and the binding of
a call's arguments to a routine's or a built-in's parameters. The task's statements
(`interpreter.Task`) stand on it.

Values of nodes that never change (numbers, strings, names' keys, rows of numbers) are kept per
node: a pose's round trip evaluates the same few hundred nodes again and again.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from screwcal.rapid import ast as A  # noqa: N812 - the node classes, as A.Name, A.Call
from simulators.rapid.builtins import BUILTINS, Lazy
from simulators.rapid.errors import RapidError
from simulators.rapid.frame import Frame
from simulators.rapid.operators import BINARY
from simulators.rapid.storage import ElemRef, FieldRef, Var
from simulators.rapid.values import RArray, Record, num

Parameter = tuple[str, bool, str]  # a routine's parameter: lower-case name, by reference, type


class Evaluator:
    """The expression half of a task: its data, the system's, ERRNO and the per-node caches."""

    routines: dict[str, A.Routine]
    data: dict[str, Any]
    system: dict[str, Var]
    errno: float

    def __init__(self) -> None:
        # the task's keys of names that mean a module's LOCAL datum or routine, by node id
        self.local_names: dict[int, str] = {}
        # each expression node's closure (frame -> value), made at its first evaluation
        self._fns: dict[int, Callable[[Frame], Any]] = {}
        self._compilers: dict[type, Callable[[Any], Callable[[Frame], Any]]] = {
            A.Num: self._num, A.Str: self._str, A.Name: self._name, A.Index: self._index,
            A.Component: self._component, A.Aggregate: self._aggregate,
            A.NumberRow: self._number_row, A.Unary: self._unary, A.Binary: self._binary,
            A.Call: self._call,
        }
        self._plans: dict[int, tuple[Any, Any, tuple[Any, ...]]] = {}  # per call node
        self._parameters: dict[int, tuple[list[Parameter], list[Parameter]]] = {}

    def call(self, r: A.Routine, pos: list[Any], opt: dict[str, Any], line: int) -> Any:
        """Run a routine (the task's statements do)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ arguments
    # A call's plan, made once per call node (the routines and built-ins are fixed at load):
    # what it calls and, per argument, how it is passed: (how, name, expression, line).
    _POS, _POS_REF, _SWITCH, _OPT, _OPT_REF, _CONDITIONAL, _LAZY = range(7)

    def _plan(self, node: A.Call | A.ProcCall, kind: str) -> tuple[Any, Any, tuple[Any, ...]]:
        """The routine of that `kind` (FUNC or PROC) named by the call, else the built-in, and
        how each argument is passed: a VAR/INOUT parameter (a routine's) or a built-in's
        reference argument by reference, the others by value."""
        key = node.key
        r = self.routines.get(self.local_names.get(id(node), key))
        plan: list[tuple[int, str, Any, int]] = []
        if r is not None and r.kind == kind:
            required = [p for p in r.params if not p.optional]
            optional = {p.name.lower(): p for p in r.params if p.optional}
            for a in node.args:
                if a.name is None:
                    n = sum(1 for step in plan if step[0] <= self._POS_REF)
                    p = required[n] if n < len(required) else None
                    by_ref = p is not None and p.mode is not None
                    plan.append((self._POS_REF, "", a.value, a.line) if by_ref else
                                (self._POS, "", self.fn(a.value), a.line))
                    continue
                name, p = a.name.lower(), optional.get(a.name.lower())
                if a.conditional:
                    by_ref = p is not None and p.mode is not None
                    plan.append(self._conditional(a, name, by_ref))
                elif a.value is None:
                    plan.append((self._SWITCH, name, None, a.line))
                elif p is not None and p.mode is not None:
                    plan.append((self._OPT_REF, name, a.value, a.line))
                else:
                    plan.append((self._OPT, name, self.fn(a.value), a.line))
            return r, None, tuple(plan)
        b = BUILTINS[key]
        for a in node.args:
            if a.name is None:
                n = sum(1 for step in plan if step[0] <= self._POS_REF or step[0] == self._LAZY)
                plan.append((self._POS_REF, "", a.value, a.line) if n in b.refs else
                            (self._LAZY, "", a.value, a.line) if n in b.lazy else
                            (self._POS, "", self.fn(a.value), a.line))
            elif a.conditional:
                name = a.name.lower()
                plan.append(self._conditional(a, name, name in b.optrefs))
            elif a.value is None:
                plan.append((self._SWITCH, a.name.lower(), None, a.line))
            else:
                name = a.name.lower()
                plan.append((self._OPT_REF, name, a.value, a.line) if name in b.optrefs else
                            (self._OPT, name, self.fn(a.value), a.line))
        return None, b, tuple(plan)

    def _conditional(self, a: A.Argument, name: str, by_ref: bool) -> tuple[int, str, Any, int]:
        """`\\Name?datum`: passed (by reference or value) when the datum, the caller's own
        optional parameter, is present; left out when it is not."""
        base = a.value
        while isinstance(base, A.Component | A.Index):
            base = base.base
        if not isinstance(base, A.Name):
            raise RapidError("ERR_ARGVALERR", f"\\{a.name}?: a datum's name expected", a.line)
        get = (lambda frame, e=a.value: self.ref(e, frame)) if by_ref else self.fn(a.value)
        return (self._CONDITIONAL, name, (base.key, get), a.line)

    def parameters(self, r: A.Routine) -> tuple[list[Parameter], list[Parameter]]:
        """A routine's required and optional parameters (lower-case name, passed by reference
        (VAR, PERS, INOUT), type), in their order, once per routine."""
        got = self._parameters.get(id(r))
        if got is None:
            got = self._parameters[id(r)] = (
                [(p.name.lower(), bool(p.mode), p.type) for p in r.params if not p.optional],
                [(p.name.lower(), bool(p.mode), p.type) for p in r.params if p.optional])
        return got

    def _args(self, plan: tuple[Any, ...], frame: Frame) -> tuple[list[Any], dict[str, Any]]:
        """A call's arguments, in their order: values, references, switches (True)."""
        pos: list[Any] = []
        opt: dict[str, Any] = {}
        for how, name, e, _line in plan:  # e: a closure by value, a node by reference
            if how == 0:  # _POS
                pos.append(e(frame))
            elif how == 1:  # _POS_REF
                pos.append(self.ref(e, frame))
            elif how == 2:  # _SWITCH
                opt[name] = True
            elif how == 3:  # _OPT
                opt[name] = e(frame)
            elif how == 4:  # _OPT_REF
                opt[name] = self.ref(e, frame)
            elif how == 6:  # _LAZY
                pos.append(Lazy(e, frame, functools.partial(self.eval, e, frame)))
            else:  # _CONDITIONAL: (the datum's key, its getter)
                key, get = e
                if key in frame.vars or key in self.data:
                    opt[name] = get(frame)
        return pos, opt

    # ------------------------------------------------------------------ expressions
    # An expression node is compiled, at its first evaluation, into a closure of the frame
    # that calls its operands' closures directly: no dispatch on the node's type, no lookup
    # of its attributes, its constants (numbers, strings, keys, rows) computed once.
    def eval(self, e: Any, frame: Frame) -> Any:
        return (self._fns.get(id(e)) or self._compile(e))(frame)

    def fn(self, e: Any) -> Callable[[Frame], Any]:
        """The closure that evaluates expression `e` in a frame."""
        return self._fns.get(id(e)) or self._compile(e)

    def _compile(self, e: Any) -> Callable[[Frame], Any]:
        f = self._fns[id(e)] = self._compilers[type(e)](e)  # nodes live as long as the task
        return f

    def ref(self, e: Any, frame: Frame) -> Any:
        """The storage an expression names: a Var, an array element, a record component."""
        if isinstance(e, A.Name):
            return self._lookup(e.key, frame, e.line, self.local_names.get(id(e)))
        if isinstance(e, A.Index):
            arr = self.eval(e.base, frame)
            for k, ie in enumerate(e.indices):
                if not isinstance(arr, RArray):
                    raise RapidError("ERR_ARGVALERR", "not an array", e.line)
                i = arr.index(self.eval(ie, frame))
                if k == len(e.indices) - 1:
                    return ElemRef(arr, i)
                arr = arr.items[i]
        if isinstance(e, A.Component):
            rec = self.eval(e.base, frame)
            if not isinstance(rec, Record) or e.name.lower() not in rec.f:
                raise RapidError("ERR_ARGVALERR", f"no component {e.name}", e.line)
            return FieldRef(rec, e.name.lower())
        raise RapidError("ERR_ARGNOTVAR", "this argument must be a variable", e.line)

    def _lookup(self, key: str, frame: Frame, line: int, data_key: str | None = None) -> Any:
        """The storage of a name: the routine's own, the task's (`data_key` for a module's
        LOCAL datum), the system's."""
        v = frame.vars.get(key)
        if v is None:
            v = self.data.get(data_key or key)
            if v is None:
                v = self.system.get(key)
                if v is None:
                    if key == "errno":
                        return Var("num", self.errno, const=True)
                    raise RapidError("ERR_REFUNKDAT", f"no data named {key}", line)
        return v

    def _num(self, e: A.Num) -> Callable[[Frame], Any]:
        return _constant(lambda: num(e.value))

    def _str(self, e: A.Str) -> Callable[[Frame], Any]:
        value = e.value
        return lambda frame: value

    def _name(self, e: A.Name) -> Callable[[Frame], Any]:
        key, line = e.key, e.line
        data_key = self.local_names.get(id(e), key)

        def name(frame: Frame) -> Any:
            v = frame.vars.get(key)
            if v is not None:
                return v.value
            v = self.data.get(data_key)
            if v is not None:
                return v.value
            if key == "true":
                return True
            if key == "false":
                return False
            if key == "errno":
                return self.errno
            return self._lookup(key, frame, line, data_key).value
        return name

    def _index(self, e: A.Index) -> Callable[[Frame], Any]:
        base, indices, line = self.fn(e.base), [self.fn(i) for i in e.indices], e.line

        def index(frame: Frame) -> Any:
            arr = base(frame)
            for i in indices:
                if not isinstance(arr, RArray):
                    raise RapidError("ERR_ARGVALERR", "not an array", line)
                try:
                    arr = arr.items[arr.index(i(frame))]
                except RapidError as err:
                    err.line = line
                    raise
            return arr
        return index

    def _component(self, e: A.Component) -> Callable[[Frame], Any]:
        base, key, name, line = self.fn(e.base), e.name.lower(), e.name, e.line

        def component(frame: Frame) -> Any:
            rec = base(frame)
            try:
                return rec.f[key]
            except (AttributeError, KeyError):
                raise RapidError("ERR_ARGVALERR", f"no component {name}", line) from None
        return component

    def _number_row(self, e: A.NumberRow) -> Callable[[Frame], Any]:
        row = _constant(lambda: [num(n.value) for n in e.items])
        return lambda frame: list(row(frame))  # its items made afresh on each access

    def _aggregate(self, e: A.Aggregate) -> Callable[[Frame], Any]:
        items = [self.fn(i) for i in e.items]
        return lambda frame: [item(frame) for item in items]

    def _unary(self, e: A.Unary) -> Callable[[Frame], Any]:
        operand, op, line = self.fn(e.operand), e.op, e.line

        def unary(frame: Frame) -> Any:
            v = operand(frame)
            if op == "NOT":
                if not isinstance(v, bool):
                    raise RapidError("ERR_ARGVALERR", "NOT needs a bool", line)
                return not v
            if not isinstance(v, float):
                raise RapidError("ERR_ARGVALERR", f"{op} needs a num", line)
            return -v if op == "-" else v
        return unary

    def _binary(self, e: A.Binary) -> Callable[[Frame], Any]:
        left, right, op, line = self.fn(e.left), self.fn(e.right), e.op, e.line
        operator = BINARY.get(op, _no_operator)

        def binary(frame: Frame) -> Any:
            a = left(frame)
            b = right(frame)
            try:
                return operator(a, b)
            except RapidError as err:
                err.line = line
                raise
            except (TypeError, KeyError):
                raise RapidError("ERR_ARGVALERR", f"{op} of {type(a).__name__} and "
                                 f"{type(b).__name__}", line) from None
        return binary

    def _call(self, e: A.Call) -> Callable[[Frame], Any]:
        plan = self._plans.get(id(e))
        if plan is None:
            plan = self._plans[id(e)] = self._plan(e, "FUNC")
        _, b, args = plan
        if b is None or any(how != self._POS for how, *_ in args):
            return lambda frame: self.invoke(e, frame, "FUNC")
        # a built-in function of values only (StrLen, StrPart, NumToStr ...): invoke's steps
        values, fn, line = [value for _, _, value, _ in args], b.fn, e.line

        def builtin(frame: Frame) -> Any:
            pos = [value(frame) for value in values]
            try:
                return fn(self, pos, {})
            except RapidError as err:
                if err.line is None:
                    err.line = line
                raise
        return builtin

    def invoke(self, node: A.Call | A.ProcCall, frame: Frame, kind: str) -> Any:
        """A function call's value, or a procedure call's effect: the module's routine of that
        `kind` (FUNC or PROC) when there is one, else the built-in of that name."""
        plan = self._plans.get(id(node))
        if plan is None:
            plan = self._plans[id(node)] = self._plan(node, kind)
        r, b, args = plan
        pos, opt = self._args(args, frame)
        if r is not None:
            return self.call(r, pos, opt, node.line)
        try:
            return b.fn(self, pos, opt)
        except RapidError as err:
            if err.line is None:
                err.line = node.line
            raise


def _constant(compute: Callable[[], Any]) -> Callable[[Frame], Any]:
    """A literal's closure: its value computed once; a literal no num can hold (beyond 32 bits)
    raises where it is evaluated, after the operands before it, as every evaluation."""
    try:
        value = compute()
    except RapidError as err:
        detail = err.detail

        def invalid(frame: Frame) -> Any:
            raise RapidError("ERR_NUMOVERFLOW", detail)
        return invalid
    return lambda frame: value


def _no_operator(a: Any, b: Any) -> Any:
    raise KeyError
