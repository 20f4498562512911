"""Issue 38: careless but ordinary input never shows a Python traceback.

Every command, every file argument, five bad kinds where it goes: a folder, a missing file (or
a missing folder for an output), an existing file (for an input: one that is not what the
argument takes; for an output folder: a file), an unwritable path (/proc/x: a file cannot be
made there, even by root) and an empty file. Each run is a fork of this process with the command
line as the user types it; it must end with a one-line message naming the path (exit 2), or
succeed where the kind is not a mistake for that argument (an output file that exists is
overwritten). A run that neither refuses nor ends within its time fails too: a command must
refuse a bad path before it starts serving.
"""

from __future__ import annotations

import csv
import importlib
import os
import signal
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from screwcal.calibration.posesets import random_configurations
from screwcal.kinematics.modelfile import save_model
from screwcal.kinematics.robots import irb1600
from screwcal.studies.simulated_measurements import simulate_measurements
from tests.screwcal.calibration.test_identify import BASE, TOOL
from tests.screwcal.commands.test_calibrate_cli import _write_measurements
from tests.screwcal.performance.test_evaluate import _write as _write_performance

KINDS = ("folder", "missing", "existing", "unwritable", "empty")
GARBAGE = "this is not what the argument takes\x00\xff\n"


@dataclass(frozen=True)
class Slot:
    """A file argument: the command line with `{}` where the path goes, whether it is read
    (input), written (output) or a folder written (outdir), and the kinds that are no mistake
    there (the command then runs and must succeed)."""

    argv: tuple[str, ...]
    role: str  # "input" | "output" | "outdir"
    fine: frozenset[str] = frozenset()
    findings: frozenset[str] = frozenset()  # kinds reported as a finding: exit 1
    skip: frozenset[str] = frozenset()  # kinds that are no mistake but would serve or run
    entry: str = "screwcal"  # or a module run with `python -m`


def _slot(line: str, role: str, fine: str = "", findings: str = "", skip: str = "",
          entry: str = "screwcal", overwrite: bool = True) -> Slot:
    """An output file that exists, empty or not, is overwritten: no mistake (`overwrite`)."""
    if role == "output" and overwrite and not skip:
        fine += " existing empty"
    return Slot(tuple(line.split()), role, frozenset(fine.split()), frozenset(findings.split()),
                frozenset(skip.split()), entry)


