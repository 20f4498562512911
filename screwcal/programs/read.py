"""Reading a program of another maker: its language from the files' extensions and contents,
then the one reader of that language."""

from __future__ import annotations

import re
from pathlib import Path

from screwcal.programs.program import Language, Program, ProgramSyntaxError

EXTENSIONS: dict[str, Language] = {".src": "krl", ".dat": "krl", ".ls": "fanuc",
                                   ".script": "urscript", ".urscript": "urscript"}


def language_of(path: str, text: str) -> Language | None:
    """The language of a file, by extension, else by its first words; None: not one of them
    (RAPID, or unknown)."""
    by_ext = EXTENSIONS.get(Path(path).suffix.lower())
    if by_ext is not None:
        return by_ext
    head = text.lstrip("\ufeff \t\r\n")[:2000]
    if head.upper().startswith("/PROG"):
        return "fanuc"
    if re.search(r"^[ \t]*def[ \t]+\w+[ \t]*\([^)]*\)[ \t]*:", head, re.M):
        return "urscript"
    if re.search(r"^[ \t]*(?:GLOBAL[ \t]+)?DEF(?:DAT|FCT)?[ \t]+\w+", head, re.M | re.I):
        return "krl"
    return None


def read_program(texts: dict[str, str], *, config: tuple[str, str] | None = None,
                 frames: tuple[str, str] | None = None) -> Program:
    """The targets of the files (path -> text) of one program; `config` a KUKA $config.dat,
    `frames` a FANUC frames file, each as (path, text). Raises ProgramSyntaxError."""
    languages = {p: language_of(p, t) for p, t in texts.items()}
    unknown = [p for p, lang in languages.items() if lang is None]
    if unknown:
        raise ProgramSyntaxError(unknown[0], 1, "not a KRL (.src/.dat), FANUC LS (.ls) or "
                                 "URScript (.script) program")
    kinds = set(languages.values())
    if len(kinds) > 1:
        raise ProgramSyntaxError(next(iter(texts)), 1, "the files are of several languages "
                                 f"({', '.join(sorted(str(k) for k in kinds))}): compensate "
                                 "one program at a time")
    language = kinds.pop()
    assert language is not None
    program = Program(language, dict(texts))
    # the one reader of the program's language is loaded (its patterns compiled), not all three
    if language == "krl":
        from screwcal.programs.krl import read_config, read_krl

        if config is not None:
            read_config(*config, program)
        read_krl(texts, program)
    elif language == "fanuc":
        from screwcal.programs.fanuc_ls import read_frames, read_ls

        if frames is not None:
            read_frames(*frames, program)
        for path, text in texts.items():
            read_ls(path, text, program)
    else:
        from screwcal.programs.urscript import read_urscript

        for path, text in texts.items():
            read_urscript(path, text, program)
    return program
