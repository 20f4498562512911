"""Issue 38: where a new user goes wrong in the first hour: numbers refused at the parser with
the service's own bounds (not after the start-up), one exit status per job outcome across
`job start` and `job watch`, documented; help that opens with what the command does."""

import re
from pathlib import Path

import pytest

from screwcal.commands.main import main
from service.cli import JOB_EXIT_STATUS, STILL_GOING, job_exit_status

SERVICE_MD = Path(__file__).resolve().parents[3] / "docs" / "service.md"


@pytest.mark.parametrize(("argv", "option"), [
    (["demo", "--poses", "3"], "--poses"),
    (["demo", "--cycles", "1"], "--cycles"),
    (["demo", "--time-scale", "-1"], "--time-scale"),
    (["emulator", "irc5", "--time-scale", "-1"], "--time-scale"),
    (["emulator", "irc5", "--speed-deg-s", "0"], "--speed-deg-s"),
    (["emulator", "arm", "--port", "70000"], "--port"),
    (["serve", "--port", "-1"], "--port"),
    (["job", "start", "--robot", "c", "--cycles", "61"], "--cycles"),
    (["job", "start", "--robot", "c", "--poses", "9"], "--poses"),
    (["job", "watch", "0"], "id"),
    (["job", "start", "--robot", "c", "--cube-edge-mm", "0"], "--cube-edge-mm"),
    (["job", "start", "--robot", "c", "--cube-edge-mm", "2500"], "--cube-edge-mm"),
])
def test_numbers_are_refused_at_the_parser_with_their_bounds(capsys, argv, option):
    with pytest.raises(SystemExit) as done:
        main(argv)
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}" in err and "Traceback" not in err, err


def test_job_outcomes_have_one_exit_status_each_and_the_table_says_them():
    assert [job_exit_status(s) for s in ("done", "failed", "waiting", "aborted")] == [0, 1, 3, 4]
    assert job_exit_status("running") == job_exit_status("paused") == STILL_GOING == 5
    rows = dict(re.findall(r"^\| (\d) \| (\w+)", SERVICE_MD.read_text(), re.M))
    said = {"done": "done", "failed": "failed", "waiting": "waiting", "aborted": "aborted"}
    assert {int(k): v for k, v in rows.items() if v in said} == {
        code: state for state, code in JOB_EXIT_STATUS.items()}
    assert rows["5"] == "still" and rows["2"] == "nothing"


def test_calibrate_help_opens_with_what_it_does(capsys):
    with pytest.raises(SystemExit):
        main(["calibrate", "--help"])
    description = capsys.readouterr().out.split("\n\n")[1]
    assert description.startswith("`screwcal calibrate`: identify a robot's errors")
    assert "docstring" not in description and "ALIGN_DOC" not in description


def test_an_unreachable_service_is_named_with_how_to_start_it(capsys, monkeypatch):
    monkeypatch.setenv("SCREWCAL_TOKEN", "t")
    assert main(["job", "--service", "http://127.0.0.1:9", "list"]) == 2
    err = capsys.readouterr().err
    assert "http://127.0.0.1:9" in err and "screwcal serve" in err, err


@pytest.mark.parametrize(("argv", "usage"), [
    (["calibrate", "--robot", "irb1600", "--data", "m.csv", "--out", "r.json", "--nosuch"],
     "usage: screwcal calibrate"),
    (["robot", "export", "x.json", "--format", "urdf", "--out", "y", "--bad"],
     "usage: screwcal robot export"),
])
def test_an_unknown_option_shows_the_commands_usage(capsys, argv, usage):
    with pytest.raises(SystemExit) as done:
        main(argv)
    err = capsys.readouterr().err
    assert done.value.code == 2 and err.startswith(usage) and "unrecognized" in err, err


def test_known_base_frame_on_data_in_another_frame_names_the_frame_option(tmp_path, capsys):
    """It used to fit to a 605 mm residual and blame the read-back lag."""
    import numpy as np

    from screwcal.calibration.posesets import random_configurations
    from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
    from screwcal.kinematics.robots import irb1600
    from screwcal.studies.simulated_measurements import simulate_measurements
    from tests.screwcal.calibration.test_identify import BASE, TOOL
    from tests.screwcal.commands.test_calibrate_cli import _write_measurements

    rng = np.random.default_rng(38)
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    q = random_configurations(30, rng)
    elsewhere = _write_measurements(tmp_path / "arm.csv", simulate_measurements(
        truth.with_frames(BASE, TOOL), q, rng, full_pose=False), full_pose=False)
    in_base = _write_measurements(tmp_path / "base.csv", simulate_measurements(
        truth, q, rng, full_pose=False), full_pose=False)
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(elsewhere), "--base-frame",
                 "known", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "leave out --base-frame known" in err and not out.exists(), err
    assert main(["calibrate", "--robot", "irb1600", "--data", str(in_base), "--base-frame",
                 "known", "--out", str(out)]) == 0


