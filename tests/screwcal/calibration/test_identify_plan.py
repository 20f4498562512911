"""An identification is a plan of stages over one fit state (identify.py, fit_state.py): the
settings say which stages run, one loop runs them, and a stage added to the plan is given the
final state and the stages before it."""

from __future__ import annotations

import numpy as np
import pytest

from screwcal.calibration.fit_state import FitState, Plan, run
from screwcal.calibration.identify import IdentifySettings, identify, plan
from screwcal.calibration.identify_stages import (
    begin,
    correct_readings_lag,
    diagnose,
    floor_compliance,
    learn_prior,
    reject_outliers,
)
from screwcal.calibration.model_choice import choose_compliance
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.single_fit import select, solve
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.robots import irb1600
from screwcal.studies.simulated_measurements import simulate_measurements


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(11)
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    return simulate_measurements(truth, random_configurations(40, rng), rng)


def test_the_settings_say_which_stages_run():
    assert plan(IdentifySettings()) == (select, solve, reject_outliers, learn_prior, diagnose,
                                        floor_compliance)
    assert plan(IdentifySettings(compliance="auto", lag="auto")) == (
        select, solve, reject_outliers, choose_compliance, correct_readings_lag, learn_prior,
        diagnose, floor_compliance)
    # the population solver, the frames-only model, no prior, the plausible scale: no learning
    for settings in (IdentifySettings(solver="de"), IdentifySettings(kind="frames"),
                     IdentifySettings(ranges=None), IdentifySettings(prior_scale="plausible")):
        assert learn_prior not in plan(settings)


def test_settings_and_keyword_options_are_one_identification(data):
    by_options = identify(irb1600(), data, kind="thesis", compliance="auto")
    by_settings = identify(irb1600(), data, IdentifySettings(kind="thesis", compliance="auto"))
    assert np.array_equal(by_options.values, by_settings.values)
    assert by_options.compliance_note == by_settings.compliance_note
    with pytest.raises(TypeError, match="not both"):
        identify(irb1600(), data, IdentifySettings(), kind="thesis")


def test_a_stage_added_after_the_plan_gets_the_final_state_and_the_stages_before(data):
    """How a stage after the identification (e.g. a residual model) is added: one more entry
    in the plan; it sees the result, the poses kept and the data given, and may run the stages
    below it again on another state."""
    settings = IdentifySettings(kind="thesis")
    seen: list[tuple[FitState, Plan]] = []

    def after(state: FitState, below: Plan) -> FitState:
        seen.append((state, below))
        return state.with_result(prior_note="seen by the stage after")

    final = run((*plan(settings), after), begin(irb1600(), data, settings))
    (state, below), = seen
    assert below == plan(settings)
    assert state.fitted.diagnostics and state.given is data and len(state.data) == len(data)
    assert final.fitted.prior_note == "seen by the stage after"
    plain = identify(irb1600(), data, settings)
    assert np.array_equal(final.fitted.values, plain.values)


def test_a_stage_leaves_the_state_it_was_given(data):
    settings = IdentifySettings(kind="thesis")
    start = begin(irb1600(), data, settings)
    fitted = run((select, solve), start)
    assert start.result is None and start.selection is None
    assert fitted.result is not None and fitted.problem is not None
    again = reject_outliers(fitted, (select, solve))
    assert fitted.result.outliers == () and again.result is not None
