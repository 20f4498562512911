"""Checks of the offline commands' options at the edge, before any work is done.

- Numeric options: argparse types that refuse NaN, infinities, and negative or zero values
  where the option is a size, a count or a noise level; argparse names the option in its error
  (`argument --noise-mm: ...`) and exits with 2.
- Output files: the folder must exist and be writable, and the file must not be one of the
  command's inputs (`check_outputs`); checked before a fit, never after it.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Iterable
from pathlib import Path

from screwcal.errors import DataFileError


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"'{text}' is not a finite number")
    return value


def finite_float(text: str) -> float:
    """Any finite number (a coordinate, an offset)."""
    return _number(text)


def positive_float(text: str) -> float:
    """A finite number > 0 (a length, a noise level, a weight)."""
    value = _number(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be > 0, not {text}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number >= 0 (a level where 0 means "none", e.g. no random joint error)."""
    value = _number(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"must be >= 0, not {text}")
    return value


def positive_int(text: str) -> int:
    """A whole number >= 1 (a count)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, not {text}")
    return value


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


def vec3(text: str) -> tuple[float, float, float]:
    """`x,y,z` (mm): three finite numbers."""
    parts = text.split(",")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"give x,y,z in mm, not '{text}'")
    try:
        x, y, z = (finite_float(v) for v in parts)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"give x,y,z in mm, not '{text}'") from None
    return x, y, z
