"""The tasks of a RAPID program on disk: which modules a controller loads together.

A controller backup keeps each task's modules under `RAPID/TASKn/PROGMOD` and
`RAPID/TASKn/SYSMOD` (the task's name is in its SYSPAR; the folder's name is used here); a
program folder saved from a task has its `.mod`, `.modx`, `.sys`, `.sysx` files (and a `.pgf`
naming them) side by side. `tasks_in(path)` finds them: every folder holding PROGMOD or SYSMOD
is one task; a folder of modules without them is one task; a backup's other folders (HOME,
BACKINFO, SYSPAR) are not tasks.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

MODULE_SUFFIXES = (".mod", ".modx", ".sys", ".sysx", ".prg")
_TASK_PARTS = ("progmod", "sysmod")


@dataclass(frozen=True)
class Task:
    name: str  # the task folder's name (TASK1), or the folder's for a program folder
    modules: tuple[Path, ...]


def _modules(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file()
                  and p.suffix.lower() in MODULE_SUFFIXES)


def tasks_in(path: Path) -> list[Task]:
    """The tasks under `path` (a backup, its RAPID folder, a TASKn folder, or a folder of
    modules), in name order; empty when there is no module."""
    path = Path(path)
    found: list[Task] = []
    task_dirs = sorted({p.parent for p in path.rglob("*") if p.is_dir()
                        and p.name.lower() in _TASK_PARTS})
    for t in task_dirs:
        modules = [m for part in sorted(t.iterdir()) if part.is_dir()
                   and part.name.lower() in _TASK_PARTS for m in _modules(part)]
        if modules:
            found.append(Task(t.name, tuple(modules)))
    # folders of modules outside every task: a program folder each (a backup's HOME holds
    # files, not a task)
    folders = sorted({p.parent for p in path.rglob("*") if p.is_file()
                      and p.suffix.lower() in MODULE_SUFFIXES} | ({path} if _modules(path)
                                                                   else set()))
    for f in folders:
        inside = (f, *f.parents)
        if any(t in inside for t in task_dirs) or any(
                d.name.lower() == "home" for d in inside if path in (d, *d.parents)):
            continue
        found.append(Task(f.name, tuple(_modules(f))))
    return found
