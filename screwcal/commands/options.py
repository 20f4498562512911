"""The offline commands' output folders, made before the work (`make_output_folder`). (The
options' vocabulary and the output files' checks, shared with the service's and the
simulators' commands, are a floor below: screwcal/arguments.py.)
"""

from __future__ import annotations

from pathlib import Path

from screwcal.errors import DataFileError


def make_output_folder(folder: str | Path, option: str = "--out") -> Path:
    """Create the output folder (and its parents) before any work is done: a file of that
    name is refused now, not after the work; a place where no folder can be made raises the
    OSError that the CLI's boundary names (commands/path_errors.py)."""
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise DataFileError(str(path), f"is a file; {option} names a folder for the outputs")
    path.mkdir(parents=True, exist_ok=True)
    return path
