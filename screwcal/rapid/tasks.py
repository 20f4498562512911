"""The tasks of a RAPID program on disk: which modules a controller loads together.

A controller backup keeps each task's modules under `RAPID/TASKn/PROGMOD` and
`RAPID/TASKn/SYSMOD` (the task's name is in its SYSPAR; the folder's name is used here); a
program folder saved from a task has its `.mod`, `.modx`, `.sys`, `.sysx` files (and a `.pgf`
naming them) side by side. `tasks_in(path)` finds them: every folder holding PROGMOD or SYSMOD
is one task; a folder of modules without them is one task; in a backup (where tasks are), HOME
holds files, not tasks: it is left out.
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
    # system modules of the tree outside the task (a controller's HOME/__MODULI__ of a tree
    # without TASKn folders), loaded beside it: read for their names
    context: tuple[Path, ...] = ()


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
    # files, not a task: left out when there are tasks)
    folders = sorted({p.parent for p in path.rglob("*") if p.is_file()
                      and p.suffix.lower() in MODULE_SUFFIXES} | ({path} if _modules(path)
                                                                   else set()))
    loose = []
    for f in folders:
        inside = (f, *f.parents)
        if any(t in inside for t in task_dirs) or (task_dirs and any(
                d.name.lower() == "home" for d in inside if path in (d, *d.parents))):
            continue
        loose.append(f)
    system = [m for f in loose for m in _modules(f) if m.suffix.lower() in (".sys", ".sysx")]
    found += [Task(f.name, tuple(_modules(f)), tuple(m for m in system if m.parent != f))
              for f in loose]
    return found
