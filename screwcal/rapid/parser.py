"""A recursive-descent parser for ABB RAPID modules (`.mod` program modules, `.sys` system
modules), after the grammar of the RAPID kernel reference.

Hand-written rather than a `lark` grammar: the program filter parses modules of 10,000
robtargets (some 200,000 numbers) in its 2-second budget, which a general parser cannot do, and
a hand-written one names what it expected at the exact line and column. The scanner works on
positions in the text (no token list): a record or array value of plain numbers on one line is
read in one regular-expression match, the common case of every robtarget.

One reading differs from the kernel grammar: NOT binds one relation (`NOT a AND b` is
`(NOT a) AND b`), as in the RAPID overview's examples.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from itertools import accumulate

from screwcal.rapid.ast import (
    Aggregate as AggregateNode,
)
from screwcal.rapid.ast import (
    AliasDecl,
    Argument,
    Assign,
    Binary,
    Call,
    Case,
    Comment,
    Component,
    Connect,
    DataDecl,
    Expr,
    For,
    Goto,
    If,
    Index,
    Label,
    Module,
    Name,
    Num,
    NumberRow,
    Param,
    ProcCall,
    Raise,
    RecordDecl,
    RecordField,
    Return,
    Routine,
    Simple,
    Stmt,
    Str,
    Test,
    Unary,
    While,
)


class RapidSyntaxError(ValueError):
    """RAPID text that does not parse: where (file, 1-based line and column) and why."""

    def __init__(self, path: str, line: int, col: int, reason: str):
        self.path, self.line, self.col, self.reason = path, line, col, reason
        super().__init__(f"{path}:{line}:{col}: {reason}")


KEYWORDS = frozenset("""ALIAS AND BACKWARD CASE CONNECT CONST DEFAULT DIV DO ELSE ELSEIF ENDFOR
ENDFUNC ENDIF ENDMODULE ENDPROC ENDRECORD ENDTEST ENDTRAP ENDWHILE ERROR EXIT FOR FROM FUNC GOTO
IF INOUT LOCAL MOD MODULE NOT OR PERS PROC RAISE RECORD RETRY RETURN STEP TEST THEN TO TRAP
TRYNEXT UNDO VAR WHILE WITH XOR""".split())

_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_SKIP = re.compile(r"(?:\s+|![^\n]*)*")
_COMMENT = re.compile(r"![^\n]*")
_TOKEN_PATTERN = (
    r"(?P<num>0[xX][0-9A-Fa-f]+|0[bB][01]+|0[oO][0-7]+|" + _NUMBER + r")(?![A-Za-z_])"
    r"|(?P<id>[A-Za-z]\w*)"
    r'|(?P<str>"(?:[^"\n]|"")*")'
    r"|(?P<op>:=|<=|>=|<>|[-+*/<>=(){}\[\],;:\\.%?|])")
_SKIP_TOKEN = re.compile(r"(?:\s+|![^\n]*)*(?:" + _TOKEN_PATTERN + ")")
# After a name or literal: the end of an argument, item or statement (the value is that atom).
_ATOM_END = re.compile(r"[ \t]*[,;)\]]")
# `[n, n, ...]` of plain numbers on one line: most of a robtarget, read in one match.
_SIGNED = re.compile(r"[-+]?" + _NUMBER)
_FLAT = re.compile(r"\[[ \t]*[-+]?" + _NUMBER + r"(?:[ \t]*,[ \t]*[-+]?" + _NUMBER
                   + r")*[ \t]*\]")
# `[[n, ...], [n, ...], ...]` on one line: a whole robtarget.
_NESTED = re.compile(r"\[[ \t]*" + _FLAT.pattern + r"(?:[ \t]*,[ \t]*" + _FLAT.pattern
                     + r")*[ \t]*\]")

# A procedure call whose arguments are all names, on one line (the rest of most statements).
_PLAIN_CALL = re.compile(r"[ \t]+([A-Za-z]\w*(?:[ \t]*,[ \t]*[A-Za-z]\w*)*)[ \t]*;")
_NAME = re.compile(r"[A-Za-z]\w*")
_AFTER_NAME = re.compile(r"\s*(:=|:|\{|\.(?!\d)|!)")
_ATOMS = frozenset(("id", "num", "str"))
_ENDS = {"PROC": "ENDPROC", "FUNC": "ENDFUNC", "TRAP": "ENDTRAP"}
_HANDLERS = ("BACKWARD", "ERROR", "UNDO")
_RELATIONS = frozenset(("<", "<=", "=", ">=", ">", "<>"))
_CLOSERS = frozenset(("ENDPROC", "ENDFUNC", "ENDTRAP", "ENDIF", "ENDWHILE", "ENDFOR", "ENDTEST",
                      "ENDMODULE", "ENDRECORD", "ELSE", "ELSEIF", "CASE", "DEFAULT",
                      *_HANDLERS))
_SIMPLE = frozenset(("RETRY", "TRYNEXT", "EXIT"))
_COMPACT_OK = (ProcCall, Assign, Goto, Return, Raise, Simple)


def parse_module(text: str, path: str = "<module>") -> Module:
    """The module in `text` (one `MODULE ... ENDMODULE`; comments before and after it
    allowed). Raises RapidSyntaxError naming `path`, the line and the column."""
    return _Parser(text, path).module()


def parse_expression(text: str, path: str = "<expression>") -> Expr:
    """One RAPID expression, e.g. a data value."""
    p = _Parser(text, path)
    e = p.expr()
    if p.kind != "eof":
        p.fail("expected the end of the expression")
    return e


class _Parser:
    def __init__(self, text: str, path: str):
        if text.startswith("\ufeff"):  # a byte-order mark: not part of the module
            text = " " + text[1:]
        elif text.startswith("\xef\xbb\xbf"):  # the same, read as latin-1
            text = "   " + text[3:]
        self.text, self.path = text, path
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]
        self.comments: list[Comment] = []
        self.pos = 0
        self.kind, self.value, self.start, self.end = "bof", "", 0, 0
        self.advance()

    # ------------------------------------------------------------ scanning
    def where(self, offset: int) -> tuple[int, int]:
        line = bisect_right(self.starts, offset)
        return line, offset - self.starts[line - 1] + 1

    def advance(self) -> None:
        self.last_end = self.end
        text, pos = self.text, self.pos
        m = _SKIP_TOKEN.match(text, pos)  # blanks and comments, then one token
        if m is None:  # the end of the text, or a character no token begins with
            skip = _SKIP.match(text, pos)
            self.collect_comments(pos, skip.end())
            p = skip.end()
            self.start = p
            if p >= len(text):
                self.kind, self.value, self.end = "eof", "", p
                self.pos = p
                return
            self.fail("a string that never closes (missing '\"' on its line)"
                      if text[p] == '"' else f"unexpected character {text[p]!r}")
        kind = m.lastgroup
        p = m.start(kind)
        if p > pos and text.find("!", pos, p) >= 0:
            self.collect_comments(pos, p)
        value = m.group(kind)
        if kind == "id" and value.upper() in KEYWORDS:
            kind, value = "kw", value.upper()
        self.kind, self.value, self.start, self.end = kind, value, p, m.end()
        self.pos = m.end()

    def collect_comments(self, start: int, end: int) -> None:
        for c in _COMMENT.finditer(self.text, start, end):
            line, col = self.where(c.start())
            self.comments.append(Comment(line, col, c.start(), c.end(), c.group()))

    def fail(self, reason: str, offset: int | None = None) -> None:
        line, col = self.where(self.start if offset is None else offset)
        raise RapidSyntaxError(self.path, line, col, reason)

    def shown(self) -> str:
        return "the end of the file" if self.kind == "eof" else f"'{self.value}'"

    def at(self, value: str) -> bool:
        return self.value == value and self.kind in ("op", "kw")

    def accept(self, value: str) -> bool:
        if self.value == value and self.kind in ("op", "kw"):
            self.advance()
            return True
        return False

    def expect(self, value: str, context: str = "") -> None:
        if not self.accept(value):
            self.fail(f"expected '{value}'{context}, found {self.shown()}")

    def ident(self, what: str) -> str:
        if self.kind != "id":
            self.fail(f"expected {what}, found {self.shown()}")
        name = self.value
        self.advance()
        return name

    def loc(self, start: int) -> tuple[int, int, int, int]:
        line, col = self.where(start)
        return line, col, start, self.last_end

    def after_ident(self) -> tuple[str, str]:
        """The token after the current name, when it is one of `:= : { .` (the common
        case, read without scanning on), else as peek_after_ident finds it."""
        m = _AFTER_NAME.match(self.text, self.end)
        if m is None:
            return "", ""
        if m.group(1) == "!":
            return self.peek_after_ident()
        return "op", m.group(1)

    def peek_after_ident(self) -> tuple[str, str]:
        """The token after the current one (kind, value), the state left as it was."""
        saved = (self.pos, self.kind, self.value, self.start, self.end, self.last_end,
                 len(self.comments))
        self.advance()
        nxt = (self.kind, self.value)
        (self.pos, self.kind, self.value, self.start, self.end, self.last_end, n) = saved
        del self.comments[n:]
        return nxt

    # ------------------------------------------------------------ module level
    def module(self) -> Module:
        start = self.start
        if not self.at("MODULE"):
            self.fail(f"not a RAPID module: it must begin with 'MODULE <name>', not "
                      f"{self.shown()}")
        self.advance()
        name = self.ident("the module's name")
        attributes: list[str] = []
        if self.accept("("):
            while True:
                if self.kind not in ("id", "kw"):
                    self.fail(f"expected a module attribute, found {self.shown()}")
                attributes.append(self.value.upper())
                self.advance()
                if not self.accept(","):
                    break
            self.expect(")", " after the module's attributes")
        data, routines, records, aliases = [], [], [], []
        while not self.at("ENDMODULE"):
            if self.kind == "eof":
                self.fail(f"missing ENDMODULE for MODULE {name} at line "
                          f"{self.where(start)[0]}")
            item_start = self.start
            local = self.accept("LOCAL")
            task = not local and self.kind == "id" and self.value.upper() == "TASK"
            if task:
                self.advance()
            if self.value in ("CONST", "VAR", "PERS") and self.kind == "kw":
                data.append(self.data_decl(item_start, "LOCAL" if local else
                                           "TASK" if task else None))
            elif task:
                self.fail(f"expected CONST, VAR or PERS after TASK, found {self.shown()}")
            elif self.value in _ENDS and self.kind == "kw":
                routines.append(self.routine(item_start, local))
            elif self.at("RECORD"):
                records.append(self.record(item_start, local))
            elif self.at("ALIAS"):
                self.advance()
                type_ = self.ident("a data type")
                alias = self.ident("the alias's name")
                self.expect(";", " after the alias")
                aliases.append(AliasDecl(*self.loc(item_start), type_, alias, local))
            else:
                self.fail("expected a data declaration (CONST, VAR, PERS), PROC, FUNC, TRAP, "
                          f"RECORD or ENDMODULE, found {self.shown()}")
        self.advance()
        end = self.last_end
        if self.kind != "eof":
            self.fail(f"text after ENDMODULE: {self.shown()}")
        line, col = self.where(start)
        return Module(line, col, start, end, name, tuple(attributes), tuple(data),
                      tuple(routines), tuple(records), tuple(aliases), tuple(self.comments))

    def data_decl(self, start: int, scope: str | None) -> DataDecl:
        storage = self.value
        self.advance()
        type_ = self.ident("a data type")
        name = self.ident("the data's name")
        dims: tuple[Expr, ...] = ()
        if self.accept("{"):
            dims = self.expr_list("}")
        value = None
        if self.accept(":="):
            value = self.expr()
        if not self.accept(";"):
            self.fail(f"the declaration of {name} does not end with ';' (found "
                      f"{self.shown()})")
        return DataDecl(*self.loc(start), storage, scope, type_, name, dims, value)

    def record(self, start: int, local: bool) -> RecordDecl:
        self.advance()
        name = self.ident("the record's name")
        fields = []
        while not self.accept("ENDRECORD"):
            fstart = self.start
            type_ = self.ident("a component's type or ENDRECORD")
            fname = self.ident("the component's name")
            self.expect(";", " after a record component")
            fields.append(RecordField(*self.loc(fstart), type_, fname))
        return RecordDecl(*self.loc(start), name, local, tuple(fields))

    def routine(self, start: int, local: bool) -> Routine:
        kind = self.value
        self.advance()
        type_ = self.ident("the function's value type") if kind == "FUNC" else None
        name = self.ident(f"the {kind}'s name")
        params: list[Param] = []
        if kind != "TRAP":
            self.expect("(", f" after {kind} {name}")
            params = self.params()
        data: list[DataDecl] = []
        while self.kind == "kw" and self.value in ("CONST", "VAR", "PERS"):
            data.append(self.data_decl(self.start, None))
        end = _ENDS[kind]
        stops = {end, *_HANDLERS}
        body = self.block(stops, f"{kind} {name}", start)
        handlers: dict[str, tuple[Stmt, ...]] = {}
        numbers: tuple[Expr, ...] = ()
        while self.kind == "kw" and self.value in _HANDLERS:
            which = self.value
            if which in handlers:
                self.fail(f"a second {which} handler in {kind} {name}")
            self.advance()
            if which == "ERROR" and self.accept("("):
                numbers = self.expr_list(")")
            handlers[which] = self.block(stops, f"{kind} {name}", start)
        self.expect(end, f" to close {kind} {name} (line {self.where(start)[0]})")
        return Routine(*self.loc(start), kind, name, local, type_, tuple(params), tuple(data),
                       body, handlers.get("BACKWARD"), handlers.get("ERROR"), numbers,
                       handlers.get("UNDO"))

    def params(self) -> list[Param]:
        out: list[Param] = []
        if self.accept(")"):
            return out
        while True:
            start = self.start
            optional = self.accept("\\")
            first = self.param(start, optional)
            others = []
            while self.accept("|"):
                self.accept("\\")
                others.append(self.param(self.start, optional))
            if others:
                first = Param(first.line, first.col, first.start, self.last_end, first.mode,
                              first.type, first.name, first.optional, first.dims,
                              tuple(others))
            out.append(first)
            if self.accept(")"):
                return out
            if not self.accept(",") and not self.at("\\"):
                self.fail(f"expected ',' or ')' in the parameter list, found {self.shown()}")

    def param(self, start: int, optional: bool) -> Param:
        mode = None
        if self.kind == "kw" and self.value in ("VAR", "PERS", "INOUT"):
            mode = self.value
            self.advance()
        type_ = self.ident("a parameter's type")
        name = self.ident("the parameter's name")
        dims = 0
        if self.accept("{"):
            while True:
                self.expect("*", " in an array parameter's dimensions")
                dims += 1
                if not self.accept(","):
                    break
            self.expect("}", " after an array parameter's dimensions")
        return Param(*self.loc(start), mode, type_, name, optional, dims)

    # ------------------------------------------------------------ statements
    def block(self, stops: set[str], owner: str, owner_start: int) -> tuple[Stmt, ...]:
        out: list[Stmt] = []
        while not (self.kind == "kw" and self.value in stops):
            if self.kind == "eof":
                self.fail(f"the file ends inside {owner} (line {self.where(owner_start)[0]}): "
                          f"expected {' or '.join(sorted(stops))}")
            if self.kind == "kw" and self.value in _CLOSERS:
                self.fail(f"expected {' or '.join(sorted(stops))} in {owner} (line "
                          f"{self.where(owner_start)[0]}), found {self.shown()}")
            out.append(self.statement())
        return tuple(out)

    def statement(self) -> Stmt:
        start, kind, value = self.start, self.kind, self.value
        if kind == "kw":
            if value == "IF":
                return self.if_(start)
            if value == "WHILE":
                self.advance()
                cond = self.expr()
                self.expect("DO", " after the WHILE condition")
                body = self.block({"ENDWHILE"}, "WHILE", start)
                self.advance()
                return While(*self.loc(start), cond, body)
            if value == "FOR":
                self.advance()
                var = self.ident("the FOR loop's variable")
                self.expect("FROM", " in the FOR loop")
                first = self.expr()
                self.expect("TO", " in the FOR loop")
                last = self.expr()
                step = self.expr() if self.accept("STEP") else None
                self.expect("DO", " in the FOR loop")
                body = self.block({"ENDFOR"}, "FOR", start)
                self.advance()
                return For(*self.loc(start), var, first, last, step, body)
            if value == "TEST":
                return self.test(start)
            if value == "GOTO":
                self.advance()
                label = self.ident("a label after GOTO")
                self.expect(";", " after GOTO")
                return Goto(*self.loc(start), label)
            if value in ("RETURN", "RAISE"):
                self.advance()
                arg = None if self.at(";") else self.expr()
                self.expect(";", f" after {value}")
                return (Return if value == "RETURN" else Raise)(*self.loc(start), arg)
            if value in _SIMPLE:
                self.advance()
                self.expect(";", f" after {value}")
                return Simple(*self.loc(start), value)
            if value == "CONNECT":
                self.advance()
                target = self.postfix(self.name_expr())
                self.expect("WITH", " in CONNECT")
                trap = self.ident("a trap routine's name")
                self.expect(";", " after CONNECT")
                return Connect(*self.loc(start), target, trap)
            self.fail(f"expected a statement, found {self.shown()}")
        if kind == "op" and value == "%":
            self.advance()
            late = self.expr()
            self.expect("%", " to close the late-bound name")
            args = self.arguments(";")
            return ProcCall(*self.loc(start), "", args, late)
        if kind != "id":
            self.fail(f"expected a statement, found {self.shown()}")
        nxt_kind, nxt = self.after_ident()
        if nxt_kind == "op" and nxt == ":":
            self.advance()
            self.advance()
            return Label(*self.loc(start), value)
        if nxt_kind == "op" and nxt in (":=", "{", "."):
            target = self.postfix(self.name_expr())
            self.expect(":=", " in the assignment")
            val = self.expr()
            self.expect(";", " after the assignment")
            return Assign(*self.loc(start), target, val)
        plain = _PLAIN_CALL.match(self.text, self.end)
        if plain:  # `MoveJ p10, v1000, z50, tool0;`: names only, on one line
            return self.plain_call(start, value, plain)
        self.advance()
        args = self.arguments(";")
        return ProcCall(*self.loc(start), value, args)

    def plain_call(self, start: int, name: str, plain: re.Match[str]) -> ProcCall:
        line = bisect_right(self.starts, start)
        base = self.starts[line - 1] - 1
        args = []
        for m in _NAME.finditer(self.text, plain.start(1), plain.end(1)):
            a, b = m.span()
            word = m.group()
            if word.upper() in KEYWORDS:  # not a plain call after all: the general way
                self.advance()
                return ProcCall(*self.loc(start), name, self.arguments(";"))
            arg = Name(line, a - base, a, b, word)
            args.append(Argument(line, a - base, a, b, arg))
        self.pos = self.end = plain.end()
        self.advance()
        return ProcCall(line, start - base, start, plain.end(), name, tuple(args))

    def if_(self, start: int) -> If:
        self.advance()
        cond = self.expr()
        if not self.accept("THEN"):
            stmt_start = self.start
            stmt = self.statement()
            if not isinstance(stmt, _COMPACT_OK):
                self.fail("a compact IF takes one simple statement (a call, an assignment, "
                          "GOTO, RETURN, RAISE, EXIT, RETRY or TRYNEXT)", stmt_start)
            return If(*self.loc(start), ((cond, (stmt,)),), (), True)
        branches = []
        stops = {"ELSEIF", "ELSE", "ENDIF"}
        body = self.block(stops, "IF", start)
        branches.append((cond, body))
        orelse: tuple[Stmt, ...] = ()
        while True:
            if self.accept("ELSEIF"):
                c = self.expr()
                self.expect("THEN", " after the ELSEIF condition")
                branches.append((c, self.block(stops, "IF", start)))
            elif self.accept("ELSE"):
                orelse = self.block({"ENDIF"}, "IF", start)
            else:
                self.expect("ENDIF")
                return If(*self.loc(start), tuple(branches), orelse)

    def test(self, start: int) -> Test:
        self.advance()
        subject = self.expr()
        cases: list[Case] = []
        default = None
        stops = {"CASE", "DEFAULT", "ENDTEST"}
        while True:
            cstart = self.start
            if self.accept("CASE"):
                if default is not None:
                    self.fail("CASE after DEFAULT", cstart)
                labels = [self.expr()]
                while self.accept(","):
                    labels.append(self.expr())
                self.expect(":", " after the CASE labels")
                body = self.block(stops, "TEST", start)
                cases.append(Case(*self.loc(cstart), tuple(labels), body))
            elif self.accept("DEFAULT"):
                self.expect(":", " after DEFAULT")
                default = self.block(stops, "TEST", start)
            else:
                self.expect("ENDTEST", " (or CASE, DEFAULT)")
                return Test(*self.loc(start), subject, tuple(cases), default)

    def arguments(self, close: str) -> tuple[Argument, ...]:
        """Arguments up to `close` (`;` of a procedure call, `)` of a function call), which is
        consumed. Positional ones are separated by commas; an optional one (`\\Name`) may follow
        the previous one without a comma."""
        args: list[Argument] = []
        first = True
        while not self.accept(close):
            if not first and not self.accept(",") and not self.at("\\"):
                self.fail(f"expected ',' or '{close}' between arguments, found {self.shown()}")
            first = False
            start = self.start
            name, value, optional, conditional = None, None, False, False
            if self.accept("\\"):
                optional = True
                name = self.ident("an optional argument's name after '\\'")
                if self.accept(":="):
                    value = self.expr()
                elif self.accept("?"):
                    conditional = True
                    value = self.postfix(self.name_expr())
            elif self.kind == "id" and self.after_ident() == ("op", ":="):
                name = self.value  # a required argument given by name
                self.advance()
                self.advance()
                value = self.expr()
            else:
                value = self.expr()
            args.append(Argument(*self.loc(start), value, name, optional, conditional))
        return tuple(args)

    # ------------------------------------------------------------ expressions
    def expr_list(self, close: str) -> tuple[Expr, ...]:
        items = [self.expr()]
        while self.accept(","):
            items.append(self.expr())
        self.expect(close)
        return tuple(items)

    def expr(self) -> Expr:
        if self.kind in _ATOMS and _ATOM_END.match(self.text, self.end):
            return self.primary()  # a lone name or literal: most arguments and items
        start = self.start
        left = self.and_()
        while self.kind == "kw" and self.value in ("OR", "XOR"):
            op = self.value
            self.advance()
            right = self.and_()
            left = Binary(*self.loc(start), op, left, right)
        return left

    def and_(self) -> Expr:
        start = self.start
        left = self.not_()
        while self.kind == "kw" and self.value == "AND":
            self.advance()
            right = self.not_()
            left = Binary(*self.loc(start), "AND", left, right)
        return left

    def not_(self) -> Expr:
        start = self.start
        if self.accept("NOT"):
            operand = self.not_()
            return Unary(*self.loc(start), "NOT", operand)
        left = self.simple()
        if self.kind == "op" and self.value in _RELATIONS:
            op = self.value
            self.advance()
            right = self.simple()
            left = Binary(*self.loc(start), op, left, right)
        return left

    def simple(self) -> Expr:
        start = self.start
        if self.kind == "op" and self.value in ("-", "+"):
            op = self.value
            self.advance()
            operand = self.term()
            if isinstance(operand, Num) and operand.text[0] not in "+-":  # a signed literal
                left: Expr = Num(*self.loc(start), self.text[start:self.last_end])
            else:
                left = Unary(*self.loc(start), op, operand)
        else:
            left = self.term()
        while self.kind == "op" and self.value in ("+", "-"):
            op = self.value
            self.advance()
            right = self.term()
            left = Binary(*self.loc(start), op, left, right)
        return left

    def term(self) -> Expr:
        start = self.start
        left = self.primary()
        while (self.kind == "op" and self.value in ("*", "/")) or \
                (self.kind == "kw" and self.value in ("DIV", "MOD")):
            op = self.value
            self.advance()
            right = self.primary()
            left = Binary(*self.loc(start), op, left, right)
        return left

    def primary(self) -> Expr:
        kind, value, start = self.kind, self.value, self.start
        if kind == "num":
            self.advance()
            return Num(*self.loc(start), value)
        if kind == "str":
            self.advance()
            return Str(*self.loc(start), value)
        if kind == "id":
            return self.postfix(self.name_expr())
        if kind == "op":
            if value == "[":
                return self.aggregate()
            if value == "(":
                self.advance()
                e = self.expr()
                self.expect(")", " to close '('")
                return e
            if value == "%":
                self.advance()
                late = self.expr()
                self.expect("%", " to close the late-bound name")
                self.expect("(", " after a late-bound function")
                return Call(*self.loc(start), "", self.arguments(")"), late)
        self.fail(f"expected a value, found {self.shown()}")
        raise AssertionError  # fail raises

    def name_expr(self) -> Expr:
        start, name = self.start, self.ident("a name")
        if self.at("("):
            self.advance()
            args = self.arguments(")")
            return Call(*self.loc(start), name, args)
        return Name(*self.loc(start), name)

    def postfix(self, base: Expr) -> Expr:
        while self.kind == "op" and self.value in ("{", "."):
            if self.accept("{"):
                indices = self.expr_list("}")
                base = Index(base.line, base.col, base.start, self.last_end, base, indices)
            else:
                self.advance()
                field = self.ident("a component name after '.'")
                base = Component(base.line, base.col, base.start, self.last_end, base, field)
        return base

    def numbers(self, start: int, end: int, line: int, base: int) -> NumberRow:
        """The NumberRow of `[n, n, ...]` between start and end (one line, checked by _FLAT)."""
        body = self.text[start + 1:end - 1]
        pieces = body.split(",")
        if " " in body or "\t" in body:
            texts, starts, at = [], [], start + 1
            for piece in pieces:
                t = piece.strip()
                texts.append(t)
                starts.append(at + piece.index(t))
                at += len(piece) + 1
        else:
            texts = pieces
            starts = list(accumulate([len(p) + 1 for p in pieces[:-1]], initial=start + 1))
        return NumberRow(line, start - base, start, end, tuple(texts), tuple(starts))

    def item(self) -> Expr:
        """An item of an aggregate: most often an aggregate itself, read without going down
        the operator levels (and again as an expression when an operator follows it)."""
        if self.kind == "op" and self.value == "[":
            saved = (self.pos, self.kind, self.value, self.start, self.end, self.last_end,
                     len(self.comments))
            value = self.aggregate()
            if self.kind == "op" and self.value in (",", "]"):
                return value
            (self.pos, self.kind, self.value, self.start, self.end, self.last_end, n) = saved
            del self.comments[n:]
        return self.expr()

    def aggregate(self) -> Expr:
        start, text = self.start, self.text
        flat = _FLAT.match(text, start)
        nested = None if flat else _NESTED.match(text, start)
        if flat or nested:  # plain numbers on one line: read in one match
            end = (flat or nested).end()
            line = bisect_right(self.starts, start)
            base = self.starts[line - 1] - 1
            value: Expr
            if flat:
                value = self.numbers(start, end, line, base)
            else:
                value = AggregateNode(line, start - base, start, end, tuple([
                    self.numbers(m.start(), m.end(), line, base)
                    for m in _FLAT.finditer(text, start + 1, end)]))
            self.pos = self.end = end
            self.advance()
            return value
        self.advance()
        items_: list[Expr] = []
        if not self.at("]"):
            items_.append(self.item())
            while self.accept(","):
                items_.append(self.item())
        if not self.accept("]"):
            self.fail(f"expected ',' or ']' in the value begun at line {self.where(start)[0]}"
                      f", found {self.shown()}")
        return AggregateNode(*self.loc(start), tuple(items_))
