"""What a task loads: the module files of `--program` (files, or a folder such as a backup's
TASK folder or a saved program's: `screwcal.rapid.tasks`), and the values `--set NAME=VALUE`
gives the modules' data. The emulated controller runs one task: a folder holding several
(a whole backup) is refused, naming them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path

from screwcal.rapid.tasks import tasks_in
from simulators.rapid.errors import LoadError, SettingError


def module_files(paths: Iterable[Path]) -> list[Path]:
    """The module files of these files and folders, each once, in the order given."""
    out: list[Path] = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            tasks = tasks_in(p)
            if not tasks:
                raise LoadError(str(p), 0, "no RAPID module in this folder")
            if len(tasks) > 1:
                raise LoadError(str(p), 0, f"{len(tasks)} tasks in this folder ("
                                f"{', '.join(t.name for t in tasks)}): the emulated controller "
                                "runs one; give its folder")
            out.extend(f for f in tasks[0].modules if f not in out)
        elif p.is_file():
            if p not in out:
                out.append(p)
        else:
            raise LoadError(str(p), 0, "no such file or folder")
    return out


class RapidText(str):
    """A datum's value as RAPID text (`--set NAME=VALUE`): evaluated as the datum's type when
    the task loads (a num, "a string" or a bare one, TRUE, an aggregate [..])."""


def assignments(items: Iterable[str]) -> dict[str, str]:
    """`NAME=VALUE` items by lower-case name; a malformed item is a SettingError naming it."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name) or not value.strip():
            raise SettingError(item, "expected NAME=VALUE, a datum of the program and its "
                               "RAPID value (e.g. serverPort=5000)")
        out[name.lower()] = value.strip()
    return out