def test_predict_refuses_joints_in_radians_as_calibrate_does(tmp_path, capsys):
    """It used to predict from them with exit 0."""
    joints = tmp_path / "j.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n0.1,0.2,0.3,0,0.5,0\n-0.1,0.3,0.2,0.1,0.6,0\n")
    out = tmp_path / "p.csv"
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--out",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert "--joint-unit rad" in err and not out.exists()
    assert f"{joints}: every joint reading in columns q1, q2, q3, q4, q5, q6" in err, err
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--joint-unit", "rad",
                 "--out", str(out)]) == 0
    degrees = [float(v) for v in out.read_text().splitlines()[1].split(",")[1:4]]
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--out",
                 str(tmp_path / "q.csv")]) == 2
    joints.write_text("q1,q2,q3,q4,q5,q6\n5.73,11.46,17.19,0,28.65,0\n-5.73,17.19,11.46,5.73,"
                      "34.38,0\n")
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--out",
                 str(tmp_path / "d.csv")]) == 0
    again = [float(v) for v in (tmp_path / "d.csv").read_text().splitlines()[1].split(",")[1:4]]
    assert max(abs(a - b) for a, b in zip(degrees, again, strict=True)) < 1.0


def test_compensate_refuses_another_robot_once_and_says_which_branch(tmp_path, capsys):
    """A result of one robot with --robot of another was refused target by target; a pose
    file without configuration did not say which solution it took."""
    from screwcal.kinematics.modelfile import save_model
    from screwcal.kinematics.robots import irb1600

    model = tmp_path / "model.json"
    save_model(irb1600(), model)
    joints = tmp_path / "j.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n0,10,10,0,60,0\n30,20,5,120,50,-10\n")
    targets = tmp_path / "t.csv"
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--out",
                 str(targets)]) == 0
    capsys.readouterr()
    out = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(model), "--robot", "irb1600", "--targets",
                 str(targets), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "nearest the joints of the target before it (the first: nearest home)" in said
    assert "shoulder front, elbow up, wrist" in said and "--rapid" in said, said
    (tmp_path / "result.json").write_text(
        '{"format": "screwcal-calibration", "robot": "irb1600", '
        f'"model": {model.read_text()}}}')
    assert main(["compensate", "--result", str(tmp_path / "result.json"), "--robot", "irb120",
                 "--targets", str(targets), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "calibrated against robot 'irb1600'" in err
    assert "leave out --robot" in err, err


def _targets_of(tmp_path, joints_deg: str) -> Path:
    joints, targets = tmp_path / "j.csv", tmp_path / "t.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n" + joints_deg)
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--out",
                 str(targets)]) == 0
    return targets


def _compensated_deg(path: Path):
    import numpy as np

    return np.array([[float(v) for v in line.split(",")[1:7]]
                     for line in path.read_text().splitlines()[1:]])


def test_targets_without_configuration_keep_the_branch_of_the_target_before(tmp_path, capsys):
    """The issue's case: next to a target with the wrist at q4 20, q6 -150, the target at q4 27,
    q6 -168 deg was solved nearest home, wrist-flipped (q4 -153, q5 -30, q6 12), while the
    command said "largest joint change" of a few degrees. Each target now takes the branch
    nearest the one before it, and the command names the branch and the largest move."""
    import numpy as np

    from screwcal.kinematics.modelfile import save_model
    from screwcal.kinematics.robots import irb1600

    model = tmp_path / "model.json"
    save_model(irb1600(), model)
    asked = np.array([[10, 10, 10, 20, 40, -150], [12, 12, 8, 27, 30, -168],
                      [14, 14, 6, 40, 20, -175]], float)
    targets = _targets_of(tmp_path, "".join(",".join(f"{v:g}" for v in q) + "\n"
                                            for q in asked))
    capsys.readouterr()
    out = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(model), "--robot", "irb1600", "--targets",
                 str(targets), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert _compensated_deg(out) == pytest.approx(asked, abs=1e-3)  # not q4 -153, q6 12
    assert "shoulder front, elbow up, wrist not flipped for 3 targets" in said, said
    assert "largest move between consecutive targets: joint 6 by 18.000 deg (targets 1 -> 2)" \
        in said, said
    assert "branch changed" not in said


