"""The phases' names and what they say of a step."""

import pytest

from service.drift import DRIFT_PHASE
from service.phases import (
    SETUP,
    STEP_OF,
    STEPS,
    Action,
    calibration_list,
    correction_step,
    is_correction,
    job_steps,
    list_kind,
)


def test_a_measured_phase_names_its_list():
    steps = job_steps("procedure", rounds=2, warmup=True)
    measured = [s for s in steps if STEP_OF[s].action is Action.MEASURE]
    assert {s: list_kind(s) for s in measured} == {
        "home_before": "perf", "perf_before": "perf", "cal": "cal", "home_after": "perf",
        "perf_after": "perf", "cal_2": "cal", "perf_after_2": "perf"}
    assert [list_kind(s) for s in STEPS["verify"][:1]] == ["perf"]


@pytest.mark.parametrize("kind", sorted(STEPS))
@pytest.mark.parametrize("rounds", [1, 2])
@pytest.mark.parametrize("warmup", [False, True])
def test_every_step_of_every_job_is_typed(kind, rounds, warmup):
    for name in (SETUP, *job_steps(kind, rounds, warmup)):
        step = STEP_OF[name]
        assert step.name == name
        assert (step.list is not None) == (step.action is Action.MEASURE)


def test_a_rounds_steps_are_found_by_what_they_do_not_by_their_spelling():
    assert [calibration_list(r) for r in ("", "_2")] == ["cal", "cal_2"]
    assert [correction_step(r) for r in ("", "_2")] == ["correction", "correction_2"]
    assert [STEP_OF[s].round for s in ("estimation", "estimation_2", "perf_after_2")] == \
        ["", "_2", "_2"]
    assert is_correction("correction_2") and not is_correction("cal")
    assert not is_correction(DRIFT_PHASE) and list_kind(DRIFT_PHASE) == "perf"
