"""`screwcal compensate --program` as a user runs it: each language's files in, the compensated
files out, the exit status saying whether every target was compensated."""

import subprocess
import sys

import numpy as np
import pytest

from screwcal.kinematics.modelfile import save_model
from tests.screwcal.calibration.program_cells import true_robot
from tests.screwcal.calibration.test_program_filter_fanuc import FRAMES, fanuc_cell
from tests.screwcal.calibration.test_program_filter_krl import CONFIG, krl_cell
from tests.screwcal.calibration.test_program_filter_urscript import ur_cell


def _run(*args):
    return subprocess.run([sys.executable, "-m", "screwcal", "compensate", *map(str, args)],
                          capture_output=True, text=True)


def _cell(tmp_path, rng, cell):
    nominal, files, q = cell(rng)
    model = tmp_path / "model.json"
    save_model(true_robot(nominal, rng), model)
    paths = []
    for name, text in files.items():
        (tmp_path / name).write_text(text)
        paths.append(tmp_path / name)
    return nominal, model, paths, q


def test_a_kuka_program_of_two_files_goes_to_a_folder(tmp_path, rng):
    nominal, model, paths, _ = _cell(tmp_path, rng, krl_cell)
    (tmp_path / "config.dat").write_text(CONFIG)
    run = _run("--result", model, "--robot", nominal.name, "--program", *paths,
               "--config", tmp_path / "config.dat", "--out", tmp_path / "out")
    assert run.returncode == 0, run.stderr + run.stdout
    assert "10 targets compensated" in run.stdout
    for p in paths:
        out = (tmp_path / "out" / p.name).read_text()
        assert out != p.read_text() and out.count("\n") == p.read_text().count("\n")


def test_a_fanuc_program_without_its_frames_says_so_and_writes_nothing(tmp_path, rng):
    nominal, model, (path,), _ = _cell(tmp_path, rng, fanuc_cell)
    run = _run("--result", model, "--robot", nominal.name, "--program", path, "--out",
               tmp_path / "out.ls")
    assert run.returncode == 2, run.stderr
    assert "UF 1 is not in the frames file given (--frames)" in run.stderr
    assert "no target compensated; nothing written" in run.stderr
    assert not (tmp_path / "out.ls").exists()
    (tmp_path / "frames.csv").write_text(FRAMES)
    run = _run("--result", model, "--robot", nominal.name, "--program", path, "--frames",
               tmp_path / "frames.csv", "--out", tmp_path / "out.ls")
    assert run.returncode == 0 and "10 targets compensated" in run.stdout, run.stderr


def test_a_program_with_targets_only_the_run_knows_exits_3(tmp_path, rng):
    nominal, model, (path,), q = _cell(tmp_path, rng, ur_cell)
    path.write_text(path.read_text().replace("end\n", "  movel(pose_add(approach, p[0, 0, "
                                             "0.01, 0, 0, 0]))\nend\n"))
    run = _run("--result", model, "--robot", nominal.name, "--program", path, "--out",
               tmp_path / "out.script", "--start-joints",
               ",".join(f"{v:.4f}" for v in np.degrees(q[0])))
    assert run.returncode == 3, run.stderr + run.stdout
    assert "1 not compensated statically" in run.stdout and ":18: pose_add(" in run.stdout


def test_a_urscript_program_from_its_start_joints(tmp_path, rng):
    nominal, model, (path,), q = _cell(tmp_path, rng, ur_cell)
    start = ",".join(f"{v:.4f}" for v in np.degrees(q[0]))
    run = _run("--result", model, "--robot", nominal.name, "--program", path,
               "--start-joints", start, "--out", tmp_path / "out.script")
    assert run.returncode == 0, run.stderr + run.stdout
    assert "10 targets compensated" in run.stdout and "1 joint targets left" in run.stdout


def test_files_that_are_no_program_are_refused_in_one_sentence(tmp_path, rng):
    nominal, model, _, _ = _cell(tmp_path, rng, ur_cell)
    other = tmp_path / "notes.txt"
    other.write_text("hello\n")
    run = _run("--result", model, "--robot", nominal.name, "--program", other, "--out",
               tmp_path / "o.txt")
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert "not a KRL (.src/.dat), FANUC LS (.ls) or URScript (.script) program" in run.stderr
    run = _run("--result", model, "--robot", nominal.name, "--program", tmp_path, "--out",
               tmp_path / "o.txt")
    assert run.returncode == 2 and "Traceback" not in run.stderr and "folder" in run.stderr


