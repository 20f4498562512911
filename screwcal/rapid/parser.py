"""A recursive-descent parser for ABB RAPID modules (`.mod` program modules, `.sys` system
modules), after the grammar of the RAPID kernel reference.

Hand-written rather than a `lark` grammar: the program filter parses modules of 10,000
robtargets (some 200,000 numbers) in its 2-second budget, which a general parser cannot do, and
a hand-written one names what it expected at the exact line and column. The scanner works on
positions in the text (no token list): a record or array value of plain numbers on one line is
read in one regular-expression match, the common case of every robtarget.

One reading differs from the kernel grammar: NOT binds one relation (`NOT a AND b` is
`(NOT a) AND b`), as in the RAPID overview's examples.

In three modules, one grammar level each: the tokens (`scanner`), the expressions and argument
lists (`expressions`), and here the module, its declarations, routines and statements.
"""


from __future__ import annotations

import re
from bisect import bisect_right

from screwcal.rapid.ast import (
    AliasDecl,
    Argument,
    Assign,
    Case,
    Connect,
    DataDecl,
    Expr,
    For,
    Goto,
    If,
    Label,
    Module,
    Name,
    Param,
    ProcCall,
    Raise,
    RecordDecl,
    RecordField,
    Return,
    Routine,
    Simple,
    Stmt,
    Test,
    While,
)
from screwcal.rapid.expressions import ExpressionParser
from screwcal.rapid.scanner import KEYWORDS, RapidEncryptedError, RapidSyntaxError

__all__ = ["KEYWORDS", "RapidEncryptedError", "RapidSyntaxError", "parse_expression",
           "parse_module"]

# `CONST robtarget p10 :=` after the storage keyword, on one line: the type and the name.
_DECL_HEAD = re.compile(r"[ \t]+([A-Za-z]\w*)[ \t]+([A-Za-z]\w*)[ \t]*(:=)[ \t]*")
_DECL_END = re.compile(r"[ \t]*;")  # after a value of plain numbers, on its line
# A procedure call whose arguments are all names, on one line (the rest of most statements).
_PLAIN_CALL = re.compile(r"[ \t]+([A-Za-z]\w*(?:[ \t]*,[ \t]*[A-Za-z]\w*)*)[ \t]*;")
_WORD = re.compile(r"[A-Za-z]\w*")  # one of those names
_ENDS = {"PROC": "ENDPROC", "FUNC": "ENDFUNC", "TRAP": "ENDTRAP"}
_HANDLERS = ("BACKWARD", "ERROR", "UNDO")
_CLOSERS = frozenset(("ENDPROC", "ENDFUNC", "ENDTRAP", "ENDIF", "ENDWHILE", "ENDFOR", "ENDTEST",
                      "ENDMODULE", "ENDRECORD", "ELSE", "ELSEIF", "CASE", "DEFAULT",
                      *_HANDLERS))
_SIMPLE = frozenset(("RETRY", "TRYNEXT", "EXIT"))
_COMPACT_OK = (ProcCall, Assign, Goto, Return, Raise, Simple)


def parse_module(text: str, path: str = "<module>") -> Module:
    """The module in `text` (one `MODULE ... ENDMODULE`; comments before and after it
    allowed; after a byte-order mark and the header a controller writes, `%%%` ... `%%%`, kept
    in `Module.header`). Raises RapidSyntaxError naming `path`, the line and the column
    (RapidEncryptedError for a text that is not RAPID source: an encrypted module)."""
    return _Parser(text, path).module()


def parse_expression(text: str, path: str = "<expression>") -> Expr:
    """One RAPID expression, e.g. a data value."""
    p = _Parser(text, path)
    e = p.expr()
    if p.kind != "eof":
        p.fail("expected the end of the expression")
    return e


class _Parser(ExpressionParser):
    """Modules, declarations, routines and statements over the expressions."""

    # ------------------------------------------------------------ module level
    def module(self) -> Module:
        start = self.start
        if not self.at("MODULE"):
            self.not_text(self.start)
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
            if self.kind == "ph":  # <DDN>, <RDN>, <TDN>: a declaration not yet written
                self.placeholder()
                continue
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
                      tuple(routines), tuple(records), tuple(aliases), tuple(self.comments),
                      self.header, tuple(self.placeholders))

    def data_decl(self, start: int, scope: str | None) -> DataDecl:
        storage = self.value
        dims: tuple[Expr, ...] = ()
        head = _DECL_HEAD.match(self.text, self.end)
        if head and head[1].upper() not in KEYWORDS and head[2].upper() not in KEYWORDS:
            type_, name = head[1], head[2]  # the two names read in one match
            # a value of plain numbers and its ';' on the line (every robtarget as
            # controllers write them): read in two more matches, without the scanner
            numbers = self.number_value(head.end()) if self.text.startswith("[", head.end()) \
                else None
            close = _DECL_END.match(self.text, numbers[1]) if numbers else None
            if numbers and close:
                self.pos = self.end = close.end()
                self.advance()
                return DataDecl(*self.loc(start), storage, scope, type_, name, dims, numbers[0])
            self.pos = head.start(3)  # else the scanner at ':='
            self.advance()
        else:
            self.advance()
            type_ = self.ident("a data type")
            name = self.ident("the data's name")
            if self.accept("{"):
                dims = self.expr_list("}")
        value = None
        if self.accept(":="):
            value = self.item((";",))
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
            if self.kind == "ph":  # <PAR>, <ALT>: a parameter not yet written
                self.placeholder()
                if self.accept(")"):
                    return out
                self.accept(",")
                continue
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
        if kind == "ph":
            return self.placeholder_statement(start)
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

    def placeholder_statement(self, start: int) -> Stmt:
        """`<SMT>` (and `<EIT>`, `<CSE>` in their blocks), with no ';' after it; or
        `<VAR> := <EXP>;`."""
        node = self.placeholder()
        if self.at(":="):
            self.advance()
            val = self.expr()
            self.expect(";", " after the assignment")
            return Assign(*self.loc(start), node, val)
        self.accept(";")
        return node

    def plain_call(self, start: int, name: str, plain: re.Match[str]) -> ProcCall:
        words = _WORD.findall(self.text, plain.start(1), plain.end(1))  # blanks, no comments
        if not KEYWORDS.isdisjoint(map(str.upper, words)):  # not a plain call after all
            self.advance()
            return ProcCall(*self.loc(start), name, self.arguments(";"))
        line = bisect_right(self.starts, start)
        base = self.starts[line - 1] - 1
        args = []
        for word in _WORD.finditer(self.text, plain.start(1), plain.end(1)):
            a, b = word.span()
            args.append(Argument(line, a - base, a, b, Name(line, a - base, a, b, word[0])))
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
