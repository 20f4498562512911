"""`screwcal demo --instrument tracker`: the procedure through the job service, the robot record
naming the emulated laser tracker (a real process, real TCP, emScon TPI) as its instrument: its
lists planned for the beam, its figures, and the instrument, its uncertainty and the air named in
the result."""

import json
import re

import numpy as np
import pytest

from screwcal.calibration.line_of_sight import THREE_SMRS_MM, visible
from screwcal.commands.main import main
from screwcal.errors import ScrewcalError
from screwcal.instrument import TRACKER_STAND_MM
from screwcal.kinematics.robots import irb1600
from service.plans import performance_plan, tracker_calibration_plan
from service.robot_record import TrackerSetup


def test_planned_poses_face_the_tracker():
    model = irb1600()
    tracker = TrackerSetup(host="t", stand_mm=list(TRACKER_STAND_MM))
    plan = tracker_calibration_plan(model, 40, tracker)
    q = np.radians([p.joints_deg for p in plan])
    assert q.shape == (40, 6)
    assert visible(model, q, np.array(TRACKER_STAND_MM)).all()
    # drawn blindly, most poses of the working region would not be seen
    rng = np.random.default_rng(1)
    from screwcal.calibration.posesets import random_configurations

    blind = random_configurations(200, rng)
    assert visible(model, blind, np.array(TRACKER_STAND_MM)).mean() < 0.5
    perf = performance_plan(model, 2, 300.0, tracker=tracker)
    assert len([p for p in perf if p.role in ("approach", "target")]) == 20
    q_perf = np.radians([p.joints_deg for p in perf])
    assert visible(model, q_perf, np.array(TRACKER_STAND_MM)).all()
    three = TrackerSetup(host="t", smrs_mm=[list(p) for p in THREE_SMRS_MM])
    q3 = np.radians([p.joints_deg for p in tracker_calibration_plan(model, 20, three)])
    assert all(visible(model, q3, np.array(TRACKER_STAND_MM), smr_mm=smr).all()
               for smr in THREE_SMRS_MM)
    behind = TrackerSetup(host="t", stand_mm=[-3000.0, 0.0, 900.0])
    with pytest.raises(ScrewcalError, match="does not see"):
        performance_plan(model, 2, 300.0, tracker=behind)


def _demo(tmp_path, capsys, *args: str) -> tuple[dict, str]:
    assert main(["demo", "--instrument", "tracker", "--time-scale", "0", "--out",
                 str(tmp_path), *args]) == 0
    return json.loads((tmp_path / "job.json").read_text()), capsys.readouterr().out


@pytest.mark.slow
def test_the_tracker_procedure_calibrates_the_typical_robot(tmp_path, capsys):
    """One SMR, the typical robot, 80 poses: through the job service as the arm's demo."""
    job, out = _demo(tmp_path, capsys, "--poses", "80", "--cycles", "3", "--realism",
                     "typical")
    perf = job["performance"]
    before = perf["perf_before"]["overall"]["ap_mm_mean"]
    after = perf["perf_after"]["overall"]["ap_mm_mean"]
    assert after <= 0.10 and before > 10 * after, (before, after)
    assert "laser tracker emscon://" in out
    # issue 40's target: the geometric-only route 2x worse (the lost motion taken up: 6.7x;
    # 1.5x when the backlash the floor is made of stayed in both)
    geometric = re.search(r"geometric only \(compliance none, lag none\)\s+([\d.]+) mm", out)
    assert geometric and float(geometric.group(1)) >= 2.0 * after, out
    assert job["correction"]["lost_motion_taken_up_deg"]
    # the floor is a floor: the true robot as warm as it then is, and its true backlash taken
    # up as ours takes up the lost motion (compensating the cold truth and leaving the
    # backlash, it was 0.051 mm, and ours 0.011 mm read "0.22x the floor")
    floor = re.search(r"oracle floor\s+([\d.]+) mm", out)
    assert floor and after >= 0.9 * float(floor.group(1)), out
    assert "the true backlash taken up" in out
    conditions = job["test_conditions"]
    assert conditions["instrument"].startswith("laser tracker emscon://")
    assert "per point as it stated it" in conditions["instrument uncertainty"]
    assert "mbar" in conditions["air (the instrument's weather)"]
    noise = job["estimation"]["noise"]
    assert 0 < noise["along_beam"]["value"] < noise["across_beam"]["value"] < 0.1
    assert "noise along the beam" in out
    assert (tmp_path / "report.html").is_file() and (tmp_path / "result.json").is_file()


@pytest.mark.slow
def test_three_smrs_give_full_poses_with_the_tracker_turned(tmp_path, capsys):
    """Three SMRs, the tracker's frame turned 25 deg (the record says so, roughly: the beam is
    pointed at SMRs 2 and 3 from the first): full poses, every pose measured once."""
    job, _ = _demo(tmp_path, capsys, "--poses", "40", "--cycles", "2", "--realism",
                     "ideal", "--smrs", "3", "--stand-yaw-deg", "25")
    assert job["performance"]["perf_after"]["overall"]["ap_mm_mean"] <= 0.10
    assert job["estimation"]["noise"].get("along_beam") is None  # full poses: the flange's
    assert "3 SMRs" in job["test_conditions"]["instrument"]
