"""One vocabulary across commands (issue 27, point 5): every parser of every entry point walked.

- every option and argument has help;
- a value with a unit carries it in the option's name, or is declared unitless below;
- every vector is `X Y Z`, parsed by one function (options.add_vector);
- a concept has one word: `--robot` a robot description (or, in `job start`, a registered
  robot), `--error-model` an error model, `--result` a calibration result; the older spellings
  warn on stderr for one release; the offline contract's (spec data-formats.md) stay silent;
- every command line the README and the docs show parses, with no deprecated spelling.
"""

import argparse
import re
import shlex
from pathlib import Path
from typing import get_args

import pytest

from screwcal.arguments import (
    CONTRACT_SPELLINGS,
    ERROR_MODELS,
    Renamed,
    Vector,
    finite_float,
    non_negative_float,
    positive_float,
    positive_int,
)
from screwcal.commands.main import build_parser, main

ROOT = Path(__file__).resolve().parents[3]
NUMERIC = {int, float, finite_float, positive_float, non_negative_float, positive_int}
UNIT = re.compile(r"-(mm|deg|rad|kg|s|deg-s|knm)$")
# Options whose number has no unit: counts, seeds, ports, ids, factors.
UNITLESS = {"--seed", "--noise-seed", "--realism-seed", "--poses", "--validation", "--cycles",
            "--warmup-cycles", "--samples", "--workers", "--port", "--arm-port", "--round",
            "--frame-from-job", "--time-scale", "id", "--backlash-poses", "--drift-poses",
            "--drift-period-poses", "--tracker-port", "--smrs", "token_id", "--after",
            "--index"}
# Options whose value holds a vector inside a larger form (one word per list: LIST=KG:X,Y,Z)
COMPOUND = {"--list-payload"}
# The older spellings, each renamed to the option that replaced it (warns for one release)
RENAMED = {
    ("compensate", "--model"): "--result",
    ("testcube", "--centre"): "--centre-mm",
    ("testcube", "--orientation"): "--orientation-deg",
    ("testcube", "--approach"): "--approach-mm",
    ("testcube", "--arm-centre"): "--arm-centre-mm",
    ("testcube", "--arm-radius"): "--arm-radius-mm",
    ("testcube", "--floor-z"): "--floor-z-mm",
    ("demo", "--model"): "--error-model",
    ("job robot-add", "--model"): "--robot",
    ("job start", "--model"): "--error-model",
    ("job start", "--arm-position"): "--arm-position-mm",
}


def _walk(parser, path=()):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _walk(sub, (*path, name))
        elif not isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            yield " ".join(path), parser, action


def _entry_points():
    """Every parser users run: the `screwcal` command and the studies run as modules."""
    from screwcal.studies import montecarlo, position_only, tracker_study

    yield from _walk(build_parser())
    for module in (montecarlo, position_only, tracker_study):
        yield from _walk(module.parser(), (module.__name__,))


ALL = list(_entry_points())


def _name(action):
    return action.option_strings[0] if action.option_strings else action.dest


def test_every_entry_point_is_walked():
    commands = {c.split()[0] for c, _, _ in ALL if c}
    assert commands >= {"simulate", "calibrate", "compensate", "align", "predict", "evaluate",
                        "testcube", "study", "robot", "rapid", "demo", "emulator", "serve",
                        "job"}
    assert {"emulator irc5", "emulator arm", "job start", "job robot-add",
            "screwcal.studies.montecarlo"} <= {c for c, _, _ in ALL}


def test_every_option_has_help():
    missing = [f"{c} {_name(a)}" for c, _, a in ALL
               if not a.help and a.help is not argparse.SUPPRESS
               and a.option_strings not in (["--service"], ["--token"])]
    hidden = [f"{c} {_name(a)}" for c, _, a in ALL if a.help == argparse.SUPPRESS
              and a.option_strings not in (["--service"], ["--token"])]
    assert not missing and not hidden, missing + hidden


