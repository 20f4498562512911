"""The CLI's error boundary for paths: an operating-system error on a path the user gave becomes
one line that names the path, what is wrong with it and what the argument expects.

    /tmp: is a folder; --out expects the file to write

The argument is found by the path: the parsed value equal to the error's path, the folder that
holds it (an output folder's file), or its stem (`x` written as `x.png`, `x.tmp`, `x.owner`).
Without a match the line names the path and what is wrong alone.
"""

from __future__ import annotations

import argparse
import errno
from collections.abc import Iterator
from pathlib import Path

WHAT_IS_WRONG = {
    errno.ENOENT: "does not exist",
    errno.EISDIR: "is a folder, not a file",
    errno.ENOTDIR: "is not a folder (or a part of its path is a file)",
    errno.EEXIST: "exists and is not a folder",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EROFS: "is on a read-only file system",
    errno.ENOSPC: "no space left on the device",
    errno.ENAMETOOLONG: "the name is too long",
    errno.ELOOP: "too many symbolic links",
}
# Options that name a file or folder to write: a missing path there cannot be created
OUTPUTS = {"--out", "--plot", "--plots", "--db", "--world"}


def path_error_text(err: OSError, args: argparse.Namespace,
                    parser: argparse.ArgumentParser) -> str:
    """The one line for `err`, raised while running the command `args` parsed by `parser`."""
    paths = [str(p) for p in (err.filename, err.filename2) if p is not None]
    for option, value, expects in _path_arguments(args, parser):
        for path in paths:
            shown = _as_given(value, path)
            if shown is not None:
                return f"{shown}: {_what_is_wrong(err, shown, option)}; {option} expects {expects}"
    if not paths:
        return _what_is_wrong(err, "", "")
    return f"{paths[-1]}: {_what_is_wrong(err, paths[-1], '')}"


def _what_is_wrong(err: OSError, path: str, option: str) -> str:
    if err.errno == errno.ENOENT and path:
        folder = Path(path).parent
        if not folder.is_dir():
            return f"its folder {folder} does not exist"
        if option in OUTPUTS:
            return f"cannot be created in {folder}"
    return WHAT_IS_WRONG.get(err.errno or 0) or (err.strerror or str(err)).rstrip(".")


def _as_given(value: str, path: str) -> str | None:
    """The path to name when the error's `path` is the argument's `value` (the value), a file
    in that folder (the file), or a file named after the value, as `x.png`, `.x.1a2b.tmp` or
    `x.tmp` when `x` or `x.json` is written (the value); None when it is none of these."""
    v, p = Path(value), Path(path)
    if _same(v, p):
        return value
    if _same(v, p.parent):
        return path
    if _same(v.parent, p.parent) and v.name and (
            p.name.startswith((f"{v.name}.", f".{v.name}.")) or p.stem == v.stem):
        return value
    return None


def _same(a: Path, b: Path) -> bool:
    try:
        return a.absolute() == b.absolute()
    except OSError:
        return str(a) == str(b)


def _path_arguments(args: argparse.Namespace, parser: argparse.ArgumentParser
                    ) -> Iterator[tuple[str, str, str]]:
    """(option, what it expects) of every string or path value in `args`, in the order of the
    parsers the command line went through."""
    for action in _actions(args, parser):
        value = getattr(args, action.dest, None)
        values = value if isinstance(value, list) else [value]
        for item in values:
            if isinstance(item, str | Path) and str(item):
                option = action.option_strings[0] if action.option_strings else (
                    action.metavar if isinstance(action.metavar, str) else action.dest.upper())
                yield option, str(item), _expects(action)


def _expects(action: argparse.Action) -> str:
    text = (action.help or action.dest).split(";")[0].strip()
    text = text.split(" (default")[0].rstrip(". ")
    return text[:1].lower() + text[1:] if text[:2] != text[:2].upper() else text


def _actions(args: argparse.Namespace, parser: argparse.ArgumentParser
             ) -> Iterator[argparse.Action]:
    """The actions of `parser` and of each subparser the parsed `args` chose."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(args, action.dest, None) or "")
            if chosen is not None:
                yield from _actions(args, chosen)
        elif action.dest != "help":
            yield action
