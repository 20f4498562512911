"""Expressions and arguments of the RAPID task: what a value is (`eval`), what storage an
expression names (`ref`, for VAR, PERS and INOUT parameters and assignments), and the binding of
a call's arguments to a routine's or a built-in's parameters. The task's statements
(`interpreter.Task`) stand on it.

Values of nodes that never change (numbers, strings, names' keys, rows of numbers) are kept per
node: a pose's round trip evaluates the same few hundred nodes again and again.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from screwcal.rapid import ast as A  # noqa: N812 - the node classes, as A.Name, A.Call
from simulators.rapid.builtins import BUILTINS
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
        self._eval: dict[type, Callable[[Any, Frame], Any]] = {
            A.Num: self._num, A.Str: self._str, A.Name: self._name, A.Index: self._index,
            A.Component: self._component, A.Aggregate: self._aggregate,
            A.NumberRow: self._number_row, A.Unary: self._unary, A.Binary: self._binary,
            A.Call: self._call,
        }
        self._nums: dict[int, float] = {}
        self._keys: dict[int, str] = {}
        self._strs: dict[int, str] = {}  # a Name node's lower-case key (nodes live as long)
        self._rows: dict[int, tuple[A.NumberRow, list[float]]] = {}
        self._plans: dict[int, tuple[Any, Any, tuple[Any, ...]]] = {}  # per call node
        self._parameters: dict[int, tuple[list[Parameter], list[Parameter]]] = {}

    def call(self, r: A.Routine, pos: list[Any], opt: dict[str, Any], line: int) -> Any:
        """Run a routine (the task's statements do)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ arguments
    # A call's plan, made once per call node (the routines and built-ins are fixed at load):
    # what it calls and, per argument, how it is passed: (how, name, expression, line).
    _POS, _POS_REF, _SWITCH, _OPT, _OPT_REF, _CONDITIONAL = range(6)

    def _plan(self, node: A.Call | A.ProcCall, kind: str) -> tuple[Any, Any, tuple[Any, ...]]:
        """The routine of that `kind` (FUNC or PROC) named by the call, else the built-in, and
        how each argument is passed: a VAR/INOUT parameter (a routine's) or a built-in's
        reference argument by reference, the others by value."""
        key = node.key
        r = self.routines.get(key)
        plan: list[tuple[int, str, Any, int]] = []
        if r is not None and r.kind == kind:
            required = [p for p in r.params if not p.optional]
            optional = {p.name.lower(): p for p in r.params if p.optional}
            for a in node.args:
                if a.name is None:
                    n = sum(1 for step in plan if step[0] <= self._POS_REF)
                    p = required[n] if n < len(required) else None
                    plan.append((self._POS_REF if p is not None and p.mode is not None
                                 else self._POS, "", a.value, a.line))
                    continue
                name, p = a.name.lower(), optional.get(a.name.lower())
                how = self._SWITCH if a.value is None else self._OPT_REF \
                    if p is not None and p.mode is not None else self._OPT
                plan.append((how, name, a.value, a.line))
            return r, None, tuple(plan)
        b = BUILTINS[key]
        for a in node.args:
            if a.name is None:
                n = sum(1 for step in plan if step[0] <= self._POS_REF)
                plan.append((self._POS_REF if n in b.refs else self._POS, "", a.value, a.line))
            elif a.conditional:
                plan.append((self._CONDITIONAL, "", None, a.line))
            elif a.value is None:
                plan.append((self._SWITCH, a.name.lower(), None, a.line))
            else:
                name = a.name.lower()
                plan.append((self._OPT_REF if name in b.optrefs else self._OPT, name, a.value,
                             a.line))
        return None, b, tuple(plan)

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
        evals = self._eval
        for how, name, e, line in plan:
            if how == 0:  # _POS
                pos.append(evals[type(e)](e, frame))
            elif how == 1:  # _POS_REF
                pos.append(self.ref(e, frame))
            elif how == 2:  # _SWITCH
                opt[name] = True
            elif how == 3:  # _OPT
                opt[name] = evals[type(e)](e, frame)
            elif how == 4:  # _OPT_REF
                opt[name] = self.ref(e, frame)
            else:
                raise RapidError("ERR_ARGVALERR", "conditional arguments are not supported",
                                 line)
        return pos, opt

    # ------------------------------------------------------------------ expressions
    def eval(self, e: Any, frame: Frame) -> Any:
        return self._eval[type(e)](e, frame)

    def ref(self, e: Any, frame: Frame) -> Any:
        """The storage an expression names: a Var, an array element, a record component."""
        if isinstance(e, A.Name):
            var = self._lookup(e.key, frame, e.line)
            return var
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

    def _lookup(self, key: str, frame: Frame, line: int) -> Any:
        v = frame.vars.get(key)
        if v is None:
            v = self.data.get(key)
            if v is None:
                v = self.system.get(key)
                if v is None:
                    if key == "errno":
                        return Var("num", self.errno, const=True)
                    raise RapidError("ERR_REFUNKDAT", f"no data named {key}", line)
        return v

    def _num(self, e: A.Num, frame: Frame) -> float:
        v = self._nums.get(id(e))
        if v is None:
            v = self._nums[id(e)] = num(e.value)
        return v

    def _str(self, e: A.Str, frame: Frame) -> str:
        v = self._strs.get(id(e))
        if v is None:
            v = self._strs[id(e)] = e.value
        return v

    def _name(self, e: A.Name, frame: Frame) -> Any:
        key = self._keys.get(id(e))
        if key is None:
            key = self._keys[id(e)] = e.key
        v = frame.vars.get(key)
        if v is not None:
            return v.value
        v = self.data.get(key)
        if v is not None:
            return v.value
        if key == "true":
            return True
        if key == "false":
            return False
        if key == "errno":
            return self.errno
        return self._lookup(key, frame, e.line).value

    def _index(self, e: A.Index, frame: Frame) -> Any:
        evals = self._eval
        base = e.base
        arr = evals[type(base)](base, frame)
        for ie in e.indices:
            if not isinstance(arr, RArray):
                raise RapidError("ERR_ARGVALERR", "not an array", e.line)
            try:
                arr = arr.items[arr.index(evals[type(ie)](ie, frame))]
            except RapidError as err:
                err.line = e.line
                raise
        return arr

    def _component(self, e: A.Component, frame: Frame) -> Any:
        base = e.base
        rec = self._eval[type(base)](base, frame)
        try:
            return rec.f[e.name.lower()]
        except (AttributeError, KeyError):
            raise RapidError("ERR_ARGVALERR", f"no component {e.name}", e.line) from None

    def _number_row(self, e: A.NumberRow, frame: Frame) -> list[float]:
        # keyed by the row (a node of the tree); its items are made afresh on each access
        row = self._rows.get(id(e))
        if row is None:
            row = self._rows[id(e)] = (e, [num(n.value) for n in e.items])
        return list(row[1])

    def _aggregate(self, e: Any, frame: Frame) -> list[Any]:
        return [self.eval(i, frame) for i in e.items]

    def _unary(self, e: A.Unary, frame: Frame) -> Any:
        operand = e.operand
        v = self._eval[type(operand)](operand, frame)
        if e.op == "NOT":
            if not isinstance(v, bool):
                raise RapidError("ERR_ARGVALERR", "NOT needs a bool", e.line)
            return not v
        if not isinstance(v, float):
            raise RapidError("ERR_ARGVALERR", f"{e.op} needs a num", e.line)
        return -v if e.op == "-" else v

    def _binary(self, e: A.Binary, frame: Frame) -> Any:
        evals = self._eval  # the dispatch of `eval`, inline: a binary is the commonest node
        left, right = e.left, e.right
        a = evals[type(left)](left, frame)
        b = evals[type(right)](right, frame)
        op = e.op
        try:
            return BINARY[op](a, b)
        except RapidError as err:
            err.line = e.line
            raise
        except (TypeError, KeyError):
            raise RapidError("ERR_ARGVALERR", f"{op} of {type(a).__name__} and "
                             f"{type(b).__name__}", e.line) from None

    def _call(self, e: A.Call, frame: Frame) -> Any:
        return self.invoke(e, frame, "FUNC")

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
