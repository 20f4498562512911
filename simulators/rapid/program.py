"""What a task loads: the module files of `--program` (files, or folders such as a backup's
TASK folder), and the values `--set NAME=VALUE` gives the modules' data.

A folder holding a program file (`*.pgf`, the controller's list of a program's modules) loads
the modules it names; any other folder loads every module file under it (`.mod`, `.modx`,
`.sys`, `.sysx`: a backup's TASKn/PROGMOD and TASKn/SYSMOD), in name order.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from simulators.rapid.errors import LoadError

MODULE_SUFFIXES = (".mod", ".modx", ".sys", ".sysx")
_PGF_MODULE = re.compile(r"<Module>\s*([^<]+?)\s*</Module>", re.IGNORECASE)


def module_files(paths: Iterable[Path]) -> list[Path]:
    """The module files of these files and folders, each once, in the order given."""
    out: list[Path] = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            found = _folder_modules(p)
            if not found:
                raise LoadError(str(p), 0, "no RAPID module in this folder (looked for "
                                f"{', '.join(MODULE_SUFFIXES)} files and a .pgf program file)")
            out.extend(f for f in found if f not in out)
        elif p.is_file():
            if p not in out:
                out.append(p)
        else:
            raise LoadError(str(p), 0, "no such file or folder")
    return out


def _folder_modules(folder: Path) -> list[Path]:
    programs = sorted(folder.glob("*.pgf"))
    if programs:
        listed: list[Path] = []
        for pgf in programs:
            for name in _PGF_MODULE.findall(pgf.read_text(encoding="utf-8", errors="replace")):
                f = pgf.parent / name.replace("\\", "/")
                if not f.is_file():
                    raise LoadError(str(pgf), 0, f"the program file names {name}: not found")
                listed.append(f)
        return listed
    return sorted((f for f in folder.rglob("*") if f.is_file()
                   and f.suffix.lower() in MODULE_SUFFIXES), key=lambda f: str(f).lower())


class RapidText(str):
    """A datum's value as RAPID text (`--set NAME=VALUE`): evaluated as the datum's type when
    the task loads (a num, "a string" or a bare one, TRUE, an aggregate [..])."""


def assignments(items: Iterable[str]) -> dict[str, str]:
    """`NAME=VALUE` items by lower-case name; a malformed item is a ValueError naming it."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) or not value.strip():
            raise ValueError(f"--set {item!r}: expected NAME=VALUE, a datum of the program "
                             "and its RAPID value (e.g. serverPort=5000)")
        out[name.lower()] = value.strip()
    return out
