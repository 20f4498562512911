"""The benchmark scripts report what a sceptic accepts (issue 29): medians with their spread,
the command's defaults, the peer at its own default; run here at tiny sizes."""

import importlib.util
import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def run(script: str, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCH / script), *args], capture_output=True,
                          text=True, timeout=timeout, cwd=BENCH)


def timing():
    spec = importlib.util.spec_from_file_location("bench_timing", BENCH / "timing.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_timing"] = module  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    return module


def test_median_not_the_best_run():
    pauses = iter([0.0, 0.0, 0.04, 0.0, 0.04, 0.04])  # warm-up, then 0, .04, 0, .04, .04
    spread = timing().median_of(5, lambda: time.sleep(next(pauses)))
    assert spread.median >= 0.04 and spread.low < 0.02 and spread.high >= 0.04
    assert spread.runs == 5
    with pytest.raises(ValueError, match="at least 3"):
        timing().median_of(1, lambda: None)


@pytest.mark.slow
def test_jobs_repeats_and_reports_the_spread():
    proc = run("jobs.py", "--robots", "2", "--rounds", "2")  # 6 jobs: a spread of two runs
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 2 and all("2 runs)" in line for line in lines), proc.stdout
    # the cells run in a process of their own: its CPU is reported beside the service's
    assert "CPU/wall service" in lines[1] and ", cells " in lines[1], proc.stdout
    assert run("jobs.py", "--rounds", "0").returncode != 0


def test_jobs_cells_in_the_services_process_on_request():
    proc = run("jobs.py", "--robots", "2", "--rounds", "1", "--cells-in-process")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "(cells included)" in lines[1] and "1 runs)" in lines[1], proc.stdout


def test_the_cells_process_answers_and_ends_with_its_input():
    with subprocess.Popen([sys.executable, str(BENCH / "cells.py")], stdin=subprocess.PIPE,
                          stdout=subprocess.PIPE, text=True, cwd=BENCH) as proc:
        try:
            proc.stdin.write("start 2\n")
            proc.stdin.flush()
            cells = json.loads(proc.stdout.readline())
            assert len(cells) == 2 and all(arm.startswith("socket://") for _, _, arm in cells)
            proc.stdin.write("cpu\nbogus\nstop\n")
            proc.stdin.flush()
            assert float(json.loads(proc.stdout.readline())) > 0
            assert "unknown command 'bogus'" in json.loads(proc.stdout.readline())["error"]
            assert json.loads(proc.stdout.readline()) == "stopped"
            proc.stdin.close()
            assert proc.wait(timeout=30) == 0
        finally:
            if proc.poll() is None:
                proc.kill()


def test_jobs_beside_cpu_bound_processes_reports_each_pair():
    # one round (the repeats are the test above's): a pair of one job alone and one beside
    # the hog, which burns a core while it runs
    proc = run("jobs.py", "--robots", "1", "--rounds", "1", "--hogs", "1")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "beside 1 CPU-bound processes" in lines[2] and "1 runs)" in lines[2], proc.stdout
    assert "beside them / alone, pair by pair" in lines[3] and "CPU/wall" in lines[1]


@pytest.mark.slow
def test_calibration_reports_medians_and_the_commands_defaults():
    proc = run("calibration.py", "--repeat", "3", "--poses", "60", "--no-de")
    assert proc.returncode == 0, proc.stderr
    assert "median (min-max), 3 runs" in proc.stdout
    assert "LM full, 40 poses, as the command" in proc.stdout
    assert "best" not in proc.stdout
    refused = run("calibration.py", "--repeat", "1")
    assert refused.returncode != 0 and "at least 3" in refused.stderr


def test_the_peer_fits_at_scipys_default_and_one_run_says_so(tmp_path):
    pytest.importorskip("pybotics")
    proc = run("process.py", "--runs", "1", "--peer-runs", "1")
    assert proc.returncode == 0, proc.stderr
    assert "one run" in proc.stdout and "(trf)" in proc.stdout, proc.stdout
    assert "median" not in proc.stdout.split("peer check")[1].split("\n", 1)[1].split(
        "import scipy")[0]


