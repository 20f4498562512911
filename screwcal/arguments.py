"""The command-line vocabulary every package's commands share (the face's `screwcal/commands`,
the service's `serve` and `job`, the simulators' `emulator`): option types that refuse NaN,
infinities and out-of-range values (argparse names the option in its error, exit 2), an option
renamed with a deprecation warning (`add_option`), a vector `X Y Z` (`add_vector`), the error
models' names, the payload's options, the output files' checks (`check_outputs`: the folder
exists and is writable, the file is none of the command's inputs; checked before any work, never
after it). A floor below the face: the face and the floors import
it, it imports nothing of theirs.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

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


def bounded_int(low: int, high: int) -> Callable[[str], int]:
    """A whole number within [low, high] (a count a later stage bounds: refused at the edge,
    not after the start-up)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be from {low} to {high}, not {text}")
        return value

    return parse


def bounded_float(low: float, high: float) -> Callable[[str], float]:
    """A finite number in (low, high] (a length a later stage bounds: refused at the edge)."""
    def parse(text: str) -> float:
        value = _number(text)
        if not low < value <= high:
            raise argparse.ArgumentTypeError(f"must be above {low:g} and at most {high:g}, "
                                             f"not {text}")
        return value

    return parse


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


# -- one vocabulary across commands (issue 27) ---------------------------------------------------
# A robot description is `--robot NAME|FILE`, an error model `--error-model`, a calibration
# result `--result FILE`; a vector is three numbers `X Y Z` (add_vector); a value with a unit
# carries it in the option's name (`--arm-radius-mm`). An older spelling stays one release as a
# deprecated alias that warns on stderr (Renamed). The offline contract (spec data-formats.md)
# fixes `calibrate --model` and `predict --model`: those stay for good, without a warning.
CONTRACT_SPELLINGS = {("calibrate", "--model"), ("predict", "--model")}
# The error models (calibration.error_parameters.ModelKind, spelled here so that `--help` does
# not import the numeric code; a test holds the two equal), the default first
ERROR_MODELS = ("full", "thesis", "joints", "frames")


def deprecation_warning(old: str, new: str) -> None:
    """The one warning of a deprecated spelling: on stderr, never on stdout (where a command's
    output goes), and the command runs as before."""
    print(f"screwcal: warning: {old} is deprecated and will be removed in the next release; "
          f"use {new}", file=sys.stderr)


class Renamed(argparse.Action):
    """A stored option that may also be given by an older name (`renamed`: the older names);
    given that way, it warns (deprecation_warning) and stores the value as the new name does."""

    def __init__(self, option_strings: Sequence[str], dest: str, renamed: Sequence[str] = (),
                 **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.renamed = tuple(renamed)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        if option_string in self.renamed:
            deprecation_warning(option_string, self.option_strings[0])
        setattr(namespace, self.dest, self.convert(values, option_string))

    def convert(self, values: Any, option_string: str | None) -> Any:
        return values


def add_option(p: argparse.ArgumentParser | argparse._ArgumentGroup, name: str, *,
               renamed: Sequence[str] = (), **kwargs: Any) -> argparse.Action:
    """An option with a value, by its name and, for one release, its older names (each warns
    when used). The older names are listed in the help after the new one."""
    kwargs["help"] = _with_older_names(kwargs.get("help"), renamed)
    return p.add_argument(name, *renamed, action=Renamed, renamed=renamed, **kwargs)


def _with_older_names(help: str | None, renamed: Sequence[str]) -> str | None:
    if not renamed or help is None:
        return help
    return f"{help} ({', '.join(renamed)}: the older name, deprecated)"


class Vector(Renamed):
    """Three finite numbers `X Y Z` (mm or deg, as the option's name says): the one parser of
    every vector option. The older one-word form `X,Y,Z` is split by old_vector_words."""

    def convert(self, values: Any, option_string: str | None) -> tuple[float, float, float]:
        x, y, z = values
        return x, y, z


def add_vector(p: argparse.ArgumentParser | argparse._ArgumentGroup, name: str, *, help: str,
               renamed: Sequence[str] = (), metavar: tuple[str, str, str] = ("X", "Y", "Z"),
               **kwargs: Any) -> argparse.Action:
    """A vector option: `name X Y Z` (three numbers)."""
    return p.add_argument(name, *renamed, action=Vector, renamed=renamed, nargs=3,
                          type=finite_float, metavar=metavar,
                          help=_with_older_names(help, renamed), **kwargs)


def vector_options(parser: argparse.ArgumentParser) -> set[str]:
    """Every option string of a Vector option, in the parser and all its subcommands."""
    names: set[str] = set()
    for action in parser._actions:
        if isinstance(action, Vector):
            names.update(action.option_strings)
        elif isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                names |= vector_options(sub)
    return names


def old_vector_words(argv: Sequence[str], vectors: set[str]) -> list[str]:
    """The command line with a vector given the older way, one word `X,Y,Z` (the payload's
    centre of gravity took it so), split into `X Y Z`, with a deprecation warning."""
    out: list[str] = []
    words = list(argv)
    k = 0
    while k < len(words):
        word = words[k]
        name, eq, value = word.partition("=")
        if name in vectors and eq and "," in value:
            parts = [name, *value.split(",")]
        elif word in vectors and k + 1 < len(words) and "," in words[k + 1]:
            parts = [word, *words[k + 1].split(",")]
            k += 1
        else:
            out.append(word)
            k += 1
            continue
        deprecation_warning(f"{name} X,Y,Z", f"{name} X Y Z (three words)")
        out += parts
        k += 1
    return out


def add_payload_arguments(p: argparse.ArgumentParser) -> None:
    """The payload on the flange: `--payload-kg`, `--payload-cog-mm X Y Z`."""
    p.add_argument("--payload-kg", type=non_negative_float, default=None,
                   help="mass on the flange (joint compliance scales with it; default: the "
                   "model's)")
    add_vector(p, "--payload-cog-mm", default=(0.0, 0.0, 0.0),
               help="its centre of gravity in the flange (tool0) frame, mm (default 0 0 0)")
