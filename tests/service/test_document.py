"""The job's result document as typed objects: what was stored comes back key for key (a
section never set stays absent, a value set to null stays null), an older document still reads,
and the performance section is the performance package's own."""

import json

import numpy as np
import pytest

from screwcal.performance.evaluate import PerformanceData, PointData, performance_section
from screwcal.performance.straightness import straightness
from service.analysis import job_warnings
from service.document import JobRecord, PerformanceSection, ResultDocument
from service.errors import ServiceError

ESTIMATION = {
    "parameters": [{"name": "J2z", "unit": "deg", "value": 0.1, "std_error": 0.001}],
    "measuring_frame": {"x": 1.0, "y": 2.0, "z": 3.0, "rx": 0.0, "ry": 0.0, "rz": 90.0,
                        "meaning": "robot base in the measuring system's frame, mm/deg"},
    "removed": [{"name": "J1rz", "reason": "not separable"}],
    "rank": 30, "condition_number": 120.0, "chi2_reduced": 1.02, "converged": True,
    "noise": None, "warnings": [], "residual_before_mm": 2.4, "residual_after_mm": 0.02}
STORED = {
    "estimation": ESTIMATION,
    "calibration": {"format": "screwcal-calibration", "model": {"name": "irb1600"}},
    "base": np.eye(4).tolist(),
    "correction": {"route": "zero", "not_identified": [], "offsets_deg": [0.1] * 6,
                   "zero_command_deg": [-0.1] * 6, "identified": [True] * 6,
                   "procedure": "thesis 4.5", "left_in_robot": [],
                   "predicted_position_error_mm": {"before": 1.0, "after": 0.1,
                                                   "meaning": "mean"},
                   "sent": True},
    "warnings": ["estimation: 2 poses rejected"],
    "a_later_section": {"kept": True},
}


def _section(seed: int) -> dict:
    rng = np.random.default_rng(seed)
    cmd = np.array([800.0, 0.0, 900.0, 0.0, 90.0, 0.0])
    data = PerformanceData("measurements", (PointData(
        "P1", cmd, cmd + rng.normal(0.0, 0.02, (5, 6))),), full_pose=True)
    line = np.column_stack([np.linspace(0, 300, 11), rng.normal(0, 0.01, 11), np.zeros(11)])
    return performance_section(data, straightness(line))


def test_a_stored_document_comes_back_key_for_key():
    doc = ResultDocument.model_validate(json.loads(json.dumps(STORED)))
    assert doc.document() == STORED
    assert doc.estimation is not None and doc.estimation.noise is None
    assert "noise" in doc.document()["estimation"]  # set to null: kept as null
    assert "performance" not in doc.document()  # never set: absent


def test_sections_set_by_assignment_are_stored():
    doc = ResultDocument()
    assert doc.document() == {}
    doc.performance = {"perf_before": PerformanceSection.model_validate(_section(1))}
    doc.warnings = []
    assert set(doc.document()) == {"performance", "warnings"}


def test_the_performance_section_is_the_performance_packages_own():
    section = _section(2)
    typed = PerformanceSection.model_validate(json.loads(json.dumps(section)))
    assert json.loads(json.dumps(typed.document())) == json.loads(json.dumps(section))
    assert typed.points["P1"].ap_mm == pytest.approx(section["points"]["P1"]["ap_mm"])
    assert "deviation_u_mm" in typed.document()["straightness"]


def test_a_document_stored_before_reads_its_straightness():
    older = {"points": {}, "straightness": {"peak_to_valley_mm": 0.05, "along_mm": [0, 1, 2],
                                            "deviation_mm": [0.01, -0.02, 0.01]}}
    typed = PerformanceSection.model_validate(older)
    assert typed.straightness is not None
    assert typed.straightness["deviation_u_mm"] == [0.01, -0.02, 0.01]


def test_the_rounds_are_read_and_written_by_suffix():
    doc = ResultDocument.model_validate(STORED)
    assert doc.correction_of("") is doc.correction and doc.correction_of("_2") is None
    second = doc.with_round("_2", calibration={"model": {}})
    assert second.calibration_of("_2") == {"model": {}} and doc.calibration_2 is None
    assert "calibration_2" in second.document()


def test_the_latest_round_is_the_newest_estimation():
    """One answer to "which round made the newest model" (the drift section's promise and a
    verify job's model both read it)."""
    assert ResultDocument().latest_round() == ""
    first = ResultDocument.model_validate(STORED)
    assert first.latest_round() == ""
    second = first.with_round("_2", estimation=first.estimation, calibration={"model": {}})
    assert second.latest_round() == "_2"
    assert second.calibration_of(second.latest_round()) == {"model": {}}


def test_a_lists_overall_figure_is_read_one_way():
    doc = ResultDocument.model_validate({
        "performance": {"perf_before": {"overall": {"ap_mm_mean": 1, "rp_mm_max": 0.02}},
                        "perf_after": {"points": {}}}})
    assert doc.overall("perf_before", "ap_mm_mean") == 1.0
    assert isinstance(doc.overall("perf_before", "ap_mm_mean"), float)
    assert doc.overall("perf_before", "rp_mm_mean") is None  # a figure not there
    assert doc.overall("perf_after", "ap_mm_mean") is None  # a list without overall figures
    assert doc.overall("perf_verify", "ap_mm_mean") is None  # a list not measured
    assert ResultDocument().overall("perf_before", "ap_mm_mean") is None


def test_warnings_read_the_typed_document():
    doc = ResultDocument.model_validate({
        "estimation": {**ESTIMATION, "chi2_reduced": 12.0},
        "performance": {"perf_before": {"overall": {"ap_mm_mean": 0.3, "rp_mm_mean": 0.02}},
                        "perf_after": {"overall": {"ap_mm_mean": 0.4, "rp_mm_mean": 0.02}}}})
    warnings = job_warnings(doc)
    assert any("poor fit" in w and "12.0" in w for w in warnings)
    assert any("accuracy got worse in perf_after" in w for w in warnings)


def test_a_job_without_a_result_has_an_empty_document():
    job = JobRecord.model_validate({
        "id": 1, "robot_id": 1, "kind": "calibration", "mode": "AUTO", "state": "queued",
        "reason": "", "options": {}, "phases": {"setup": {"started": True}}, "result": None,
        "created": 0.0, "updated": 0.0})
    assert job.result.document() == {}
    assert job.phases["setup"].document() == {"started": True}
    assert job.options.cycles == 30


def test_every_service_error_the_api_raises_has_one_status():
    from service.api.errors import HTTP_STATUS

    def leaves(cls: type) -> set[type]:
        subs = set(cls.__subclasses__())
        return subs | {c for s in subs for c in leaves(s)}

    unmapped = {c.__name__ for c in leaves(ServiceError)
                if not any(issubclass(c, k) for k in HTTP_STATUS)}
    assert unmapped == set()


def test_every_error_model_of_the_command_line_is_a_job_option():
    """One list of error models (issue 27): calibrate's, demo's and job start's choices are the
    service's; the frames model with a ZERO route is refused (it identifies no offset)."""
    from pydantic import ValidationError

    from screwcal.arguments import ERROR_MODELS
    from service.document import JobOptions

    for model in ERROR_MODELS:
        assert JobOptions(model=model).model == model
    with pytest.raises(ValidationError, match="identifies no joint offset"):
        JobOptions(model="frames", correction="zero+compensate")