def test_several_rapid_modules_go_to_the_rapid_filter_together(tmp_path):
    """`--program A.mod B.sys` is one task's modules, as `--rapid A.mod B.sys`: a target declared
    in one and moved to in the other is compensated in its tool."""
    from screwcal.kinematics.robots import irb1600

    save_model(irb1600(), tmp_path / "m.json")
    (tmp_path / "Data.sys").write_text(
        "MODULE Data(SYSMODULE)\n  PERS tooldata tGun:=[TRUE,[[0,0,150],[1,0,0,0]],"
        "[1,[0,0,50],[1,0,0,0],0,0,0]];\n  CONST robtarget pA:=[[900,0,900],[0,0,1,0],"
        "[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n")
    (tmp_path / "Main.mod").write_text("MODULE Main\n  PROC main()\n    MoveL pA, v100, fine, "
                                       "tGun;\n  ENDPROC\nENDMODULE\n")
    run = _run("--result", tmp_path / "m.json", "--robot", "irb1600", "--program",
               tmp_path / "Data.sys", tmp_path / "Main.mod", "--out", tmp_path / "out")
    assert run.returncode == 0, run.stderr + run.stdout
    assert (tmp_path / "out" / "Data.sys").is_file() and (tmp_path / "out" / "Main.mod").is_file()


def test_the_collector_rests_while_the_program_is_read_and_filtered(tmp_path, rng, monkeypatch):
    """The program's tree (10,000 targets: some hundred thousand objects, no cycle) is read and
    filtered with the cyclic collector off, as the RAPID filter's is (its passes over the tree
    took ~70 ms of a 2 s run); the collector is back on after, a refused program too."""
    import gc

    from screwcal.calibration import program_filter
    from screwcal.commands.main import build_parser
    from screwcal.errors import DataFileError

    nominal, model, paths, _ = _cell(tmp_path, rng, krl_cell)
    (tmp_path / "config.dat").write_text(CONFIG)
    seen = []
    real = program_filter.filter_program

    def watched(*args, **kwargs):
        seen.append(gc.isenabled())
        return real(*args, **kwargs)

    monkeypatch.setattr(program_filter, "filter_program", watched)
    argv = ["compensate", "--result", str(model), "--robot", nominal.name, "--config",
            str(tmp_path / "config.dat"), "--out", str(tmp_path / "out"), "--program"]
    args = build_parser("compensate").parse_args([*argv, *map(str, paths)])
    assert gc.isenabled() and args.func(args) == 0
    assert seen == [False] and gc.isenabled()
    (tmp_path / "broken.dat").write_text("DEFDAT broken\nDECL E6POS XP1={X 1.0,Y 2.0\n")
    args = build_parser("compensate").parse_args([*argv, str(tmp_path / "broken.dat")])
    with pytest.raises(DataFileError, match=r"broken\.dat: line 2: an aggregate"):
        args.func(args)
    assert gc.isenabled()


def test_a_program_compensated_without_a_residual_model_loads_only_what_it_needs(tmp_path, rng):
    """Every run pays the start-up (a quarter of the 2 s 10,000 targets may take, issue 42): a
    result without a residual model loads neither its module nor the Gaussian process's, a
    program neither the pose files' branch choice nor the RAPID parser, and nothing loads scipy
    or the service."""
    nominal, model, paths, _ = _cell(tmp_path, rng, krl_cell)
    (tmp_path / "config.dat").write_text(CONFIG)
    argv = ["compensate", "--result", str(model), "--robot", nominal.name, "--program",
            *map(str, paths), "--config", str(tmp_path / "config.dat"), "--out", "out"]
    code = ("import sys\nfrom screwcal.commands.main import main\n"
            f"assert main({argv!r}) == 0\nprint(sorted(sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    loaded = set(eval(out.stdout.strip().splitlines()[-1]))
    assert "screwcal.calibration.program_filter" in loaded
    assert not loaded & {"screwcal.calibration.residual_model", "screwcal.calibration.residual_gp",
                         "screwcal.commands.target_branches", "screwcal.rapid", "scipy",
                         "service", "simulators"}
