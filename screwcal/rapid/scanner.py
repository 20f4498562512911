"""The scanner of the RAPID parser: tokens read at positions in the text (no token list),
keywords, comments collected on the way, and `RapidSyntaxError` with the 1-based line and column.

`Scanner` holds the current token (`kind`: num, id, str, op, kw, eof; `value`; its `start` and
`end` offsets) and the helpers every grammar level uses (`accept`, `expect`, `ident`, `loc`).
"""

from __future__ import annotations

import re
from bisect import bisect_right
from typing import NoReturn

from screwcal.rapid.ast import Comment, Placeholder


class RapidSyntaxError(ValueError):
    """RAPID text that does not parse: where (file, 1-based line and column) and why."""

    def __init__(self, path: str, line: int, col: int, reason: str):
        self.path, self.line, self.col, self.reason = path, line, col, reason
        super().__init__(f"{path}:{line}:{col}: {reason}")


class RapidEncryptedError(RapidSyntaxError):
    """A module whose text is not RAPID source: encrypted (RobotWare loads such modules as
    they are, and no tool but the controller reads them) or binary."""


KEYWORDS = frozenset("""ALIAS AND BACKWARD CASE CONNECT CONST DEFAULT DIV DO ELSE ELSEIF ENDFOR
ENDFUNC ENDIF ENDMODULE ENDPROC ENDRECORD ENDTEST ENDTRAP ENDWHILE ERROR EXIT FOR FROM FUNC GOTO
IF INOUT LOCAL MOD MODULE NOT OR PERS PROC RAISE RECORD RETRY RETURN STEP TEST THEN TO TRAP
TRYNEXT UNDO VAR WHILE WITH XOR""".split())

# Placeholders: the parts of a program not yet written (RAPID kernel reference, placeholders),
# as the FlexPendant and RobotStudio leave them: `<SMT>` a statement, `<EXP>` an expression...
PLACEHOLDERS = frozenset("TDN DDN RDN PAR ALT DIM SMT VAR EIT CSE EXP ARG ID".split())
NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"  # a literal's digits, unsigned
_SKIP = re.compile(r"(?:\s+|![^\n]*)*")
_COMMENT = re.compile(r"![^\n]*")
_TOKEN_PATTERN = (
    r"(?P<num>0[xX][0-9A-Fa-f]+|0[bB][01]+|0[oO][0-7]+|" + NUMBER + r")(?![A-Za-z_])"
    r"|(?P<ph><(?:" + "|".join(sorted(PLACEHOLDERS)) + r")>)"
    r"|(?P<id>[A-Za-z]\w*)"
    r'|(?P<str>"(?:[^"\n]|"")*")'
    r"|(?P<op>:=|<=|>=|<>|[-+*/<>=(){}\[\],;:\\.%?|])")
# The header a controller writes at the top of a saved module: `%%%`, NAME:VALUE lines
# (VERSION:1, LANGUAGE:ENGLISH), `%%%`; kept as written, not part of the module.
_HEADER = re.compile(r"[ \t\r\n]*%%%[ \t]*\r?\n((?:[ \t]*(?:[A-Za-z_]\w*[ \t]*:[^\n%]*)?\r?\n)*)"
                     r"[ \t]*%%%")
# Characters no RAPID text holds (control characters other than blanks): binary or encrypted.
_BINARY = re.compile(r"[\x00-\x08\x0e-\x1a\x1c-\x1f\x7f]")
# Blanks and comments taken whole (atomic: a comment never gives back its characters as
# tokens, as it would at the end of a file without a last line end), then one token.
_SKIP_TOKEN = re.compile(r"(?>(?:\s+|![^\n]*)*)(?:" + _TOKEN_PATTERN + ")")
_AFTER_NAME = re.compile(r"\s*(:=|:|\{|\.(?!\d)|!)")


class Scanner:
    """The current token of `text` and how to move on; `fail` raises RapidSyntaxError."""

    def __init__(self, text: str, path: str):
        if text.startswith("\ufeff"):  # a byte-order mark: not part of the module
            text = " " + text[1:]
        elif text.startswith("\xef\xbb\xbf"):  # the same, read as latin-1
            text = "   " + text[3:]
        self.text, self.path = text, path
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]
        self.comments: list[Comment] = []
        self.placeholders: list[Placeholder] = []
        self.pos = 0
        self.header = ""  # the saved-module header, from its first %%% to its last
        header = _HEADER.match(text)
        if header is not None:
            self.header = header.group().lstrip()
            self.pos = header.end()
        elif text.lstrip().startswith("%%%"):
            self.start = text.index("%")
            self.fail("a saved-module header (%%%) that does not close: expected NAME:VALUE "
                      "lines (VERSION:1, LANGUAGE:ENGLISH) and a closing %%% before MODULE")
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
            skip = _SKIP.match(text, pos)  # always matches (perhaps nothing)
            p = pos if skip is None else skip.end()
            self.collect_comments(pos, p)
            self.start = p
            if p >= len(text):
                self.kind, self.value, self.end = "eof", "", p
                self.pos = p
                return
            if text[p] == '"':
                self.fail("a string that never closes (missing '\"' on its line)")
            self.not_text(p)
            self.fail(f"unexpected character {text[p]!r}")
        kind = m.lastgroup
        assert kind is not None  # a token matched: one of the named alternatives
        p = m.start(kind)
        if p > pos and text.find("!", pos, p) >= 0:
            self.collect_comments(pos, p)
        value = m.group(kind)
        if kind == "id" and value.upper() in KEYWORDS:
            kind, value = "kw", value.upper()
        self.kind, self.value, self.start, self.end = kind, value, p, m.end()
        self.pos = m.end()

    def not_text(self, offset: int) -> None:
        """Fail with RapidEncryptedError when the text from `offset` on is not source text:
        over a quarter of control characters or bytes outside ASCII (a stray one in a text is
        a syntax error, not an encrypted module)."""
        sample = self.text[offset:offset + 512]
        if len(_BINARY.findall(sample)) + sum(c > "\x7e" for c in sample) > len(sample) // 4:
            line, col = self.where(offset)
            raise RapidEncryptedError(self.path, line, col, "an encrypted or binary module, not "
                                      "RAPID source text: it cannot be read here (the "
                                      "controller loads an encrypted module as it is)")

    def collect_comments(self, start: int, end: int) -> None:
        for c in _COMMENT.finditer(self.text, start, end):
            line, col = self.where(c.start())
            self.comments.append(Comment(line, col, c.start(), c.end(), c.group()))

    def fail(self, reason: str, offset: int | None = None) -> NoReturn:
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