CUBE = "--edge-mm 300 --centre-mm 900 0 700"
# {m} measurements, {r} model file (a calibrated robot), {j} joints, {t} targets, {p} RAPID,
# {perf} performance, {line} straight line, {s} sweeps, {e} emulator errors, {o} a fine output
SLOTS = [
    _slot("calibrate --robot {} --data {m} --out {o}.json", "input"),
    _slot("calibrate --robot irb1600 --data {} --out {o}.json", "input"),
    _slot("calibrate --robot irb1600 --data {m} --out {}", "output", "existing"),
    _slot("calibrate --robot irb1600 --data {m} --out {o}.json --base-guess {}", "input"),
    _slot("align --robot {} --sweeps {s} --out {o}.json", "input"),
    _slot("align --robot irb1600 --sweeps {} --out {o}.json", "input"),
    _slot("align --robot irb1600 --sweeps {s} --out {}", "output", "existing"),
    _slot("predict --result {} --joints {j} --out {o}.csv", "input"),
    _slot("predict --robot {} --joints {j} --out {o}.csv", "input"),
    _slot("predict --model {} --joints {j} --out {o}.csv", "input"),
    _slot("predict --result {r} --joints {} --out {o}.csv", "input"),
    _slot("predict --result {r} --joints {j} --out {}", "output", "existing"),
    _slot("compensate --result {} --targets {t} --out {o}.csv", "input"),
    _slot("compensate --result {r} --targets {} --out {o}.csv", "input"),
    _slot("compensate --result {r} --measuring-targets {} --out {o}.csv", "input"),
    _slot("compensate --result {r} --rapid {} --out {o}.mod", "input"),
    _slot("compensate --result {r} --targets {t} --out {}", "output", "existing"),
    _slot("compensate --result {r} --rapid {p} --out {}", "output", "existing"),
    _slot("compensate --result {r} --robot {} --targets {t} --out {o}.csv", "input"),
    _slot("evaluate --data {} --out {o}.json", "input"),
    _slot("evaluate --data {perf} --out {}", "output", "existing"),
    _slot("evaluate --data {perf} --before {} --out {o}.json", "input"),
    _slot("evaluate --data {perf} --path {} --out {o}.json", "input"),
    _slot("evaluate --data {perf} --path {line} --path-before {} --out {o}.json", "input"),
    _slot("evaluate --data {perf} --out {o}.json --plots {}", "outdir", "folder missing"),
    # a cube given (edge and centre): the largest cube's search (4 s) is not what is tested
    _slot("testcube --robot {} --out {o}.csv --cycles 2", "input"),
    _slot(f"testcube --robot irb1600 --out {{}} --cycles 2 {CUBE}", "output", "existing"),
    _slot(f"testcube --robot irb1600 --out {{o}}.csv --cycles 2 {CUBE} --plot {{}}", "output",
          overwrite=False),  # a-file.txt is no PNG: refused
    _slot("study planar --samples 1 --workers 1 --out {}", "outdir", "folder missing"),
    _slot("robot show {}", "input"),
    _slot("robot import {} --out {o}.json", "input"),
    _slot("robot import {r} --out {}", "output", "existing"),
    _slot("robot export {} --format urdf --out {o}.urdf", "input"),
    _slot("robot export {r} --format urdf --out {}", "output", "existing"),
    _slot("rapid check {}", "input", findings="existing empty"),
    # no service to ask: a path that is no mistake, or that only writing shows (/proc/x as
    # root), ends in "cannot reach the service"
    _slot("job model 1 --out {}", "output", skip="existing empty unwritable"),
    _slot("job report 1 --out {}", "output", skip="existing empty unwritable"),
    _slot("job robot-add --name c --controller 127.0.0.1:1 --arm loop:// --robot {}", "input"),
    _slot("demo --out {}", "outdir", skip="folder missing"),
    _slot("serve --db {} --port 0", "output", skip="empty"),
    _slot("emulator irc5 --port 0 --program {}", "input"),
    _slot("emulator irc5 --port 0 --errors {}", "input"),
    _slot("emulator irc5 --port 0 --realism-file {}", "input"),
    _slot("emulator irc5 --port 0 --world {}", "output", skip="existing empty"),
    _slot("emulator arm --port 0 --world {}", "input", skip="missing existing empty"),
    _slot("--data {}", "input", entry="screwcal.studies.small_sets"),  # python -m
]


