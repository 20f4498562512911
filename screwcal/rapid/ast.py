"""The nodes of a parsed RAPID module: frozen dataclasses, each knowing where it starts (1-based
line and column) and the span of its text (`start`, `end`: offsets, so that a rewrite can change
those characters and nothing else).

Names keep the case they are written in; RAPID compares them without case (`key` is the
lower-case form).
"""

from __future__ import annotations

from dataclasses import MISSING, field, fields
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dataclasses import dataclass
else:  # each node's __init__ is built from its fields below (_slot_setting_init): the
    # dataclass's own, compiled for each class and thrown away, is never made (a tenth of
    # loading the parser)
    from dataclasses import dataclass as _dataclass
    from functools import partial

    dataclass = partial(_dataclass, init=False)


@dataclass(frozen=True, slots=True)
class Node:
    line: int
    col: int
    start: int
    end: int


# ---------------------------------------------------------------- expressions
@dataclass(frozen=True, slots=True)
class Num(Node):
    """A numeric literal as written (with its sign when one is written before it: `-1.5`)."""

    text: str

    @property
    def value(self) -> float:
        t = self.text.replace(" ", "").lower()
        sign = -1 if t.startswith("-") else 1
        t = t.lstrip("+-")
        if t.startswith(("0x", "0b", "0o")):
            return float(sign * int(t, 0))
        return sign * float(t)


@dataclass(frozen=True, slots=True)
class Str(Node):
    """A string literal: `text` as written with its quotes, `value` what it holds."""

    text: str

    @property
    def value(self) -> str:
        body = self.text[1:-1].replace('""', '"')
        out, i = [], 0
        while i < len(body):
            if body[i] == "\\" and body[i + 1:i + 2] == "\\":
                out.append("\\")
                i += 2
            elif body[i] == "\\" and len(body) >= i + 3:
                try:
                    out.append(chr(int(body[i + 1:i + 3], 16)))
                    i += 3
                    continue
                except ValueError:
                    out.append("\\")
                    i += 1
            else:
                out.append(body[i])
                i += 1
        return "".join(out)


@dataclass(frozen=True, slots=True)
class Name(Node):
    """A name used as a value: a datum, a parameter, TRUE/FALSE, a constant such as v100."""

    name: str

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class Index(Node):
    """`base{i, j}`: an array element."""

    base: Expr
    indices: tuple[Expr, ...]


@dataclass(frozen=True, slots=True)
class Component(Node):
    """`base.name`: a record component."""

    base: Expr
    name: str


@dataclass(frozen=True, slots=True)
class Aggregate(Node):
    """`[a, b, ...]`: the value of a record or array."""

    items: tuple[Expr, ...]


@dataclass(frozen=True, slots=True)
class NumberRow(Node):
    """`[n, n, ...]` of numeric literals on one line (most of every robtarget), kept compact:
    a module may hold hundreds of thousands of numbers. `texts` as written (with their sign),
    `starts` their offsets; `items` gives them as Num nodes, as an Aggregate has them."""

    texts: tuple[str, ...]
    starts: tuple[int, ...]

    @property
    def items(self) -> tuple[Num, ...]:
        shift = self.col - self.start
        return tuple(Num(self.line, a + shift, a, a + len(t), t)
                     for t, a in zip(self.texts, self.starts, strict=True))


@dataclass(frozen=True, slots=True)
class Unary(Node):
    op: str  # "-", "+", "NOT"
    operand: Expr


@dataclass(frozen=True, slots=True)
class Binary(Node):
    op: str  # upper case: + - * / DIV MOD < <= = >= > <> AND OR XOR
    left: Expr
    right: Expr


@dataclass(frozen=True, slots=True)
class Argument(Node):
    """One argument of a call: positional (`name` None), optional or named (`\\Name`,
    `\\Name:=value`, `Name:=value`), conditional (`\\Name?datum`)."""

    value: Expr | None
    name: str | None = None
    optional: bool = False  # written with a backslash
    conditional: bool = False  # `\Name?datum`


@dataclass(frozen=True, slots=True)
class Call(Node):
    """A function call in an expression: `name(args)`; `late` when the name is an expression
    between percent signs (`%"f" + s%(...)`)."""

    name: str
    args: tuple[Argument, ...]
    late: Expr | None = None

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class Placeholder(Node):
    """A part of the program not yet written, as the program editor leaves it: `<SMT>` (a
    statement), `<EXP>` (an expression), `<ARG>` (an argument), `<DDN>` (a declaration)...
    (RAPID kernel reference, placeholders). A module holding them loads; the controller stops
    with an execution error when it reaches one. `kind` without the brackets (SMT, EXP...)."""

    kind: str


Expr = Num | Str | Name | Index | Component | Aggregate | NumberRow | Unary | Binary | Call \
    | Placeholder


# ---------------------------------------------------------------- statements
@dataclass(frozen=True, slots=True)
class Assign(Node):
    target: Expr
    value: Expr


@dataclass(frozen=True, slots=True)
class ProcCall(Node):
    """A procedure call (every instruction: `MoveL p, v, z, tool \\WObj:=w;`), or a late-bound
    one (`%name% args;`: `name` is empty and `late` the expression)."""

    name: str
    args: tuple[Argument, ...]
    late: Expr | None = None

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class If(Node):
    """IF/ELSEIF/ELSE: `branches` is (condition, body) pairs in order; `compact` for
    `IF cond statement;`."""

    branches: tuple[tuple[Expr, tuple[Stmt, ...]], ...]
    orelse: tuple[Stmt, ...] = ()
    compact: bool = False


