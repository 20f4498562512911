"""The names `rapid check` knows: the instructions, functions and data types of the RobotWare
base system (`reference_instructions`, `reference_functions`: ABB's technical reference
manual, a section per name) and of the RobotWare options (`reference_options`: one table per
option), with their arguments as far as the check verifies them: how many positional
(required) arguments, which optional `\\Name` arguments exist, and which of them are
alternatives of one another. Names compare without case, as in RAPID.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

from screwcal.rapid.reference_functions import DATA_TYPES, FUNCTIONS
from screwcal.rapid.reference_instructions import INSTRUCTIONS
from screwcal.rapid.reference_options import CALIBRATION_CELL, OPTIONS, Option

__all__ = ["CALIBRATION_CELL", "OPTIONS", "Catalogue", "Signature", "catalogue", "option_keys"]


@dataclass(frozen=True)
class Signature:
    """What `rapid check` knows of a routine's arguments: positional counts (None: not
    checked), optional names (None: any) and the groups of alternatives among them."""

    name: str
    min_positional: int | None
    max_positional: int | None
    options: frozenset[str] | None  # lower case
    alternatives: tuple[frozenset[str], ...] = ()  # lower case, groups of two or more


def _table(text: str) -> dict[str, Signature]:
    out = {}
    for row in re.sub(r"\n[ \t]+", " ", text.strip()).splitlines():  # indented: continued
        name, count, *options = row.split()
        low, _, high = count.partition("-")
        groups = [frozenset(o.lower().split("|")) for o in options if o != "*"]
        out[name.lower()] = Signature(
            name, None if low == "*" else int(low), None if low == "*" else int(high or low),
            None if options == ["*"] else frozenset(n for g in groups for n in g),
            tuple(g for g in groups if len(g) > 1))
    return out


@dataclass(frozen=True)
class Catalogue:
    """The names of one controller: its base system and the options it has; `elsewhere`
    tells, for a name it lacks, the options that would bring it."""

    instructions: dict[str, Signature]
    functions: dict[str, Signature]
    types: frozenset[str]
    elsewhere: dict[str, tuple[str, ...]]  # lower-case name -> option titles


BASE_INSTRUCTIONS = _table(INSTRUCTIONS)
BASE_FUNCTIONS = _table(FUNCTIONS)
BASE_TYPES = frozenset(DATA_TYPES.split())
_BY_KEY = {o.key: o for o in OPTIONS}


def option_keys() -> tuple[str, ...]:
    return tuple(_BY_KEY)


def _names(option: Option) -> set[str]:
    return {*_table(option.instructions or "x 0"), *_table(option.functions or "x 0"),
            *option.types.split()} - {"x"}


def catalogue(options: Iterable[str] = CALIBRATION_CELL) -> Catalogue:
    """The catalogue of a controller with these options (keys of `OPTIONS`; ValueError names
    an unknown one and the keys there are)."""
    chosen = []
    for key in options:
        if key.lower() not in _BY_KEY:
            raise ValueError(f"unknown RobotWare option '{key}': one of {', '.join(_BY_KEY)}")
        chosen.append(_BY_KEY[key.lower()])
    instructions, functions = dict(BASE_INSTRUCTIONS), dict(BASE_FUNCTIONS)
    types = set(BASE_TYPES)
    for o in chosen:
        for k, sig in _table(o.instructions or "x 0").items():
            instructions.setdefault(k, sig)
        for k, sig in _table(o.functions or "x 0").items():
            functions.setdefault(k, sig)
        types |= set(o.types.split())
    instructions.pop("x", None)
    functions.pop("x", None)
    elsewhere: dict[str, list[str]] = {}
    for o in OPTIONS:
        if o not in chosen:
            for name in _names(o):
                elsewhere.setdefault(name.lower(), []).append(o.title)
    return Catalogue(instructions, functions, frozenset(types),
                     {k: tuple(v) for k, v in elsewhere.items()})
