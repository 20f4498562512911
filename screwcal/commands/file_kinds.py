"""Files given to the wrong command: each file argument names the kinds of file it takes; a file
recognisably of another kind is refused before any work, with a sentence naming the command
that takes it.

    screwcal predict: error: demo-output/job.json is a job's whole result, which no command
    reads; --result takes a calibration result: the demo's result.json, or `screwcal job model
    ID --out result.json`

A file is recognised by its first bytes and, for JSON, its members (`kind_of`); a file of no
known kind is left to the command's reader, which says what is wrong with it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

# kind: (what it is, which command takes it)
KINDS = {
    "result": ("a calibration result", "screwcal predict --result, compensate --result and "
               "robot export take it"),
    "model": ("a robot or model file", "--robot of calibrate, predict, compensate and testcube "
              "takes it"),
    "job": ("a job's whole result (the demo's job.json, GET /jobs/ID/result)",
            "no command reads it; the calibrated model is the demo's result.json, or `screwcal "
            "job model ID --out result.json`"),
    "evaluation": ("an evaluation report (screwcal evaluate --out)", "no command reads it"),
    "html": ("a report page", "open it in a browser"),
    "measurements": ("a measurement file", "screwcal calibrate --data takes it"),
    "performance": ("a performance test file", "screwcal evaluate --data takes it"),
    "joints": ("a joints file", "screwcal predict --joints takes it"),
    "poses": ("a pose file (x, y, z, rx, ry, rz without joints)",
              "screwcal compensate --targets or --measuring-targets takes it"),
    "sweeps": ("a sweeps file", "screwcal align --sweeps and calibrate --base-guess take it"),
    "rapid": ("a RAPID module", "screwcal compensate --rapid and rapid check take it"),
    "urdf": ("a URDF", "screwcal robot import takes it"),
}
ROBOT = frozenset({"model", "result"})
# (command, action, option's dest) -> the kinds it takes; any other known kind is refused
TAKES: dict[tuple[str, str, str], tuple[frozenset[str], str]] = {
    ("calibrate", "", "robot"): (ROBOT, "a library robot or a robot file"),
    ("calibrate", "", "data"): (frozenset({"measurements"}), "a measurement file"),
    ("calibrate", "", "base_guess"): (frozenset({"sweeps"}), "a sweeps file"),
    ("align", "", "robot"): (ROBOT, "a library robot or a robot file"),
    ("align", "", "sweeps"): (frozenset({"sweeps"}), "a sweeps file"),
    ("predict", "", "result"): (ROBOT, "a calibration result"),
    ("predict", "", "robot"): (ROBOT, "a library robot or a robot file"),
    ("predict", "", "model"): (ROBOT, "a calibration result or a robot file"),
    ("predict", "", "joints"): (frozenset({"joints", "measurements", "performance"}),
                                "a joints file"),
    ("compensate", "", "result"): (ROBOT, "a calibration result"),
    ("compensate", "", "robot"): (ROBOT, "a library robot or a robot file"),
    ("compensate", "", "targets"): (frozenset({"poses", "measurements"}), "a pose file"),
    ("compensate", "", "measuring_targets"): (frozenset({"poses", "measurements"}),
                                              "a pose file"),
    ("compensate", "", "rapid"): (frozenset({"rapid"}), "a RAPID module"),
    ("evaluate", "", "data"): (frozenset({"performance"}), "a performance test file"),
    ("evaluate", "", "before"): (frozenset({"performance"}), "a performance test file"),
    ("testcube", "", "robot"): (ROBOT, "a library robot or a robot file"),
    ("robot", "show", "robot"): (ROBOT, "a library robot or a robot file"),
    ("robot", "export", "result"): (ROBOT, "a calibration result or a robot file"),
    ("robot", "import", "file"): (frozenset({"model", "urdf"}), "a robot description"),
}


def refuse_wrong_kinds(args: argparse.Namespace) -> str | None:
    """The sentence refusing the first file argument of `args` that is recognisably of a kind
    its option does not take; None when there is none."""
    command = getattr(args, "command", "") or ""
    action = getattr(args, "action", "") or ""
    for (cmd, act, dest), (takes, wanted) in TAKES.items():
        if cmd != command or (act and act != action):
            continue
        given = getattr(args, dest, None)
        for value in given if isinstance(given, list) else [given]:
            kind = kind_of(Path(value)) if isinstance(value, str | Path) and value else None
            if kind is None or kind in takes:
                continue
            what, who = KINDS[kind]
            option = dest.upper() if command == "robot" else f"--{dest.replace('_', '-')}"
            return f"{value} is {what}: {who}; {option} takes {wanted}"
    return None


def kind_of(path: Path) -> str | None:
    """The kind of the file at `path` (a key of KINDS), or None: not a file, or not one of
    them."""
    try:
        if not path.is_file():
            return None
        with path.open("rb") as f:
            head = f.read(4096)
    except OSError:
        return None
    text = head.decode("utf-8", errors="replace").lstrip("\ufeff").lstrip()
    lowered = text[:200].lower()
    if lowered.startswith(("<!doctype html", "<html")):
        return "html"
    if lowered.startswith("<?xml") or lowered.startswith("<robot"):
        return "urdf" if "<robot" in lowered or "<robot" in text.lower() else None
    if text.startswith("{"):
        return _json_kind(path)
    if lowered.startswith(("module ", "%%%")):
        return "rapid"
    return _csv_kind(text.splitlines()[0] if text else "")


def _json_kind(path: Path) -> str | None:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict):
        return None
    form = doc.get("format")
    if form == "screwcal-calibration":
        return "result"
    if form == "screwcal-model":
        return "model"
    if "state" in doc and ({"performance", "calibration", "estimation"} & doc.keys()):
        return "job"
    if "units" in doc and "result" in doc:
        return "evaluation"
    return None


def _csv_kind(header: str) -> str | None:
    columns = {c.strip().lower() for c in header.split(",")}
    joints = {f"q{i}" for i in range(1, 7)} <= columns
    position = {"x", "y", "z"} <= columns
    some_position = bool({"x", "y", "z"} & columns)  # a measurement file missing a column
    if columns & {"cycle", "x_cmd", "y_cmd", "z_cmd"}:  # one of its own is enough: a file
        return "performance"  # missing another is the reader's to name
    if "joint" in columns and "q1" in columns and position:
        return "sweeps"
    if joints and some_position:
        return "measurements"
    if joints:
        return "joints"
    if position and {"rx", "ry", "rz"} <= columns:
        return "poses"
    return None
