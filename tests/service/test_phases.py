"""The phases' names and what they say of a step."""

from service.phases import STEPS, job_steps, list_kind


def test_a_measured_phase_names_its_list():
    steps = job_steps("procedure", rounds=2, warmup=True)
    measured = [s for s in steps if s.startswith(("cal", "perf", "home"))]
    assert {s: list_kind(s) for s in measured} == {
        "home_before": "perf", "perf_before": "perf", "cal": "cal", "home_after": "perf",
        "perf_after": "perf", "cal_2": "cal", "perf_after_2": "perf"}
    assert [list_kind(s) for s in STEPS["verify"][:1]] == ["perf"]
