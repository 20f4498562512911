"""The report's words: every parameter symbol an identification can produce is defined, what a
parameter could not be separated from is read from the identification's own sentence, and the
fit's chi2/dof is explained as it was computed. The page as a whole, laid out by a browser:
tests/integration/test_report_browser.py."""

from __future__ import annotations

import numpy as np
import pytest

from screwcal.calibration.error_parameters import candidate_params
from screwcal.calibration.identifiability import explain_removed
from screwcal.kinematics.robots import builtin_model
from service.document import EstimationSummary, RemovedParameter
from service.report.calibration import fit_words
from service.report.symbols import (
    CONSEQUENCES,
    family,
    in_words,
    legend,
    partners,
    taken_up_by,
)


@pytest.mark.parametrize("kind", ["full", "thesis", "joints"])
@pytest.mark.parametrize("compliance", ["none", "j23", "wrist", "j23-free"])
def test_every_parameter_an_identification_can_name_has_its_symbol_defined(kind, compliance):
    names = [p.name for p in candidate_params(builtin_model("irb1600"), kind, base=True,
                                              tool_rotation=True, tool_position=True,
                                              compliance=compliance)]
    undefined = [n for n in names if family(n) is None]
    assert not undefined
    symbols = dict(legend(names))
    assert all(meaning for meaning in symbols.values())
    assert [n for n in names if in_words(n) == n] == []  # each in words too


def test_what_a_parameter_moves_with_is_read_from_the_identifications_sentence():
    """explain_removed writes the combination; the report names its parameters, strongest
    first, and says what took up the effect."""
    names = ["base.rz", "J2", "J1", "J5.dir.u", "J4"]
    rng = np.random.default_rng(3)
    J = rng.normal(size=(30, 5))
    J[:, 2] = 1.02 * J[:, 0] - 0.3 * J[:, 1]  # J1 ~ base.rz and J2
    J[:, 3] = 0.0  # no effect at all
    out = dict(explain_removed(J, np.array([0, 1, 4]), np.array([2, 3]), names,
                               np.linalg.norm(J, axis=0)))
    j1 = RemovedParameter(name="J1", reason=out["J1"])
    assert partners(j1) == ["base.rz", "J2"]
    assert taken_up_by(j1) == "frame"
    dead = RemovedParameter(name="J5.dir.u", reason=out["J5.dir.u"])
    assert partners(dead) == [] and taken_up_by(dead) == "none"
    wrist = RemovedParameter(name="J6", reason="not separable from +1 home.rx (scaled columns)")
    assert taken_up_by(wrist) == "robot" and "near the calibration poses" in CONSEQUENCES[
        "robot"]


def _estimation(noise: dict | None, chi2: float) -> EstimationSummary:
    return EstimationSummary(parameters=[], rank=30, condition_number=92.3, chi2_reduced=chi2,
                             converged=True, noise=noise, residual_before_mm=12.9,
                             residual_after_mm=0.1)


def test_chi2_of_estimated_noise_levels_is_one_by_construction_and_the_report_says_so():
    """With the noise levels estimated from the data chi2/dof is ~1 whatever the fit: the report
    gives the position noise the fit needed instead of 'as large as the noise explains' (which
    it said beside a warning that the residuals needed 5.6 times the instrument's noise)."""
    estimated = {"position": {"value": 0.0729, "unit": "mm", "estimated": True, "std": 0.008,
                              "measured": True}}
    words = fit_words(_estimation(estimated, 0.99))
    assert "by construction" in words and "0.073 mm" in words
    assert "as large as" not in words
    stated = fit_words(_estimation({"position": {"value": 0.013, "estimated": False}}, 0.95))
    assert "as large as the stated measuring noise" in stated
    assert "larger than" in fit_words(_estimation(None, 4.0))