def test_every_number_with_a_unit_names_it():
    """A numeric option carries its unit in its name (`--arm-radius-mm`), or is declared
    unitless (a count, a seed, a port) in UNITLESS."""
    unnamed = [f"{c} {_name(a)}" for c, _, a in ALL
               if (a.type in NUMERIC or isinstance(a, Vector))
               and not UNIT.search(_name(a)) and _name(a) not in UNITLESS]
    assert not unnamed, unnamed
    used = {_name(a) for _, _, a in ALL}
    assert UNITLESS <= used, UNITLESS - used  # the table names no option that is gone


def test_vectors_are_x_y_z_through_one_parser():
    """Three numbers are always `X Y Z` through options.add_vector: no other nargs=3, no
    option that takes `X,Y,Z` as one word (but inside a compound form)."""
    for c, _, a in ALL:
        if a.nargs == 3 or (isinstance(a.metavar, tuple) and len(a.metavar) == 3):
            assert isinstance(a, Vector), f"{c} {_name(a)}"
        if isinstance(a, Vector):
            assert a.nargs == 3 and a.type is finite_float, f"{c} {_name(a)}"
        if _name(a) not in COMPOUND and isinstance(a.metavar, str):
            assert not re.search(r"\w+,\w+,\w+", a.metavar), f"{c} {_name(a)}: {a.metavar}"


def test_one_word_per_concept():
    """`--model` is no option's own name any more: the contract's two spellings (silent) and the
    renamed ones (warning) only; the error model has one list of choices everywhere."""
    from screwcal.calibration.error_parameters import ModelKind
    from screwcal.kinematics.readings import JOINT_CONVENTIONS

    assert set(ERROR_MODELS) == set(get_args(ModelKind))
    for c, _, a in ALL:
        if "--model" in a.option_strings:
            assert a.option_strings[0] != "--model" or (c, "--model") in CONTRACT_SPELLINGS, c
        if a.dest == "error_model":
            assert tuple(a.choices) == ERROR_MODELS, c
        if a.dest == "joint_convention":
            assert tuple(a.choices) == JOINT_CONVENTIONS, c
    renamed = {(c, old): a.option_strings[0] for c, _, a in ALL if isinstance(a, Renamed)
               for old in a.renamed}
    assert renamed == RENAMED
    assert all("deprecated" in a.help for _, _, a in ALL if isinstance(a, Renamed) and a.renamed)
    spelled = {(c, s) for c, _, a in ALL for s in a.option_strings}
    assert CONTRACT_SPELLINGS <= spelled


def _value_for(action):
    if isinstance(action, Vector):
        return ["1", "2", "3"]
    if action.choices:
        return list(action.choices)[-1]
    return "7" if action.type in NUMERIC else "x.json"


@pytest.mark.parametrize("where", sorted(RENAMED))
def test_each_older_spelling_warns_on_stderr_and_parses_as_the_new(where, capsys):
    command, old = where
    parser, action = next((p, a) for c, p, a in ALL if c == command and old in a.option_strings)
    words = _value_for(action)
    words = words if isinstance(words, list) else [words]
    for spelling in (old, action.option_strings[0]):
        ns = argparse.Namespace()
        values = parser._get_values(action, words)  # the conversion argparse does
        action(parser, ns, values, spelling)
        out, err = capsys.readouterr()
        assert out == ""
        if spelling == old:
            assert f"{old} is deprecated" in err and action.option_strings[0] in err
        else:
            assert err == ""
        assert getattr(ns, action.dest) is not None


def test_older_spellings_run_the_same_command(tmp_path, capsys):
    """testcube with every older spelling writes what the new spellings write, and says on
    stderr only that the old ones go."""
    new = ["testcube", "--robot", "irb1600", "--edge-mm", "300", "--centre-mm", "800", "0", "700",
           "--arm-centre-mm", "500", "0", "0", "--arm-radius-mm", "1200", "--floor-z-mm", "-10",
           "--approach-mm", "0", "0", "40", "--orientation-deg", "0", "180", "0", "--cycles", "2"]
    old = [{"--centre-mm": "--centre", "--arm-centre-mm": "--arm-centre",
            "--arm-radius-mm": "--arm-radius", "--floor-z-mm": "--floor-z",
            "--approach-mm": "--approach", "--orientation-deg": "--orientation"}.get(w, w)
           for w in new]
    assert main([*new, "--out", str(tmp_path / "new.csv")]) == 0
    out_new, err_new = capsys.readouterr()
    assert main([*old, "--out", str(tmp_path / "old.csv")]) == 0
    out_old, err_old = capsys.readouterr()
    assert (tmp_path / "new.csv").read_text() == (tmp_path / "old.csv").read_text()
    assert out_old.replace("old.csv", "new.csv") == out_new and err_new == ""
    assert err_old.count("is deprecated") == 6


