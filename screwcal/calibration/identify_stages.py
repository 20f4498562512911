"""The stages of an identification after its first fit: the outliers rejected, the readings'
lag corrected (`lag="auto"`), the prior's scales learned on a small set, the data-quality
diagnostics of the fit returned, a compliance below zero held at zero in its model. (The fit
itself: `single_fit.select` and `solve`; the compliance chosen by the data: `model_choice`.)
Each is `(state, below) -> state` over a `fit_state.FitState`; one that needs another fit runs
the stages `below` it on that fit's start.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from screwcal.calibration import empirical_prior
from screwcal.calibration.compliance_floor import held_at_zero
from screwcal.calibration.diagnostics import (
    MAX_OUTLIER_FRACTION,
    DataQuality,
    acquisition_order,
    data_quality,
    pose_tests,
)
from screwcal.calibration.fit_state import FitState, Plan, run
from screwcal.calibration.identify_result import Outlier
from screwcal.calibration.identify_settings import IdentifySettings
from screwcal.calibration.lag import READING_T, correct_lag, moving_terms, reading_increment
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.model_choice import first_fitted
from screwcal.calibration.outlier_rounds import reject_in_rounds
from screwcal.calibration.residual_problem import residual_rows
from screwcal.calibration.single_fit import noise_components
from screwcal.kinematics.model import SerialModel

LAG_ROUNDS = 4  # estimate-correct-refit rounds of lag="auto", while the residual falls


def begin(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings,
          given: MeasurementSet | None = None) -> FitState:
    """The state an identification of `data` with `settings` starts from (`given`: the
    measurements it was given, when `data` are some of them)."""
    first, choose = first_fitted(nominal, settings)
    return FitState(nominal, data, first, settings, data if given is None else given,
                    choose_compliance=choose)


def reject_outliers(state: FitState, below: Plan) -> FitState:
    """Stage: the poses whose residual says they do not belong (data snooping,
    `diagnostics.pose_tests`) rejected, at most `MAX_OUTLIER_FRACTION` of the poses with those
    rejected before (`state.found`). After a fit, rounds on its linearisation find the poses to
    reject (`outlier_rounds`: the clearly worst first, no refit per round), then the poses kept
    are fitted once more (`below`), from the fit's start and parameters and the rounds'
    estimate and noise levels, and that fit's own tests confirm it (a pose still beyond its
    limit starts new rounds). `outliers="keep"`: listed, kept."""
    rejected = list(state.found)
    limit = max(1, int(MAX_OUTLIER_FRACTION * (len(state.data) + len(state.found))))
    while True:
        result, problem, x, current = state.fitted, state.problem, state.x, state.data
        if result.residual_kind == "distance" or not state.settings.statistical \
                or problem is None or x is None:
            return state.with_result(outliers=tuple(rejected))
        e, A = problem.raw(x)
        test = pose_tests(e, A, problem.whiten)
        limit_T = test.threshold()
        if test.statistic.max() <= limit_T or state.settings.outliers == "keep" \
                or len(rejected) >= limit:
            break
        theta, free = noise_components(result.noise)
        rounds = reject_in_rounds(e, A, problem.components(x), theta, free, problem.prior, x,
                                  problem.whiten, limit - len(rejected))
        rejected += [Outlier(current.ids[r.index], current.line_of(r.index), r.residual_mm,
                             r.statistic, r.threshold, rejected=True) for r in rounds.rejected]
        kept_poses = np.setdiff1d(np.arange(len(current)), [r.index for r in rounds.rejected])
        state = run(below, replace(state, data=current.take(kept_poses),
                                   earlier=state.selection, rows=kept_poses,
                                   rounds_x=rounds.x, rounds_theta=rounds.theta, richer=None))
    kept = [Outlier(current.ids[k], current.line_of(int(k)), float(np.linalg.norm(e[k, :3])),
                    float(test.statistic[k]), limit_T, rejected=False)
            for k in np.flatnonzero(test.statistic > limit_T)]
    return replace(state, tested=test, residuals=e).with_result(
        outliers=tuple(rejected + kept))


def correct_readings_lag(state: FitState, below: Plan) -> FitState:
    """Stage (`lag="auto"`): when the diagnostics find joint readings that lag the motion and
    the data know each pose's previous readings, each joint's lag and lost motion (backlash)
    estimated with the fit's parameters (`lag.reading_increment`) and the readings corrected,
    in a few rounds while the residual falls, on the poses the fit kept (its outliers stand;
    the refits test the corrected poses again; its compliance stands); then the terms within
    `lag.READING_T` standard errors of zero left out."""
    state = diagnose(state, below)
    result = state.fitted
    flagged = [] if result.diagnostics is None else result.diagnostics.lag.flagged
    why = "the data do not say which pose came before which" if state.data.q_previous is None \
        else "the readings do not lag the motion" if not flagged \
        else "distance residuals carry no joint's rate" if result.residual_kind == "distance" \
        or state.problem is None or state.x is None else ""
    if why:
        return state.with_result(lag_note="not corrected: " + why)
    kept, found, n = state.data, state.rejected(), state.nominal.n_joints
    terms = moving_terms(kept)
    best, total = state, np.zeros(2 * n)
    for _ in range(LAG_ROUNDS):
        assert best.problem is not None and best.x is not None
        trial_total = total + reading_increment(best.problem, best.x, terms)[0]
        trial = run(below, state.refit(correct_lag(kept, trial_total[:n], trial_total[n:]),
                                       state.settings, found))
        if trial.fitted.residuals_after.mean() >= best.fitted.residuals_after.mean():
            break
        best, total = trial, trial_total
    if best is state:
        return state.with_result(lag_note=f"not corrected: flagged joints {flagged}, but "
                                 "correcting the readings did not lower the residual")
    # the terms the corrected fit supports (beyond READING_T standard errors); the rest are
    # noise: left out, and the readings fitted once more without them
    assert best.problem is not None and best.x is not None
    std = reading_increment(best.problem, best.x, terms)[1]
    terms = terms & (np.abs(total) >= READING_T * std)
    if not terms.any():
        return state.with_result(lag_note=f"not corrected: flagged joints {flagged}, but no "
                                 f"joint's lag or lost motion is beyond {READING_T:g} standard "
                                 "errors")
    if np.any(total[~terms]):
        total = np.where(terms, total, 0.0)
        best = run(below, state.refit(correct_lag(kept, total[:n], total[n:]), state.settings,
                                      found))
    lag, lost = total[:n], total[n:]
    shown = ", ".join(f"J{j + 1} {v:.2e}" for j, v in enumerate(lag) if terms[j]) or "none"
    lost_shown = ", ".join(f"J{j + 1} {np.degrees(v):.4f}" for j, v in enumerate(lost)
                           if terms[n + j]) or "none"
    return best.with_result(reading_lag=lag, reading_lost_motion=lost, lag_note=(
        f"corrected: the readings lagged the motion (flagged joints {flagged}); lag per joint "
        f"(share of the previous move still in the reading): {shown}; lost motion (backlash, "
        f"deg; half of it on the side each joint came from): {lost_shown}; residual mean "
        f"{result.residuals_after.mean():.3f} -> {best.fitted.residuals_after.mean():.3f} mm. "
        "Better: wait for the arm to settle, or calibrate with the commanded joints"))


def learn_prior(state: FitState, below: Plan) -> FitState:
    """Stage (`prior_scale="learned"`): on a small set for the model (`empirical_prior.
    is_small`), the identification repeated (`below`) with the prior's scales learned from the
    data (`empirical_prior`) until they settle. The refits take the poses the first kept (its
    outliers stand); a learned prior under which a pose looks like an outlier is too narrow for
    this robot: the rounds stop at the one before."""
    result, asked = state.fitted, state.asked
    plausible = asked.ranges
    numbers = residual_rows(result.residual_kind) * len(result.residuals_after)
    if plausible is None or not empirical_prior.is_small(numbers, result.rank):
        return state
    first = state.rejected()
    dropped = {o.id for o in first}
    seen = {o.id for o in result.outliers if not o.rejected}  # flagged and kept already
    given = state.given
    kept = given.take(np.array([k for k, i in enumerate(given.ids) if i not in dropped], int))
    prior, rounds, flagged = plausible, 0, 0
    while rounds < empirical_prior.ROUNDS:
        fit = state.fitted
        step = empirical_prior.updated_ranges(fit.params, fit.values, fit.std_errors, prior,
                                              plausible)
        if step.moved <= empirical_prior.SETTLED and rounds:
            break
        trial = run(below, begin(state.nominal, kept, replace(
            asked, prior=step.ranges, outliers="keep"), given))
        flagged = sum(o.id not in seen for o in trial.fitted.outliers)
        if flagged:
            break
        prior, rounds = step.ranges, rounds + 1
        state = trial.with_result(outliers=first + trial.fitted.outliers)
    return state.with_result(prior_note=empirical_prior.describe(prior, plausible, rounds,
                                                                 flagged))


def diagnose(state: FitState, below: Plan) -> FitState:
    """Stage: the data-quality diagnostics of the fit returned (`diagnostics.data_quality`;
    once per fit: a fit diagnosed already passes as it is)."""
    if state.diagnosed:
        return state
    return replace(state, diagnosed=True).with_result(diagnostics=_data_quality(state))


def floor_compliance(state: FitState, below: Plan) -> FitState:
    """Stage: a joint compliance below zero held at 0 in the model, with a warning
    (`compliance_floor`: every command that reads the model refuses one)."""
    return replace(state, result=held_at_zero(state.fitted))


def _data_quality(state: FitState) -> DataQuality | None:
    """The data-quality diagnostics of a fit (None without the statistical pose tests:
    distances, or the thesis's weighting), from the pose tests its outliers were tested with."""
    result, problem, x, current = state.fitted, state.problem, state.x, state.data
    if result.residual_kind == "distance" or not state.settings.statistical \
            or problem is None or x is None:
        return None
    e, test = state.residuals, state.tested
    if e is None or test is None:
        e, A = problem.raw(x)
        test = pose_tests(e, A, problem.whiten)
    estimated = None if result.noise is None or result.noise.position_std_mm is None \
        else result.noise.position_mm
    return data_quality(e, problem.joint_jacobian(x), np.degrees(current.q), test, current.ids,
                        estimated, state.settings.stated_position_mm(),
                        acquisition_order(current.ids, current.lines))