def test_the_first_screen_says_whether_it_worked_in_one_sentence():
    """Issue 38: a verdict before any table: the factor, before and after, and what is left
    beside the robot's repeatability; numbers in fixed notation."""
    from service.document import PerformanceSection, ResultDocument
    from service.report.markup import number
    from service.report.summary import verdict

    def doc(before: float, after: float, rp: float) -> ResultDocument:
        return ResultDocument(performance={
            "perf_before": PerformanceSection(overall={"ap_mm_mean": before, "rp_mm_max": rp}),
            "perf_after": PerformanceSection(overall={"ap_mm_mean": after, "rp_mm_max": rp})})

    phases = ("perf_before", "perf_after")
    good = verdict(doc(53.925, 0.084, 0.05), phases)
    assert good is not None and good.startswith("It worked: the robot is 642x more accurate")
    assert "53.925 mm before and 0.084 mm after" in good and "as good as this robot" in good
    left = verdict(doc(53.925, 0.5, 0.05), phases)
    assert left is not None and "something the model does not hold remains" in left
    poor = verdict(doc(1.0, 0.95, 0.05), phases)
    assert poor is not None and poor.startswith("The calibration did not make the robot")
    assert verdict(doc(1.0, 0.5, 0.05), ("perf_before",)) is None
    assert number(5.54e-05) == "0.000055" and "e-" not in number(1.2e-7)


def test_phase_times_are_named_in_words_and_an_emulated_robots_are_said_scaled():
    """Issue 38: 'cal 1.35' beside the thesis's 60/90 minutes read as a real robot's time."""
    from service.document import JobOptions, JobRecord, PhaseRecord
    from service.report.context import ReportContext
    from service.report.timing import timing_section

    job = JobRecord(id=1, robot_id=1, kind="procedure", mode="AUTO", state="done", reason="",
                    options=JobOptions(), created=0.0, updated=0.0,
                    phases={"cal": PhaseRecord(done=True, seconds=5.54e-05),
                            "estimation": PhaseRecord(done=True, seconds=1.2)})
    emulated = timing_section(ReportContext(job, {"emulation": ["geometric errors only"]}))
    real = timing_section(ReportContext(job, {}))
    assert emulated is not None and real is not None
    assert "calibration poses" in emulated and ">cal<" not in emulated
    assert "faster than real time" in emulated and "faster than real time" not in real
    assert "e-05" not in emulated


def test_the_terminal_counts_what_it_lists_and_says_where_the_rest_is():
    """Issue 38: "identified (32 parameters)" was followed by 22 lines (the joints' only): the
    count and the list now agree, the frames' parameters are counted by frame, and what was held
    at nominal is counted and named."""
    from service.document import EstimatedParameter
    from service.result_text import _estimation_lines

    names = ["base.x", "base.y", "base.rz", "tool.x", "tool.y", "home.z", "J1", "J2",
             "J2.dir.u", "J3c"]
    est = EstimationSummary(
        parameters=[EstimatedParameter(name=n, unit="mm", value=0.1, std_error=0.01)
                    for n in names],
        removed=[RemovedParameter(name="J6", reason="not separable from tool.rz"),
                 RemovedParameter(name="base.z", reason="not separable from J2")],
        rank=10, condition_number=50.0, chi2_reduced=1.0, converged=True,
        residual_before_mm=10.0, residual_after_mm=0.1)
    lines = _estimation_lines(est)
    assert lines[0] == ("  identified (10 parameters, chi2/dof 1.00): the 4 of the joints below; "
                        "the other 3 of the robot base frame, 2 of the tool (the measured point), "
                        "1 of the flange at home are in the result:")
    listed = [line.split()[0] for line in lines[1:] if line.startswith("    J")]
    assert listed == ["J1", "J2", "J2.dir.u", "J3c"]
    assert "    2 held at nominal, not separable from these data (not corrected): J6, base.z" \
        in lines


