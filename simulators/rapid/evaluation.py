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

    def call(self, r: A.Routine, pos: list[Any], opt: dict[str, Any], line: int) -> Any:
        """Run a routine (the task's statements do)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ arguments
    def _bind(self, args: tuple[A.Argument, ...], frame: Frame, r: A.Routine
              ) -> tuple[list[Any], dict[str, Any]]:
        required = [p for p in r.params if not p.optional]
        optional = {p.name.lower(): p for p in r.params if p.optional}
        pos: list[Any] = []
        opt: dict[str, Any] = {}
        for a in args:
            if a.name is None:
                p = required[len(pos)] if len(pos) < len(required) else None
                by_ref = p is not None and p.mode is not None
                pos.append(self.ref(a.value, frame) if by_ref else self.eval(a.value, frame))
            else:
                p = optional.get(a.name.lower())
                if a.value is None:
                    opt[a.name.lower()] = True
                elif p is not None and p.mode is not None:
                    opt[a.name.lower()] = self.ref(a.value, frame)
                else:
                    opt[a.name.lower()] = self.eval(a.value, frame)
        return pos, opt

    def _builtin_args(self, args: tuple[A.Argument, ...], frame: Frame, b: Any
                      ) -> tuple[list[Any], dict[str, Any]]:
        pos: list[Any] = []
        opt: dict[str, Any] = {}
        for a in args:
            if a.name is None:
                pos.append(self.ref(a.value, frame) if len(pos) in b.refs
                           else self.eval(a.value, frame))
            elif a.conditional:
                raise RapidError("ERR_ARGVALERR", "conditional arguments are not supported",
                                 a.line)
            elif a.value is None:
                opt[a.name.lower()] = True
            else:
                key = self._keys.get(id(a))
                if key is None:
                    key = self._keys[id(a)] = a.name.lower()
                opt[key] = self.ref(a.value, frame) if key in b.optrefs \
                    else self.eval(a.value, frame)
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
        arr = self.eval(e.base, frame)
        for ie in e.indices:
            if not isinstance(arr, RArray):
                raise RapidError("ERR_ARGVALERR", "not an array", e.line)
            try:
                arr = arr.items[arr.index(self.eval(ie, frame))]
            except RapidError as err:
                err.line = e.line
                raise
        return arr

    def _component(self, e: A.Component, frame: Frame) -> Any:
        rec = self.eval(e.base, frame)
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
        v = self.eval(e.operand, frame)
        if e.op == "NOT":
            if not isinstance(v, bool):
                raise RapidError("ERR_ARGVALERR", "NOT needs a bool", e.line)
            return not v
        if not isinstance(v, float):
            raise RapidError("ERR_ARGVALERR", f"{e.op} needs a num", e.line)
        return -v if e.op == "-" else v

    def _binary(self, e: A.Binary, frame: Frame) -> Any:
        a = self.eval(e.left, frame)
        b = self.eval(e.right, frame)
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
        key = self._keys.get(id(node))
        if key is None:
            key = self._keys[id(node)] = node.key
        r = self.routines.get(key)
        if r is not None and r.kind == kind:
            pos, opt = self._bind(node.args, frame, r)
            return self.call(r, pos, opt, node.line)
        b = BUILTINS[key]
        pos, opt = self._builtin_args(node.args, frame, b)
        try:
            return b.fn(self, pos, opt)
        except RapidError as err:
            if err.line is None:
                err.line = node.line
            raise