@pytest.fixture(scope="module")
def samples(tmp_path_factory) -> dict[str, str]:
    """Small valid inputs for the arguments that are not under test."""
    d = tmp_path_factory.mktemp("samples")
    rng = np.random.default_rng(38)
    truth = irb1600().with_frames(BASE, TOOL)
    data = simulate_measurements(truth, random_configurations(30, rng), rng, full_pose=False)
    _write_measurements(d / "m.csv", data, full_pose=False)
    save_model(irb1600(), d / "model.json")
    (d / "joints.csv").write_text("q1,q2,q3,q4,q5,q6\n0,10,10,0,30,0\n")
    (d / "targets.csv").write_text("id,x,y,z,rx,ry,rz\na,800,100,900,0,80,0\n")
    (d / "P.mod").write_text("MODULE P\n  CONST robtarget p:=[[900,0,900],[0,0,1,0],[0,0,0,0],"
                             "[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")
    _write_performance(d / "perf.csv", rng, np.array([0.1, 0, 0]), 0.01, cycles=3)
    t = np.linspace(0, 400, 21)
    (d / "line.csv").write_text("x,y,z\n" + "\n".join(
        f"{700 + v:.3f},0,400" for v in t) + "\n")
    with (d / "sweeps.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["joint", "q1", "x", "y", "z"])
        for q in np.linspace(-60, 60, 9):
            a = np.radians(q)
            w.writerow([1, q, 1000 * np.cos(a), 1000 * np.sin(a), 800])
        for a in np.radians(np.linspace(-40, 40, 9)):
            w.writerow([2, 0, 150 + 700 * np.sin(a), 0, 486 + 700 * np.cos(a)])
    return {"m": str(d / "m.csv"), "r": str(d / "model.json"), "j": str(d / "joints.csv"),
            "t": str(d / "targets.csv"), "p": str(d / "P.mod"), "perf": str(d / "perf.csv"),
            "line": str(d / "line.csv"), "s": str(d / "sweeps.csv")}


def bad_path(kind: str, role: str, where: Path) -> str:
    """The path of one bad kind, made in `where`."""
    if kind == "folder":
        (where / "a-folder").mkdir()
        return str(where / "a-folder")
    if kind == "missing":
        return str(where / "no-such-folder" / "x") if role != "input" else str(
            where / "no-such-file.csv")
    if kind == "unwritable":
        return "/proc/x" if role != "input" else "/proc/x/y"
    path = where / "a-file.txt"
    path.write_text("" if kind == "empty" else GARBAGE, encoding="latin-1")
    return str(path)


OURS = ("screwcal.", "service.", "simulators.", "protocol.")


def _load(names: list[str]) -> None:
    """Import here what a fork imported of the project's packages, so that the next fork starts
    with it (each fork loading the same command modules again was most of a refused run's
    CPU); a module that does not import here is left to the forks, which import it as before."""
    for name in names:
        if name not in sys.modules:
            try:
                importlib.import_module(name)
            except Exception:  # the forks still import it, and say what fails
                continue


def run_forked(call: Callable[[], int], cwd: Path, timeout_s: int) -> tuple[int, str]:
    """Run `call` in a fork of this process in `cwd`, stdout and stderr to files; its exit
    status and what it wrote on stderr. An exception that escapes is printed as Python would,
    with status 99; a run still going after `timeout_s` is killed by its own alarm. What the
    run imported of the project is then imported here too (`_load`)."""
    out, err = cwd / "stdout.txt", cwd / "stderr.txt"
    loaded, before = cwd / "modules.txt", set(sys.modules)
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 98
        try:
            os.chdir(cwd)
            for fd, path in ((1, out), (2, err)):
                os.dup2(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC), fd)
            sys.stdout = open(1, "w", closefd=False)  # pytest captures the parent
            sys.stderr = open(2, "w", closefd=False)
            os.setpgid(0, 0)  # what it starts is stopped with it
            signal.signal(signal.SIGALRM, signal.SIG_DFL)
            signal.alarm(timeout_s)
            code = call()
        except SystemExit as done:
            code = done.code if isinstance(done.code, int) else 2
        except BaseException:  # what the user would see: a traceback
            traceback.print_exc()
            code = 99
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            loaded.write_text("\n".join(m for m in sys.modules
                                         if m.startswith(OURS) and m not in before))
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    try:
        os.killpg(pid, signal.SIGKILL)  # anything it left behind
    except ProcessLookupError:
        pass
    code = os.waitstatus_to_exitcode(status)
    if loaded.exists():
        _load(loaded.read_text().split())
    return code, err.read_text(errors="replace") if err.exists() else ""


def _call(slot: Slot, argv: list[str]) -> Callable[[], int]:
    def call() -> int:
        os.environ["SCREWCAL_TOKEN"] = "t"
        os.environ["SCREWCAL_SERVICE"] = "http://127.0.0.1:9"  # nothing listens there
        if slot.entry == "screwcal":
            from screwcal.commands.main import main

            return main(argv)
        import runpy

        sys.argv = [slot.entry, *argv]
        # as `python -m` in a fresh process: a copy an earlier test imported is not reused
        # (runpy warns of it, and the warning is an error here)
        sys.modules.pop(slot.entry, None)
        runpy.run_module(slot.entry, run_name="__main__")
        return 0

    return call


CASES = [pytest.param(slot, kind, id=f"{' '.join(slot.argv)}:{kind}".replace(" ", "_"))
         for slot in SLOTS for kind in KINDS
         if kind not in slot.skip]


@pytest.mark.parametrize(("slot", "kind"), CASES)
def test_no_traceback_where_a_file_goes(tmp_path, samples, slot, kind):
    work = tmp_path / "work"
    work.mkdir()
    path = bad_path(kind, slot.role, tmp_path)
    argv = [word.format(path, o=str(work / "out"), **samples) for word in slot.argv]
    code, err = run_forked(_call(slot, argv), work, timeout_s=30)
    assert "Traceback" not in err, err
    if kind in slot.fine:
        assert code == 0, err
        return
    if kind in slot.findings:
        assert code == 1 and Path(path).name in (work / "stdout.txt").read_text(), err
        return
    assert code == 2, f"exit {code}: {err}"
    lines = [line for line in err.splitlines() if line.strip() and "warning" not in line]
    assert len(lines) == 1, err
    assert Path(path).name in lines[0], err