def test_the_robot_section_speaks_words_with_units():
    """Issue 38: the robot section showed the realism file's keys (compliance_deg_per_knm,
    drift_ppm, warmup_s) and a bullet ending in a colon."""
    import re

    from service.document import JobOptions, JobRecord, ResultDocument
    from service.report.conditions import robot_section
    from service.report.context import ReportContext
    from simulators.realism import PRESETS

    est = EstimationSummary(
        parameters=[], rank=30, condition_number=92.3, chi2_reduced=1.0, converged=True,
        residual_before_mm=12.9, residual_after_mm=0.1,
        compliance={"joints": [{"name": "J2c", "compliance_deg_per_knm": 0.12,
                                "std_error": 0.01}], "note": "", "payload": {
            "kg": 5.0, "cog_mm": [0.0, 0.0, 80.0]}},
        reading_lag={"per_joint": [0.0, 0.0002, 0.0002, 0.0, 0.0, 0.0], "note": ""})
    job = JobRecord(id=1, robot_id=1, kind="procedure", mode="AUTO", state="done", reason="",
                    options=JobOptions(), phases={}, created=0.0, updated=0.0,
                    result=ResultDocument(estimation=est))
    robot = {"name": "cell 1", "emulation": ["geometric errors drawn from seed 1; realism harsh",
                                             *PRESETS["harsh"].describe()]}
    html = robot_section(ReportContext(job, robot))
    assert html is not None
    text = re.sub(r"<[^>]+>", " ", html)
    assert not re.findall(r"\b[a-z0-9]+_[a-z0-9_]+\b", text), text
    assert "warm-up time constant of 1800 s" in text and "J2 0.24 deg/kNm" in text
    assert not re.search(r":\s*</li>", html)


def test_the_rejected_pose_is_ringed_on_the_residual_chart_in_its_place(tmp_path):
    """Issue 38: the pose the fit rejected as an outlier was on no chart (the residuals are of
    the poses fitted, numbered 1..n as if it had never been measured). A calibration of 30
    poses, pose 12 moved 3 mm: the result names the poses fitted, and the chart rings pose 12
    at its residual in the fit that flagged it, between poses 11 and 13, with the table's row
    of the same figure."""
    import json
    import re

    from screwcal.calibration.posesets import random_configurations
    from screwcal.commands.main import main
    from screwcal.kinematics.robots import irb1600
    from screwcal.studies.simulated_measurements import simulate_measurements
    from service.report.calibration import REJECTED, residual_pair
    from tests.screwcal.calibration.test_identify import BASE, TOOL
    from tests.screwcal.commands.test_calibrate_cli import _write_measurements

    rng = np.random.default_rng(12)
    data = simulate_measurements(irb1600().with_frames(BASE, TOOL),
                                 random_configurations(30, rng), rng, full_pose=False)
    data.positions_mm[11] += [3.0, 0.0, 0.0]
    path = _write_measurements(tmp_path / "m.csv", data, full_pose=False)
    with path.open() as f:  # ids 1..30, as a job numbers its poses
        lines = f.read().splitlines()
    path.write_text("\n".join([lines[0], *(re.sub(r"^p(\d+),", lambda m: f"{int(m[1]) + 1},",
                                                  line) for line in lines[1:])]) + "\n")
    out = tmp_path / "r.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(path), "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    rejected = [o for o in doc["outliers"] if o["rejected"]]
    assert [o["id"] for o in rejected] == ["12"], doc["outliers"]
    assert doc["residuals"]["poses"] == [str(k) for k in range(1, 31) if k != 12]
    assert any(w.startswith("1 pose rejected as an outlier: pose 12 (line 13)")
               for w in doc["warnings"]), doc["warnings"]  # not '1 poses'
    est = EstimationSummary(parameters=[], rank=1, condition_number=1.0, chi2_reduced=1.0,
                            converged=True, residual_before_mm=1.0, residual_after_mm=0.1)
    html = residual_pair(doc, est)
    points = re.findall(r"<circle class='point( marked)?' data-series='([^']+)' "
                        r"data-value='([^']+)' cx='([\d.]+)'", html)
    ringed = [(float(v), float(x)) for m, s, v, x in points if s == REJECTED]
    assert [m for m, s, _, _ in points if s == REJECTED] == [" marked"]
    assert ringed[0][0] == pytest.approx(rejected[0]["residual_mm"])
    after = {float(x): float(v) for _, s, v, x in points if s.startswith("after")}
    xs = sorted(after)
    assert len(xs) == 29 and xs[10] < ringed[0][1] < xs[11]  # between poses 11 and 13
    row = re.search(rf"<tr><td[^>]*>{re.escape(REJECTED)}</td>(.*?)</tr>", html).group(1)
    cells = [float(c) for c in re.findall(r">([-\d.]+)<", row)]
    assert cells[-1] == pytest.approx(rejected[0]["residual_mm"], abs=5e-5)
    assert "Rejected as an outlier and left out of the fit: pose 12 (" in html
