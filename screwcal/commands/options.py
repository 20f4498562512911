"""Checks of the offline commands' output files at the edge, before any work is done: the
folder must exist and be writable, and the file must not be one of the command's inputs
(`check_outputs`); checked before a fit, never after it. Output folders are made before the
work (`make_output_folder`). (The options' vocabulary, shared with the service's and the
simulators' commands, is a floor below: screwcal/arguments.py.)
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from screwcal.errors import DataFileError


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and a.samefile(b))
    except OSError:
        return False


def check_outputs(outputs: Iterable[str | Path | None], inputs: Iterable[str | Path | None]
                  ) -> None:
    """Refuse (DataFileError) an output file whose folder is missing or not writable, or that
    is one of the inputs: a command never overwrites what it reads."""
    given_inputs = [Path(p) for p in inputs if p]
    for out in outputs:
        if not out:
            continue
        path = Path(out)
        for source in given_inputs:
            if _same_file(path, source):
                raise DataFileError(str(path), f"is also the input {source}: choose another "
                                    "output file (the input is never overwritten)")
        if path.is_dir():
            raise DataFileError(str(path), "is a folder: name the output file")
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise DataFileError(str(path), f"the folder {folder} does not exist: create it or "
                                "choose another output")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise DataFileError(str(path), f"the folder {folder} is not writable")


def make_output_folder(folder: str | Path, option: str = "--out") -> Path:
    """Create the output folder (and its parents) before any work is done: a file of that
    name is refused now, not after the work; a place where no folder can be made raises the
    OSError that the CLI's boundary names (commands/path_errors.py)."""
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise DataFileError(str(path), f"is a file; {option} names a folder for the outputs")
    path.mkdir(parents=True, exist_ok=True)
    return path