def test_a_wrist_passing_through_zero_changes_branch_and_says_why(tmp_path, capsys):
    """Joint 5 from +8 to -8 deg: the joints move on (the flipped branch's label), and the
    command says where the branch changed and why; nearest home would have done the same here,
    but the first target nearest home, then each next to its predecessor."""
    import numpy as np

    from screwcal.kinematics.modelfile import save_model
    from screwcal.kinematics.robots import irb1600

    model = tmp_path / "model.json"
    save_model(irb1600(), model)
    asked = np.array([[10, 10, 10, 30, q5, 0] for q5 in (20, 8, -8, -20)], float)
    targets = _targets_of(tmp_path, "".join(",".join(f"{v:g}" for v in q) + "\n"
                                            for q in asked))
    capsys.readouterr()
    out = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(model), "--targets", str(targets), "--out",
                 str(out)]) == 0
    said = capsys.readouterr().out
    assert _compensated_deg(out) == pytest.approx(asked, abs=1e-3)
    assert ("branch changed at target 3 (line 4): shoulder front, elbow up, wrist not flipped "
            "-> shoulder front, elbow up, wrist flipped: it lies nearer the joints before "
            "(16.0 deg in joint space") in said, said


@pytest.mark.parametrize(("option", "scale", "said"), [
    ("--targets", (1e-3, 1.0), "in columns x, y, z lies within 1.13 mm of the robot's base as "
                               "read (mm), inside the robot"),
    ("--targets", (1 / 25.4, 1.0), "they look like inches; convert them to mm"),
    ("--targets", (1.0, 0.017453292519943295), "every angle in columns rx, ry, rz lies within "
                                               "+-3.2 deg: they look like radians"),
    ("--measuring-targets", (1e-3, 1.0), "every target in columns x, y, z lies within 0.0392 mm "
                                         "of their centre as read (mm): they look like metres"),
])
def test_compensate_refuses_targets_in_other_units(tmp_path, capsys, option, scale, said):
    """Issue 38: compensate's target reader had no units check (metres were solved as mm,
    each target refused as out of reach, or worse); it refuses them as calibrate does, naming
    the file and the columns."""
    from screwcal.kinematics.modelfile import save_model
    from screwcal.kinematics.robots import irb1600

    model = tmp_path / "model.json"
    save_model(irb1600(), model)
    targets = _targets_of(tmp_path, "10,10,10,20,40,-150\n12,12,8,27,30,-168\n"
                                    "14,14,6,40,20,-175\n")
    rows = [line.split(",") for line in targets.read_text().splitlines()]
    other = tmp_path / "other.csv"
    other.write_text(",".join(rows[0]) + "\n" + "".join(
        ",".join([r[0], *(repr(float(v) * scale[0]) for v in r[1:4]),
                  *(repr(float(v) * scale[1]) for v in r[4:7])]) + "\n" for r in rows[1:]))
    capsys.readouterr()
    out = tmp_path / "c.csv"
    assert main(["compensate", "--result", str(model), option, str(other), "--out",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"screwcal compensate: error: {other}: ") and said in err, err
    assert err.count("\n") == 1 and not out.exists()


def test_evaluate_checks_its_units_as_calibrate_does(tmp_path, capsys):
    import csv
    import json

    source = Path(__file__).resolve().parents[3] / "docs" / "examples" / "irb1600" / \
        "performance.csv"
    rows = list(csv.DictReader(source.read_text().splitlines()))
    metres = tmp_path / "m.csv"
    with metres.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (float(v) / 1000.0 if k in ("x", "y", "z", "x_cmd", "y_cmd", "z_cmd")
                            else v) for k, v in r.items()})
    out = tmp_path / "r.json"
    assert main(["evaluate", "--data", str(metres), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--length-unit m" in err and not out.exists()
    assert "(columns x_cmd, y_cmd, z_cmd)" in err, err
    attained = tmp_path / "a.csv"  # the commanded positions in mm, the measured in metres
    with attained.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: (float(v) / 1000.0 if k in ("x", "y", "z") else v)
                        for k, v in r.items()})
    assert main(["evaluate", "--data", str(attained), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{attained}: every attained position (columns x, y, z)" in err, err
    assert main(["evaluate", "--data", str(metres), "--length-unit", "m", "--out", str(out)]) == 0
    in_m = json.loads(out.read_text())["result"]["overall"]["ap_mm_mean"]
    assert main(["evaluate", "--data", str(source), "--out", str(out)]) == 0
    assert in_m == pytest.approx(json.loads(out.read_text())["result"]["overall"]["ap_mm_mean"],
                                 rel=1e-6)


def test_the_demos_report_shows_our_route_beside_geometric_only_and_the_floor(tmp_path):
    """Those figures were on the terminal only; the page's first screen shows them under the
    verdict."""
    from screwcal.commands.demo import routes_on_the_report

    page = tmp_path / "report.html"
    page.write_text("<header></header><section><p class='verdict'><b>It worked.</b></p>"
                    "<table class='summary'></table></section>")
    routes_on_the_report(page, 0.070, 0.354, 0.045)
    html = page.read_text()
    at = html.index("On the same emulated robot")
    assert html.index("It worked") < at < html.index("<table class='summary'>")
    assert "0.354" in html and "5.057" in html and "0.045" in html and "the floor" in html
    assert "backlash, the drift" in html  # what stays in the floor when ours leaves it too
    routes_on_the_report(page, 0.011, 0.084, 0.006, lost_motion_taken_up=True)
    assert "the true backlash taken up as ours takes up the lost motion" in page.read_text()


def test_robot_list_is_a_small_command():
    """It took 3.3 s every run (each robot's reach on a 721 x 721 grid); the whole process now
    costs 0.28-0.34 s of CPU here. CPU time, not wall time: a loaded host stretches the wall."""
    import resource
    import subprocess
    import sys

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([sys.executable, "-m", "screwcal", "robot", "list"],
                          capture_output=True, text=True, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    assert "irb1600" in done.stdout and cpu_s < 0.5, cpu_s


def test_a_jobs_state_is_said_once():
    """Issue 38: 'job 3: aborted aborted by the operator' (the state, then a reason that says it
    again); `job watch` already said it once."""
    from service.result_text import result_table
    from service.schemas import JobResult

    aborted = JobResult(id=3, state="aborted", reason="aborted by the operator", phases={})
    assert result_table(aborted).splitlines()[0] == "job 3: aborted by the operator"
    failed = JobResult(id=4, state="failed", reason="the arm stopped answering", phases={})
    assert result_table(failed).splitlines()[0] == "job 4: failed: the arm stopped answering"
    done = JobResult(id=5, state="done", reason="", phases={})
    assert result_table(done).splitlines()[0] == "job 5: done"
    paused = JobResult(id=6, state="paused", reason="the disk is full", phases={})
    assert result_table(paused).splitlines()[0] == "job 6: paused: the disk is full"


def test_job_watch_says_its_events_in_words():
    """Issue 38: raw progress dumps ('phase: phase=cal, seconds=1.3487892850002936')."""
    from service.operator import event_text

    assert event_text({"kind": "phase", "seq": 4, "time": 1.0, "phase": "cal",
                       "seconds": 1.3487892850002936}) == "done: calibration poses in 1.35 s"
    assert event_text({"kind": "resumed", "seq": 5, "phase": "perf_after"}) == \
        "resumed: performance after (ISO 9283)"
    assert event_text({"kind": "warning", "message": "the fit is poor"}) == \
        "warning: the fit is poor"
    assert event_text({"kind": "corrected", "route": "compensate", "note": "nothing sent"}) == \
        "corrected: route compensate, nothing sent"


def test_one_is_said_in_the_singular(tmp_path, capsys):
    """Issue 38: '1 poses'."""
    from screwcal.tables import counted

    joints = tmp_path / "j.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n10,20,30,0,40,0\n")
    assert main(["predict", "--robot", "irb1600", "--joints", str(joints), "--out",
                 str(tmp_path / "p.csv")]) == 0
    assert "predicted 1 pose with model 'irb1600'" in capsys.readouterr().out
    assert [counted(n, "pose") for n in (0, 1, 2)] == ["0 poses", "1 pose", "2 poses"]
    assert counted(1, "axis", "axes") == "1 axis" and counted(3, "axis", "axes") == "3 axes"


def test_a_cube_that_does_not_fit_names_the_option_that_makes_it_smaller(tmp_path, capsys):
    """Issue 38: `job start` said "try a smaller edge" and had no edge option; it has one now
    (the job's cube_edge_mm), and the sentence names it and testcube's."""
    assert main(["testcube", "--robot", "irb120", "--edge-mm", "1500", "--out",
                 str(tmp_path / "c.csv")]) == 2
    err = capsys.readouterr().err
    assert "try a smaller edge (testcube --edge-mm, job start --cube-edge-mm)" in err, err
    from screwcal.commands.main import build_parser

    args = build_parser().parse_args(["job", "start", "--robot", "c", "--cube-edge-mm", "150"])
    assert args.cube_edge_mm == 150.0


def test_a_step_prompt_gives_the_joints_as_a_person_reads_them():
    """Issue 38: STEP prompts showed 15-digit joints and -0.0."""
    from service.operator import step_prompt

    assert step_prompt("cal", 3, [12.345678901234567, -0.0, -1e-9, 90.0, -45.5, 180.00049],
                       "ZERO next") == ("ZERO next. robot will move to pose 3 of calibration "
                                        "poses (joints 12.346, 0, 0, 90, -45.5, 180 deg): go? "
                                        "[y/N] ")
    assert step_prompt("perf_before", 0, None) == (
        "robot will move to pose 0 of performance before (ISO 9283): go? [y/N] ")
