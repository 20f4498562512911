"""The expressions of the RAPID grammar (kernel reference: expressions): OR/XOR over AND over
NOT and the relations, sums, terms, primaries with calls, indices and components, aggregates
`[a, b, ...]`, and the argument lists of calls.

An aggregate of plain numbers on one line (`[n, n, ...]`, or nested once: a whole robtarget) is
read in one regular-expression match into a `NumberRow`, the common case of every robtarget.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from collections.abc import Iterator
from itertools import accumulate
from operator import add

from screwcal.rapid.ast import (
    Aggregate as AggregateNode,
)
from screwcal.rapid.ast import (
    Argument,
    Binary,
    Call,
    Component,
    Expr,
    Index,
    Name,
    Num,
    NumberRow,
    Placeholder,
    Str,
    Unary,
)
from screwcal.rapid.scanner import Scanner

# After a name or literal: the end of an argument, item or statement (the value is that atom).
_ATOM_END = re.compile(r"[ \t]*[,;)\]]")
# A signed literal's digits as NUMBER has them, every part taken possessively: a number in a
# row is followed by a blank, ',' or ']', which no part of it gives back (no backtracking:
# twice as fast on a robtarget, 150 characters a declaration).
_ROW_NUMBER = r"[-+]?+(?:\d++(?:\.\d*+)?+|\.\d++)(?:[eE][-+]?+\d++)?+"
# `[n, n, ...]` of plain numbers on one line: most of a robtarget, read in one match.
_FLAT = re.compile(r"\[[ \t]*+" + _ROW_NUMBER + r"(?:[ \t]*+,[ \t]*+" + _ROW_NUMBER
                   + r")*+[ \t]*+\]")
# `[[n, ...], [n, ...], ...]` on one line: a whole robtarget.
_NESTED = re.compile(r"\[[ \t]*+" + _FLAT.pattern + r"(?:[ \t]*+,[ \t]*+" + _FLAT.pattern
                     + r")*+[ \t]*+\]")

_ATOMS = frozenset(("id", "num", "str"))
_RELATIONS = frozenset(("<", "<=", "=", ">=", ">", "<>"))


def _offsets(pieces: list[str], first: int) -> Iterator[int]:
    """Where each of `pieces` (a text split at single commas) begins, the first at `first`:
    the lengths before it and a comma after each (no Python-level loop: 170,000 numbers in a
    module of 10,000 robtargets)."""
    return map(add, accumulate(map(len, pieces), initial=first), range(len(pieces)))


class ExpressionParser(Scanner):
    """Expressions and argument lists; `_Parser` (parser.py) adds declarations and
    statements."""

    def arguments(self, close: str) -> tuple[Argument, ...]:
        """Arguments up to `close` (`;` of a procedure call, `)` of a function call), which is
        consumed. Positional ones are separated by commas; an optional one (`\\Name`) or a
        placeholder (`<ARG>`) may follow the previous one without a comma."""
        args: list[Argument] = []
        first = True
        while not self.accept(close):
            if not first and not self.accept(",") and not self.at("\\") and \
                    self.kind != "ph":  # `<ARG>`: an argument not yet written
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
        if kind == "ph":
            return self.placeholder()
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

    def placeholder(self) -> Placeholder:
        """The current `<XXX>` token as a node, noted in `placeholders`."""
        node = Placeholder(*self.where(self.start), self.start, self.end, self.value[1:-1])
        self.placeholders.append(node)
        self.advance()
        return node

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
        if " " not in body and "\t" not in body:
            return NumberRow(line, start - base, start, end, tuple(pieces),
                             tuple(_offsets(pieces, start + 1)))
        texts, starts, at = [], [], start + 1
        for piece in pieces:
            t = piece.strip()
            texts.append(t)
            starts.append(at + piece.index(t))
            at += len(piece) + 1
        return NumberRow(line, start - base, start, end, tuple(texts), tuple(starts))

    def number_rows(self, start: int, end: int, line: int, base: int) -> tuple[NumberRow, ...]:
        """The NumberRows of `[[n, ...], [n, ...], ...]` between start and end (one line,
        checked by _NESTED): split at `],[` when written without blanks (a robtarget as the
        controller writes it), else row by row."""
        inner = self.text[start + 1:end - 1]
        if " " in inner or "\t" in inner:
            return tuple([self.numbers(m.start(), m.end(), line, base)
                          for m in _FLAT.finditer(self.text, start + 1, end)])
        rows = []
        at = start + 1  # the row's '['
        for body in inner[1:-1].split("],["):
            texts = body.split(",")
            starts = tuple(_offsets(texts, at + 1))
            after = at + len(body) + 2  # one past the row's ']'
            rows.append(NumberRow(line, at - base, at, after, tuple(texts), starts))
            at = after + 1
        return tuple(rows)

    def item(self, follow: tuple[str, ...] = (",", "]")) -> Expr:
        """An item of an aggregate (or a data value, followed by ';'): most often an
        aggregate itself, read without going down the operator levels (and again as an
        expression when anything but `follow` comes after it)."""
        if self.kind == "op" and self.value == "[":
            saved = (self.pos, self.kind, self.value, self.start, self.end, self.last_end,
                     len(self.comments))
            value = self.aggregate()
            if self.kind == "op" and self.value in follow:
                return value
            (self.pos, self.kind, self.value, self.start, self.end, self.last_end, n) = saved
            del self.comments[n:]
        return self.expr()

    def number_value(self, start: int) -> tuple[Expr, int] | None:
        """`[n, n, ...]` (a NumberRow) or `[[n, ...], [n, ...], ...]` (an Aggregate of them) of
        plain numbers on one line at `start`, read in one match, and where it ends; None for
        any other value."""
        text = self.text
        flat = _FLAT.match(text, start)
        whole = flat or _NESTED.match(text, start)
        if whole is None:
            return None
        end = whole.end()
        line = bisect_right(self.starts, start)
        base = self.starts[line - 1] - 1
        if flat:
            return self.numbers(start, end, line, base), end
        return AggregateNode(line, start - base, start, end,
                             self.number_rows(start, end, line, base)), end

    def aggregate(self) -> Expr:
        start = self.start
        numbers = self.number_value(start)
        if numbers is not None:  # plain numbers on one line: read in one match
            value, self.end = numbers
            self.pos = self.end
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