def test_a_vector_given_the_older_way_is_split_with_a_warning(capsys):
    """`--payload-cog-mm X,Y,Z` (one word) was the payload's syntax: it still parses, negative
    numbers too, and warns; `X Y Z` is the one syntax."""
    from screwcal.arguments import old_vector_words, vector_options

    parser = build_parser("calibrate")
    base = ["calibrate", "--robot", "irb1600", "--data", "d.csv", "--out", "r.json"]
    for words in (["--payload-cog-mm", "-10,0,50.5"], ["--payload-cog-mm=-10,0,50.5"]):
        args = parser.parse_args(old_vector_words([*base, *words], vector_options(parser)))
        assert args.payload_cog_mm == (-10.0, 0.0, 50.5)
        assert "--payload-cog-mm X,Y,Z is deprecated" in capsys.readouterr().err
    args = parser.parse_args([*base, "--payload-cog-mm", "-10", "0", "50.5"])
    assert args.payload_cog_mm == (-10.0, 0.0, 50.5)
    with pytest.raises(SystemExit):
        parser.parse_args([*base, "--payload-cog-mm", "1", "nan", "2"])


def _shown_command_lines():
    """`screwcal ...` lines of the README's and the docs' code blocks that are whole commands
    (no [optional] parts, no A|B choices, no placeholders)."""
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        block = False
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.lstrip().startswith("```"):
                block = not block
                continue
            text = re.split(r"\s(?:&&?|\|\|?|;)(?:\s|$)", line.split("#")[0])[0].strip()
            if block and text.startswith("screwcal ") and not re.search(r"[\[\]|<>]|\.\.\.",
                                                                         text):
                yield path.name, text


LINES = list(_shown_command_lines())


def test_the_docs_show_command_lines():
    assert len(LINES) > 15


@pytest.mark.parametrize("where,line", LINES)
def test_every_command_line_the_docs_show_parses_without_older_spellings(where, line, capsys):
    from screwcal.arguments import old_vector_words, vector_options

    # a shell variable stands for what the shell gives: a port's a number, a folder's a word
    line = re.sub(r"\$\{?([A-Za-z_]\w*)\}?",
                  lambda m: "4012" if m.group(1).endswith("PORT") else m.group(1).lower(), line)
    words = shlex.split(line)[1:]
    parser = build_parser(words[0])
    parser.parse_args(old_vector_words(words, vector_options(parser)))
    assert "deprecated" not in capsys.readouterr().err, (where, line)


def test_the_contract_s_predict_model_stays_silent_and_means_result_or_robot(tmp_path, capsys):
    """spec data-formats.md: `predict --model result.json` and `predict --model irb1600`. Both
    run as `--result` and `--robot` do, with nothing more on stdout or stderr."""
    from screwcal.kinematics.modelfile import save_model
    from screwcal.kinematics.robots import builtin_model

    joints = tmp_path / "j.csv"
    joints.write_text("id,q1,q2,q3,q4,q5,q6\na,10,20,-30,40,50,60\n")
    save_model(builtin_model("irb120"), tmp_path / "m.json")
    for old, new, given in (("--model", "--result", str(tmp_path / "m.json")),
                            ("--model", "--robot", "irb1600")):
        written = []
        for k, option in enumerate((old, new)):
            out = tmp_path / f"p{k}.csv"
            assert main(["predict", option, given, "--joints", str(joints), "--out",
                         str(out)]) == 0
            captured = capsys.readouterr()
            assert captured.err == ""
            written.append((out.read_text(), captured.out.replace(out.name, "P")))
        assert written[0] == written[1]
