"""The RAPID string built-ins: length, parts, searching, numbers and bytes to and from text
(at most 80 characters: a longer result is ERR_STRTOOLNG)."""

from __future__ import annotations

import re
from typing import Any

from simulators.rapid.builtins import builtin
from simulators.rapid.errors import RapidError
from simulators.rapid.values import is_integer, num, string


def _pos_arg(s: str, pos: float, what: str, allow_end: bool = True) -> int:
    if not is_integer(pos) or not 1 <= pos <= len(s) + (1 if allow_end else 0):
        raise RapidError("ERR_ARGVALERR", f"{what} {pos:g} outside the string of {len(s)}")
    return int(pos)


@builtin("StrLen", "func")
def _strlen(task: Any, pos: list, opt: dict) -> float:
    return float(len(pos[0]))


@builtin("StrPart", "func")
def _strpart(task: Any, pos: list, opt: dict) -> str:
    s, start, n = pos
    if not (is_integer(start) and is_integer(n)) or start < 1 or n < 0 or \
            start + n - 1 > len(s):
        raise RapidError("ERR_ARGVALERR",
                         f"StrPart({start:g}, {n:g}) outside the string of {len(s)}")
    return s[int(start) - 1:int(start) - 1 + int(n)]


@builtin("StrFind", "func", opts=("NotInSet",))
def _strfind(task: Any, pos: list, opt: dict) -> float:
    """The first position from ChPos holding a character of Set (\\NotInSet: not of Set);
    StrLen + 1 when there is none."""
    s, start, chars = pos
    i = _pos_arg(s, start, "StrFind position")
    found = _char_set(chars, bool(opt.get("notinset"))).search(s, i - 1)
    return float(len(s) + 1 if found is None else found.start() + 1)


_CHAR_SETS: dict[tuple[str, bool], re.Pattern[str]] = {}


def _char_set(chars: str, outside: bool) -> re.Pattern[str]:
    """One character of `chars` (`outside`: any other character), compiled once per set (a
    program's sets are its constants; a set made at run time is kept among 256 at most)."""
    pattern = _CHAR_SETS.get((chars, outside))
    if pattern is None:
        if len(_CHAR_SETS) >= 256:
            _CHAR_SETS.clear()
        members = "".join(re.escape(c) for c in dict.fromkeys(chars))
        text = ("[^" + members + "]" if outside else "[" + members + "]") if members else \
            ("(?s:.)" if outside else "(?!)")
        pattern = _CHAR_SETS[(chars, outside)] = re.compile(text)
    return pattern


@builtin("StrMemb", "func")
def _strmemb(task: Any, pos: list, opt: dict) -> bool:
    s, at, chars = pos
    return s[_pos_arg(s, at, "StrMemb position", allow_end=False) - 1] in chars


@builtin("StrMatch", "func")
def _strmatch(task: Any, pos: list, opt: dict) -> float:
    s, start, pattern = pos
    i = _pos_arg(s, start, "StrMatch position")
    k = s.find(pattern, i - 1)
    return float(len(s) + 1 if k < 0 else k + 1)


_NUM_TEXT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\Z")


@builtin("StrToVal", "func", refs=(1,))
def _strtoval(task: Any, pos: list, opt: dict) -> bool:
    """A num's text (RAPID literal syntax) into Val: TRUE, or FALSE and Val unchanged."""
    s, target = pos
    if isinstance(target.value, float):
        if not _NUM_TEXT.match(s):
            return False
        try:
            target.value = num(float(s))
        except RapidError:
            return False
        return True
    if isinstance(target.value, bool):
        if s not in ("TRUE", "FALSE"):
            return False
        target.value = s == "TRUE"
        return True
    if isinstance(target.value, str):
        target.value = string(s)
        return True
    raise RapidError("ERR_ARGVALERR", "StrToVal into this data type is not supported")


@builtin("NumToStr", "func")
def _numtostr(task: Any, pos: list, opt: dict) -> str:
    value, dec = pos
    if not is_integer(dec) or dec < 0:
        raise RapidError("ERR_ARGVALERR", f"NumToStr decimals {dec:g}")
    text = f"{value:.{int(dec)}f}"
    if float(text) == 0.0:
        text = text.lstrip("-")
    return string(text)


_BYTE_BASES = (("hex", 16, "{:02X}"), ("okt", 8, "{:03o}"), ("bin", 2, "{:08b}"))


@builtin("StrToByte", "func", opts=("Hex", "Okt", "Bin", "Char"))
def _strtobyte(task: Any, pos: list, opt: dict) -> float:
    """A byte from its text: decimal, or \\Hex, \\Okt, \\Bin digits, or \\Char a character."""
    text = pos[0]
    if opt.get("char"):
        if len(text) != 1:
            raise RapidError("ERR_ARGVALERR", f"StrToByte \\Char of {text!r}: one character")
        return float(ord(text))
    base = next((b for key, b, _ in _BYTE_BASES if opt.get(key)), 10)
    try:
        value = int(text, base)
    except ValueError:
        value = -1
    if not 0 <= value <= 255:
        raise RapidError("ERR_ARGVALERR", f"StrToByte of {text!r}: no byte in base {base}")
    return float(value)


@builtin("ByteToStr", "func", opts=("Hex", "Okt", "Bin", "Char"))
def _bytetostr(task: Any, pos: list, opt: dict) -> str:
    """A byte's text: decimal, or \\Hex (2 digits), \\Okt (3), \\Bin (8), \\Char."""
    b = pos[0]
    if not (is_integer(b) and 0 <= b <= 255):
        raise RapidError("ERR_ARGVALERR", f"ByteToStr of {b!r}: no byte (0..255)")
    if opt.get("char"):
        return chr(int(b))
    fmt = next((f for key, _, f in _BYTE_BASES if opt.get(key)), "{:d}")
    return fmt.format(int(b))


@builtin("ValToStr", "func")
def valtostr(task: Any, pos: list, opt: dict) -> str:
    v = pos[0]
    if isinstance(v, bool):
        return "TRUE" if v else "FALSE"
    if isinstance(v, float):
        return string(f"{v:.9g}" if not is_integer(v) else f"{int(v)}")
    return string(repr(v) if not isinstance(v, str) else v)