def test_the_peer_script_defaults_to_trf(tmp_path):
    pytest.importorskip("pybotics")
    sys.path.insert(0, str(BENCH))
    try:
        from calibration import write_csv  # the benchmarks' own helper
    finally:
        sys.path.remove(str(BENCH))
    import numpy as np

    from screwcal.calibration.posesets import random_configurations
    from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
    from screwcal.kinematics.dh import dh_from_model
    from screwcal.kinematics.robots import irb1600
    from screwcal.studies.simulated_measurements import simulate_measurements

    rng = np.random.default_rng(1)
    data = simulate_measurements(apply_virtual_joints(irb1600(), THESIS_TABLE11),
                                 random_configurations(40, rng), rng)
    write_csv(tmp_path / "m.csv", data)
    mdh = dh_from_model(irb1600(), "mdh")
    (tmp_path / "robot.json").write_text(json.dumps({
        "mdh": [[r.alpha, r.a_mm, r.theta, r.d_mm] for r in mdh.rows],
        "flange": mdh.dh_flange.tolist()}))
    proc = run("peer_calibrate.py", str(tmp_path / "robot.json"), str(tmp_path / "m.csv"),
               str(tmp_path / "out.json"))
    assert proc.returncode == 0, proc.stderr
    out = json.loads((tmp_path / "out.json").read_text())
    assert out["method"] == "trf"
    assert out["mean_error_after_mm"] < out["mean_error_before_mm"]


def test_rapid_filter_reports_the_median_wall_and_cpu_time():
    proc = run("rapid_filter.py", "--targets", "40", "--repeat", "3")
    assert proc.returncode == 0, proc.stderr
    line = proc.stdout.splitlines()[-1]
    assert "40 robtargets, 3 runs: wall" in line and "CPU" in line and "(target 2 s)" in line


def test_interleaved_alternates_and_needs_five_rounds():
    order = []
    spreads = timing().interleaved(5, [lambda: order.append("a"), lambda: order.append("b")])
    assert order == ["a", "b"] * 6  # a warm-up each, then five rounds in turn
    assert [s.runs for s in spreads] == [5, 5]
    with pytest.raises(ValueError, match="at least 5"):
        timing().interleaved(4, [lambda: None])


def test_outliers_names_every_gross_error_and_reports_the_ratio():
    proc = run("outliers.py", "--poses", "300")
    assert proc.returncode == 0, proc.stderr
    assert "5 interleaved rounds" in proc.stdout and "dirty / clean" in proc.stdout
    assert "CPU time: clean" in proc.stdout
    assert "3 of 3 by pose index, 0 clean poses rejected; all named" in proc.stdout, proc.stdout
    assert run("outliers.py", "--rounds", "3").returncode != 0


def test_identify_cost_reports_the_ratio_to_a_solve_of_its_size():
    proc = run("identify_cost.py", "--poses", "100")
    assert proc.returncode == 0, proc.stderr
    assert "identification / lstsq" in proc.stdout and "600 residuals" in proc.stdout
    assert "lstsq (600 x" in proc.stdout and "CPU time (one thread both)" in proc.stdout
    assert run("identify_cost.py", "--rounds", "2").returncode != 0


def test_kinematics_reports_medians_of_interleaved_rounds_and_checks_ik():
    proc = run("kinematics.py", "--rounds", "3", "--poses", "200")
    assert proc.returncode == 0, proc.stderr
    assert "medians of 3 interleaved rounds; every IK result checked first" in proc.stdout
    assert "best" not in proc.stdout
    assert run("kinematics.py", "--rounds", "2").returncode != 0


def test_peers_check_ik_results_and_report_spreads():
    """With or without the peers installed: screwcal's rows, their spreads, the rounds."""
    proc = run("peers.py", "--rounds", "5", "--batch", "20", "--poses", "40", timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "medians of 5 interleaved rounds; every IK result checked first" in proc.stdout
    assert "IK one target, warm" in proc.stdout and "screwcal" in proc.stdout
    assert run("peers.py", "--rounds", "3").returncode != 0  # fewer than 5 rounds per side
