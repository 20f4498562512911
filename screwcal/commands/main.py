"""The `screwcal` console script: a thin face that only dispatches to each command's module.

It is the one place that imports across packages (docs/architecture.md): the core owns calibrate,
predict, evaluate, ...; the simulators own `emulator`.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

from screwcal import __version__
from screwcal.errors import ScrewcalError
from screwcal.runtime.policy import for_command_line

# Each subcommand and the module that registers it (`add_parser`) and runs it. A command named
# on the line imports its module alone (`screwcal calibrate` need not import the service, the
# emulators or pydantic: start-up is most of a small calibration's time); `--help`, no command
# or an unknown one build them all, in this order. A test holds the table to the modules.
COMMANDS = {
    "simulate": "screwcal.commands.simulate",
    "calibrate": "screwcal.commands.calibrate",
    "compensate": "screwcal.commands.compensate",
    "align": "screwcal.commands.calibrate",
    "predict": "screwcal.commands.predict",
    "evaluate": "screwcal.commands.evaluate",
    "testcube": "screwcal.commands.testcube",
    "study": "screwcal.commands.study",
    "robot": "screwcal.commands.robot",
    "rapid": "screwcal.commands.rapid",
    "demo": "screwcal.commands.demo",
    "emulator": "simulators.cli",
    "serve": "service.cli",
    "job": "service.cli",
    "user": "service.people_cli",
    "audit": "service.people_cli",
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand, or of `command`'s module only."""
    parser = argparse.ArgumentParser(
        prog="screwcal",
        description="Screw-theory calibration of 6-axis industrial robots (mm and degrees).")
    parser.add_argument("--version", action="version", version=f"screwcal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    modules = [COMMANDS[command]] if command in COMMANDS else list(dict.fromkeys(
        COMMANDS.values()))
    for name in modules:
        importlib.import_module(name).add_parser(sub)
    return parser


def _command_named(argv: Sequence[str]) -> str | None:
    """The subcommand on the line: its first word, when no option comes before it."""
    return argv[0] if argv and argv[0] in COMMANDS else None


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    for_command_line()  # BLAS threads, heap, collector: the process's (screwcal.runtime.policy)
    try:
        parser = build_parser(_command_named(argv))
        from screwcal.arguments import old_vector_words, vector_options

        args, unknown = parser.parse_known_args(old_vector_words(argv, vector_options(parser)))
        if unknown:  # said by the command's own parser: its usage, not the top level's
            _chosen_parser(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    except KeyboardInterrupt:  # Ctrl-C while the command's modules load
        print("screwcal: interrupted", file=sys.stderr)
        return 130
    try:
        from screwcal.commands.file_kinds import refuse_wrong_kinds

        wrong = refuse_wrong_kinds(args)  # a demo's job.json given to predict, ...
        if wrong is not None:
            return _refused(args.command, wrong)
        code = int(args.func(args))
        sys.stdout.flush()  # a reader gone shows here (a pipe buffers), not at exit
        return code
    except ScrewcalError as err:
        return _refused(args.command, err)
    except KeyboardInterrupt:
        print(f"screwcal {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader left (`screwcal calibrate ... | head`): the command
        # stops where it was, as SIGPIPE would stop it, without a traceback (calibrate has
        # written its result by then: it prints after)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
        return 141  # as a shell reports a command ended by SIGPIPE
    except OSError as err:  # a path the user gave: a folder, missing, not writable, ...
        from screwcal.commands.path_errors import path_error_text

        return _refused(args.command, path_error_text(err, args, parser))
    except Exception as err:
        from service.errors import ServiceError  # only the service's commands raise it

        if not isinstance(err, ServiceError):
            raise
        return _refused(args.command, err)


def _chosen_parser(parser: argparse.ArgumentParser, args: argparse.Namespace
                   ) -> argparse.ArgumentParser:
    """The innermost subcommand parser the parsed `args` went through."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(args, action.dest, None) or "")
            if chosen is not None:
                return _chosen_parser(chosen, args)
    return parser


def _refused(command: str, err: Exception | str) -> int:
    print(f"screwcal {command}: error: {err}", file=sys.stderr)
    return 2
