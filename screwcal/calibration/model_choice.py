"""The joint compliance chosen by the data (`compliance="auto"`): the candidate models in one
table, each with the test that keeps it over the simpler one, and the stage that chooses.

"auto" fits the first compliant candidate (the joint-2/3 compliance, one coefficient per joint
under the mass table's load) and keeps it when a coefficient is beyond `COMPLIANCE_T` standard
errors; else the rigid model is fitted nested in it (its start, its Jacobian's columns, its
noise levels: `single_fit.select`). A kept candidate gives way to the next one in the table
(a coefficient per joint and arm mass: the data correct the table's proportions) when the data
have at least its `min_poses` and its test says so (an F-test on the residual's drop). Where no
compliance can be told (no masses, the frames-only model, the population solver) the rigid
model is fitted and the result says why (`compliance_note`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import fdtrc

from screwcal.calibration.fit_state import FitState, Plan, run
from screwcal.calibration.identify_result import CalibrationResult
from screwcal.calibration.identify_settings import IdentifySettings
from screwcal.kinematics.model import SerialModel

COMPLIANCE_T = 5.0  # |value| / std error above which "auto" keeps a joint compliance
FREE_MIN_POSES = 200  # enough poses to let auto try a compliance per joint and arm mass
FREE_P = 0.001  # ...and keep it when the residual's drop is this unlikely by chance

AUTO = "auto"
RIGID = "none"


@dataclass(frozen=True)
class Candidate:
    """A compliant model "auto" tries: its `compliance`, the poses it needs, and its test
    against the model before it (its p-value or statistic, and whether it keeps it)."""

    compliance: str
    min_poses: int
    test: Callable[[CalibrationResult, CalibrationResult], tuple[bool, str]]


def _t_test(result: CalibrationResult, simpler: CalibrationResult) -> tuple[bool, str]:
    """A coefficient beyond `COMPLIANCE_T` standard errors (of the fit itself: the rigid model
    is nested in it)."""
    t = compliance_t(result)
    shown = ", ".join(f"{n} {v:.1f}" for n, v in t.items()) or "none identifiable"
    if bool(t) and max(t.values()) > COMPLIANCE_T:
        return True, f"chosen (auto): the data support it, |value| / std error: {shown} (> " \
            f"{COMPLIANCE_T:g})"
    return False, f"left out (auto): the data do not support it, |value| / std error: {shown}"


def _f_test(result: CalibrationResult, simpler: CalibrationResult) -> tuple[bool, str]:
    """The residual's drop against the simpler model's, unlikely by chance (`FREE_P`)."""
    p_value = nested_f_test(simpler, result)
    if p_value < FREE_P:
        return True, f"with a coefficient per joint and arm mass (the data correct the mass " \
            f"table's proportions: F-test p = {p_value:.2g} < {FREE_P:g}"
    return False, f"per-mass coefficients add nothing significant (F-test p = {p_value:.2g})"


# The compliant models "auto" tries, in order: each kept over the one before by its test.
CANDIDATES = (
    Candidate("j23", 0, _t_test),
    Candidate("j23-free", FREE_MIN_POSES, _f_test),
)


def not_tried(nominal: SerialModel, settings: IdentifySettings) -> str:
    """Why "auto" does not try a compliance on this model and solver, or ""."""
    if not nominal.all_masses:
        return "not tried: no masses load the joints (a built-in robot's table or a payload)"
    if settings.kind == "frames":
        return "not tried: the frames-only model"
    if settings.solver != "lm":
        return "not tried: the population solver"
    return ""


def first_fitted(nominal: SerialModel, settings: IdentifySettings) -> tuple[IdentifySettings,
                                                                             bool]:
    """The settings of an identification's first fit and whether its compliance is still to be
    chosen: "auto" fits the first candidate (the rigid model where none is tried)."""
    if settings.compliance != AUTO:
        return settings, False
    first = RIGID if not_tried(nominal, settings) else CANDIDATES[0].compliance
    return replace(settings, compliance=first), True


def choose_compliance(state: FitState, below: Plan) -> FitState:
    """Stage: the compliance the data support among `CANDIDATES` ("auto"; a fit of a fixed
    compliance, e.g. a refit once it is chosen, passes as it is). The models tried after the
    first start from the poses it kept: the outliers are searched for once, then confirmed."""
    if not state.choose_compliance:
        return state
    state = replace(state, choose_compliance=False)
    why = not_tried(state.nominal, state.settings)
    if why:
        return state.with_result(compliance_note=why)
    first, *others = CANDIDATES
    kept, note = first.test(state.fitted, state.fitted)
    if not kept:  # the rigid model, nested in the compliant one
        plain = run(below, state.refit(state.data, replace(state.settings, compliance=RIGID),
                                       state.rejected(), richer=state))
        return plain.with_result(compliance_note=note)
    n_poses = len(state.data) + len(state.rejected())
    chosen = state
    for candidate in others:
        if n_poses < candidate.min_poses:
            break
        trial = run(below, state.refit(chosen.data, replace(
            state.settings, compliance=candidate.compliance), chosen.rejected()))
        better, said = candidate.test(trial.fitted, chosen.fitted)
        if better:
            chosen, note = trial, f"{note}; {said}, {n_poses} poses)"
        else:
            note = f"{note}; {said}"
    return chosen.with_result(compliance_note=note)


def compliance_t(result: CalibrationResult) -> dict[str, float]:
    """|value| / std error of each identifiable compliance coefficient of a result."""
    return {p.name: abs(v) / s for p, v, s in zip(result.params, result.values,
                                                   result.std_errors, strict=True)
            if p.kind.is_compliance and s > 0}


def nested_f_test(simple: CalibrationResult, rich: CalibrationResult) -> float:
    """p-value of the richer model's drop in the position residual sum of squares (F-test of
    nested least-squares models, on the poses both kept)."""
    m = 3 * min(len(simple.residuals_after), len(rich.residuals_after))
    rss_a = float(np.sum(simple.residuals_after ** 2))
    rss_b = float(np.sum(rich.residuals_after ** 2))
    extra = max(rich.rank - simple.rank, 1)
    dof = max(m - rich.rank, 1)
    if rss_b <= 0 or rss_a <= rss_b:
        return 1.0
    return float(fdtrc(extra, dof, (rss_a - rss_b) / extra / (rss_b / dof)))