@dataclass(frozen=True, slots=True)
class While(Node):
    condition: Expr
    body: tuple[Stmt, ...]


@dataclass(frozen=True, slots=True)
class For(Node):
    var: str
    start_value: Expr
    stop_value: Expr
    step: Expr | None
    body: tuple[Stmt, ...]


@dataclass(frozen=True, slots=True)
class Case(Node):
    labels: tuple[Expr, ...]
    body: tuple[Stmt, ...]


@dataclass(frozen=True, slots=True)
class Test(Node):
    subject: Expr
    cases: tuple[Case, ...]
    default: tuple[Stmt, ...] | None = None


@dataclass(frozen=True, slots=True)
class Label(Node):
    name: str


@dataclass(frozen=True, slots=True)
class Goto(Node):
    label: str


@dataclass(frozen=True, slots=True)
class Return(Node):
    value: Expr | None


@dataclass(frozen=True, slots=True)
class Raise(Node):
    value: Expr | None


@dataclass(frozen=True, slots=True)
class Simple(Node):
    """RETRY, TRYNEXT or EXIT."""

    keyword: str


@dataclass(frozen=True, slots=True)
class Connect(Node):
    """`CONNECT interrupt WITH trap;`"""

    target: Expr
    trap: str


Stmt = Assign | ProcCall | If | While | For | Test | Label | Goto | Return | Raise | Simple \
    | Connect | Placeholder


# ---------------------------------------------------------------- declarations
@dataclass(frozen=True, slots=True)
class DataDecl(Node):
    """`[LOCAL|TASK] CONST|VAR|PERS type name[{dims}] [:= value];`"""

    storage: str  # CONST, VAR, PERS
    scope: str | None  # LOCAL, TASK or None
    type: str
    name: str
    dims: tuple[Expr, ...]
    value: Expr | None

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class Param(Node):
    """One parameter: `mode` is None, VAR, PERS or INOUT; `optional` when written `\\...`;
    `alternatives` holds the others of `\\num a | num b`; `dims` the number of `*`."""

    mode: str | None
    type: str
    name: str
    optional: bool = False
    dims: int = 0
    alternatives: tuple[Param, ...] = ()


@dataclass(frozen=True, slots=True)
class Routine(Node):
    """PROC, FUNC or TRAP with its handlers (None: no such handler)."""

    kind: str  # PROC, FUNC, TRAP
    name: str
    local: bool
    type: str | None  # a FUNC's value type
    params: tuple[Param, ...]
    data: tuple[DataDecl, ...]
    body: tuple[Stmt, ...]
    backward: tuple[Stmt, ...] | None = None
    error: tuple[Stmt, ...] | None = None
    error_numbers: tuple[Expr, ...] = ()  # ERROR (n1, n2)
    undo: tuple[Stmt, ...] | None = None

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class RecordField(Node):
    type: str
    name: str


@dataclass(frozen=True, slots=True)
class RecordDecl(Node):
    name: str
    local: bool
    fields: tuple[RecordField, ...]


@dataclass(frozen=True, slots=True)
class AliasDecl(Node):
    type: str
    name: str
    local: bool


@dataclass(frozen=True, slots=True)
class Comment(Node):
    text: str  # from `!` to the end of the line


@dataclass(frozen=True, slots=True)
class Module(Node):
    name: str
    attributes: tuple[str, ...]  # SYSMODULE, NOSTEPIN, VIEWONLY, READONLY, NOVIEW (upper case)
    data: tuple[DataDecl, ...]
    routines: tuple[Routine, ...]
    records: tuple[RecordDecl, ...] = ()
    aliases: tuple[AliasDecl, ...] = ()
    comments: tuple[Comment, ...] = field(default=(), repr=False)
    header: str = ""  # a saved module's header as written: `%%%`, VERSION:1 ..., `%%%`
    placeholders: tuple[Placeholder, ...] = ()  # every one, where it is, in text order


# ---------------------------------------------------------------- construction
def _slot_setting_init(cls: type[Node]) -> None:
    """Give a node class an `__init__` that stores each field through its slot's descriptor.

    A frozen dataclass's own `__init__` stores every field with `object.__setattr__`, looked up
    on `object` at each store: a module of 10,000 robtargets builds 150,000 nodes, and that
    was half of parsing it. The signature, the defaults and what is stored are the dataclass's
    (assigning to a field afterwards still raises FrozenInstanceError)."""
    names, params, env = [], [], {}
    for k, f in enumerate(fields(cls)):
        env[f"_set{k}"] = getattr(cls, f.name).__set__  # the slot's member descriptor
        if f.default is not MISSING:
            env[f"_default{k}"] = f.default
            params.append(f"{f.name}=_default{k}")
        elif f.default_factory is not MISSING:  # pragma: no cover - no node has one
            raise TypeError(f"{cls.__name__}.{f.name}: a node's field takes a default, not a "
                            "default_factory")
        else:
            params.append(f.name)
        names.append(f"    _set{k}(self, {f.name})")
    source = f"def __init__(self, {', '.join(params)}):\n" + "\n".join(names) + "\n"
    exec(source, env)  # the source is built from the class's own field names
    init = env["__init__"]
    init.__qualname__, init.__module__ = f"{cls.__qualname__}.__init__", cls.__module__
    cls.__init__ = init  # type: ignore[method-assign]  # an __init__ built from its fields


for _cls in [c for c in tuple(globals().values()) if isinstance(c, type) and issubclass(c, Node)]:
    _slot_setting_init(_cls)  # the classes as the module holds them (slots=True made new ones)
