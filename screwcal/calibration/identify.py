"""Parameter identification (thesis 2.2.3, Eq. 2.4): Levenberg-Marquardt and Differential
Evolution on an error model, with an honest account of what the data can tell.

`identify(...)` is what users call. Its parts, each in its own module:

- `identify_settings`: the options as one frozen `IdentifySettings`, the `NoiseModel`;
- `residual_problem`: the residuals and their Jacobian, the weighting (statistical or the
  thesis's Eq. 2.4), the prior's rows;
- `noise_levels`: the noise levels estimated with the parameters (variance components);
- `solvers`: LM, and DE within the thesis's bounds;
- `single_fit`: one fit of all the poses given (starting frames, identifiable parameters,
  solve, statistics);
- `identify_result`: `CalibrationResult`, `NoiseEstimate`, `Outlier`.

This module orchestrates them: the outliers rejected and the fit repeated, the joint compliance
chosen by the data (`compliance="auto"`), the readings' lag estimated and corrected
(`lag="auto"`). It leaves the process as it finds it: the BLAS threads, the C heap's thresholds
and the garbage collector are the program's to set, at its door (`screwcal.runtime.policy`: a
program that identifies often in one thread calls `runtime.policy.for_worker()` once).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Literal

import numpy as np
from scipy.special import fdtrc

from screwcal.calibration import empirical_prior
from screwcal.calibration.compliance_floor import held_at_zero
from screwcal.calibration.diagnostics import (
    MAX_OUTLIER_FRACTION,
    acquisition_order,
    data_quality,
    pose_tests,
)
from screwcal.calibration.error_parameters import ModelKind
from screwcal.calibration.identifiability import Index, Residual
from screwcal.calibration.identify_result import CalibrationResult, NoiseEstimate, Outlier
from screwcal.calibration.identify_settings import (
    DEFAULT_RANGES,
    Frames,
    IdentifySettings,
    NoiseModel,
    Outliers,
    Solver,
    variance_from_levels,
)
from screwcal.calibration.lag import correct_lag, lag_increment
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.outlier_rounds import reject_in_rounds
from screwcal.calibration.plausible import PlausibleRanges
from screwcal.calibration.residual_problem import residual_rows
from screwcal.calibration.single_fit import RicherFit, WarmStart, fit_once
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

__all__ = ["CalibrationResult", "Frames", "IdentifySettings", "NoiseEstimate", "NoiseModel",
           "Outlier", "PriorScale", "identify"]

PriorScale = Literal["learned", "plausible"]  # the prior's scale on small sets

LAG_ROUNDS = 4  # estimate-correct-refit rounds of lag="auto", while the residual falls
COMPLIANCE_T = 5.0  # |value| / std error above which "auto" keeps a joint compliance
FREE_MIN_POSES = 200  # enough poses to let auto try a compliance per joint and arm mass
FREE_P = 0.001  # ...and keep it when the residual's drop is this unlikely by chance


def identify(nominal: SerialModel, data: MeasurementSet, *, kind: ModelKind = "full",
             residual: Residual | None = None, frames: Frames = "unknown",
             solver: Solver = "lm", weighting: str = "statistical",
             weight_mm: float = 1.0, noise: NoiseModel | None = None,
             de_link_bounds_mm: tuple[float, float] = (0.0, 1.0), seed: int = 0,
             base_guess: Array | None = None,
             link_offsets: Sequence[str] | None = None,
             outliers: Outliers = "reject",
             de_polish: bool = True, compliance: str = "none",
             lag: Literal["none", "auto"] = "none",
             plausible: PlausibleRanges | None = DEFAULT_RANGES,
             prior_scale: PriorScale = "learned") -> CalibrationResult:
    """Identify the error model `kind` of `nominal` from measured data. With unknown frames,
    `base_guess` (e.g. from `base_alignment.base_from_sweeps`) starts the base there. With
    `solver="de"`, `de_polish=False` returns differential evolution's own best (the thesis's
    DE, for comparison); by default a bounded least-squares polish refines it. `compliance`
    ("none", "j23", "wrist") identifies the joints' compliance under gravity with the geometry
    (`error_parameters.compliance_params`); "auto" fits the joint-2/3 compliance and keeps it when
    the data support it (a coefficient beyond `COMPLIANCE_T` standard errors), else fits
    without; with at least `FREE_MIN_POSES` poses it then tries a coefficient per joint and
    arm mass ("j23-free": the data correct the mass table's proportions) and keeps it when an
    F-test on the residual says so (p < `FREE_P`); the result says which and why
    (`compliance_note`). `lag="auto"`: when the diagnostics find joint readings that lag the
    motion and the data know each pose's previous readings, the lag per joint is estimated
    from the residuals and the readings corrected, in a few rounds while the residual falls
    (`reading_lag`, `lag_note`; `screwcal.calibration.lag`).

    Poses whose residual says they do not belong (data snooping, `diagnostics.pose_tests`) are
    rejected, the worst first, and the fit repeated (`outliers="keep"`: listed, kept); at most
    a tenth of the poses. The result lists them and the data-quality
    diagnostics.

    `plausible`: every parameter carries a weak zero-mean prior scaled by its plausible range
    (`screwcal.calibration.plausible`): among models that fit equally, the one nearest nominal;
    the result names the directions the prior decided (`held_by_prior`) and warns of any
    parameter beyond its range. None: plain least squares. `prior_scale="learned"`: on a small
    set for the model (`empirical_prior.is_small`) the prior's scale per group of parameters is
    then learned from the data (empirical Bayes, a few refits; `prior_note` says the scales),
    within the plausible ranges; "plausible": the plausible ranges' scale only."""
    settings = IdentifySettings(
        kind=kind, residual=residual, frames=frames, solver=solver, weighting=weighting,
        weight_mm=weight_mm, noise=noise or NoiseModel(), de_link_bounds_mm=de_link_bounds_mm,
        seed=seed, base_guess=base_guess, link_offsets=link_offsets, outliers=outliers,
        de_polish=de_polish, compliance=compliance, ranges=plausible)
    if prior_scale == "plausible":
        return held_at_zero(_with_lag(nominal, data, settings, lag))
    # a compliance below zero: held at 0 in the model (every reader refuses it)
    return held_at_zero(_with_learned_prior(nominal, data, settings, lag))


def _with_learned_prior(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings,
                        lag: Literal["none", "auto"]) -> CalibrationResult:
    """One identification (`_with_lag`); on a small set for the model, repeated with the
    prior's scales learned from the data (`empirical_prior`) until they settle. The refits
    take the poses the first kept (its outliers stand); a learned prior under which a pose
    looks like an outlier is too narrow for this robot: the rounds stop at the one before."""
    started = time.perf_counter()
    result = _with_lag(nominal, data, settings, lag)
    plausible = settings.ranges
    numbers = residual_rows(result.residual_kind) * len(result.residuals_after)
    if plausible is None or settings.solver != "lm" or settings.kind == "frames" or \
            not empirical_prior.is_small(numbers, result.rank):
        return result
    first = _rejected(result)
    dropped = {o.id for o in first}
    seen = {o.id for o in result.outliers if not o.rejected}  # flagged and kept already
    kept = data.take(np.array([k for k, i in enumerate(data.ids) if i not in dropped], int))
    prior, rounds, flagged = plausible, 0, 0
    while rounds < empirical_prior.ROUNDS:
        step = empirical_prior.updated_ranges(result.params, result.values, result.std_errors,
                                              prior, plausible)
        if step.moved <= empirical_prior.SETTLED and rounds:
            break
        trial = _with_lag(nominal, kept, replace(settings, prior=step.ranges, outliers="keep"),
                          lag)
        flagged = sum(o.id not in seen for o in trial.outliers)
        if flagged:
            break
        prior, rounds = step.ranges, rounds + 1
        result = replace(trial, outliers=first + trial.outliers)
    return replace(result, seconds=time.perf_counter() - started,
                   prior_note=empirical_prior.describe(prior, plausible, rounds, flagged))


def _with_lag(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings,
              lag: Literal["none", "auto"]) -> CalibrationResult:
    """One identification, then (`lag="auto"`) the readings' lag estimated and corrected, on the
    poses the first identification kept (its outliers are not searched for again)."""
    result, kept = _with_compliance(nominal, data, settings)
    if lag == "none":
        return result
    flagged = [d["joint"] for d in result.diagnostics.get("lag", {}).get("per_joint", [])
               if d["flagged"]]
    if data.q_previous is None or not flagged:
        return replace(result, lag_note="not corrected: " + (
            "the data do not say which pose came before which" if data.q_previous is None
            else "the readings do not lag the motion"))
    if settings.compliance == "auto":
        settings = replace(settings, compliance=result.compliance)
    best, lam = result, np.zeros(nominal.n_joints)
    for _ in range(LAG_ROUNDS):
        trial_lag = lam + lag_increment(best.model, correct_lag(kept, lam))
        trial, _ = _with_compliance(nominal, correct_lag(kept, trial_lag), settings,
                                    _rejected(result))
        if trial.residuals_after.mean() >= best.residuals_after.mean():
            break
        best, lam = trial, trial_lag
    shown = ", ".join(f"J{j + 1} {v:.2e}" for j, v in enumerate(lam))
    return replace(best, reading_lag=lam, lag_note=(
        f"corrected: the readings lagged the motion (flagged joints {flagged}); lag per joint "
        f"(share of the previous move still in the reading): {shown}; residual mean "
        f"{result.residuals_after.mean():.3f} -> {best.residuals_after.mean():.3f} mm. Better: "
        "wait for the arm to settle, or calibrate with the commanded joints"))


def _rejected(result: CalibrationResult) -> tuple[Outlier, ...]:
    return tuple(o for o in result.outliers if o.rejected)


def _compliance_not_tried(nominal: SerialModel, settings: IdentifySettings) -> str:
    """Why "auto" does not try a compliance on this model and solver, or ""."""
    if not nominal.all_masses:
        return "not tried: no masses load the joints (a built-in robot's table or a payload)"
    if settings.kind == "frames":
        return "not tried: the frames-only model"
    if settings.solver != "lm":
        return "not tried: the population solver"
    return ""


Fit = tuple[CalibrationResult, MeasurementSet]  # a result and the poses it kept


def _with_compliance(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings,
                     found: tuple[Outlier, ...] = ()) -> Fit:
    """One identification with the settings' compliance ("auto": chosen by the data), of the
    poses `data` (`found`: rejected before). The models "auto" compares after the first fit
    start from the poses it kept: the outliers are searched for once, then only confirmed."""
    if settings.compliance != "auto":
        result, kept, _ = _identify_rejecting(nominal, data, settings, found)
        return replace(result, compliance=settings.compliance), kept
    why, richer = _compliance_not_tried(nominal, settings), None
    if not why:
        bent, kept, richer = _identify_rejecting(nominal, data,
                                                 replace(settings, compliance="j23"), found,
                                                 diagnose=_compliance_supported)
        bent = replace(bent, compliance="j23")
        t = _compliance_t(bent)
        shown = ", ".join(f"{n} {v:.1f}" for n, v in t.items()) or "none identifiable"
        if _compliance_supported(bent):
            return _bent_or_free(nominal, kept, settings, bent, note=(
                f"chosen (auto): the data support it, |value| / std error: {shown} (> "
                f"{COMPLIANCE_T:g})"), n_poses=len(data) + len(found))
        why = f"left out (auto): the data do not support it, |value| / std error: {shown}"
        data, found = kept, _rejected(bent)
    plain, kept, _ = _identify_rejecting(nominal, data, replace(settings, compliance="none"),
                                         found, richer)
    return replace(plain, compliance="none", compliance_note=why), kept


def _compliance_t(result: CalibrationResult) -> dict[str, float]:
    """|value| / std error of each identifiable compliance coefficient of a result."""
    return {p.name: abs(v) / s for p, v, s in zip(result.params, result.values,
                                                   result.std_errors, strict=True)
            if p.kind.startswith("compliance") and s > 0}


def _compliance_supported(result: CalibrationResult) -> bool:
    """Whether "auto" keeps the compliance of this fit: a coefficient beyond `COMPLIANCE_T`
    standard errors."""
    t = _compliance_t(result)
    return bool(t) and max(t.values()) > COMPLIANCE_T


def _bent_or_free(nominal: SerialModel, kept: MeasurementSet, settings: IdentifySettings,
                  bent: CalibrationResult, note: str, n_poses: int) -> Fit:
    """The joint-2/3 compliance the data support; with enough poses (`n_poses` given, `kept`
    those the bent fit kept), a coefficient per joint and arm mass instead when an F-test says
    it pays."""
    if n_poses < FREE_MIN_POSES:
        return replace(bent, compliance="j23", compliance_note=note), kept
    free, free_kept = _with_compliance(nominal, kept, replace(settings, compliance="j23-free"),
                                       _rejected(bent))
    p_value = _nested_f_test(bent, free)
    if p_value < FREE_P:
        return replace(free, compliance="j23-free", compliance_note=(
            f"{note}; with a coefficient per joint and arm mass (the data correct the "
            f"mass table's proportions: F-test p = {p_value:.2g} < {FREE_P:g}, "
            f"{n_poses} poses)")), free_kept
    return replace(bent, compliance="j23", compliance_note=(
        f"{note}; per-mass coefficients add nothing significant (F-test p = "
        f"{p_value:.2g})")), kept


def _nested_f_test(simple: CalibrationResult, rich: CalibrationResult) -> float:
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


def _identify_rejecting(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings,
                        found: tuple[Outlier, ...] = (), richer: RicherFit | None = None,
                        diagnose: Callable[[CalibrationResult], bool] | None = None
                        ) -> tuple[CalibrationResult, MeasurementSet, RicherFit]:
    """One identification (see `identify`) of the poses `data` (`found`: rejected before),
    rejecting outliers: after a fit, rounds on its linearisation find the poses to reject
    (`outlier_rounds`: the clearly worst first, no refit per round), then the poses kept are
    fitted once more, from the first fit's start and parameters and the rounds' estimate and
    noise levels (`single_fit.WarmStart`), and that fit's own tests confirm it (a pose still
    beyond its limit starts new rounds). `richer`: the fit of the model with the joint-2/3
    compliance on these poses (`single_fit.fit_once`). `diagnose`: whether the result is to
    carry the data-quality diagnostics (default: always; a fit "auto" is about to set aside
    goes without). Also returns the poses kept and the last fit, for a nested one."""
    started = time.perf_counter()
    rejected = list(found)
    current = data
    limit = max(1, int(MAX_OUTLIER_FRACTION * (len(data) + len(found))))
    warm = None
    while True:
        fit = fit_once(nominal, current, settings, warm, richer)
        result, problem, x, richer = fit.result, fit.problem, fit.x, None  # (its poses only)
        if result.residual_kind == "distance" or not settings.statistical:
            return replace(result, outliers=tuple(rejected),
                           seconds=time.perf_counter() - started), current, \
                RicherFit(fit.selection, None)
        e, A = problem.raw(x)
        test = pose_tests(e, A, problem.whiten)
        limit_T = test.threshold()
        if test.statistic.max() <= limit_T or settings.outliers == "keep" \
                or len(rejected) >= limit:
            break
        theta, free = _levels(result.noise)
        rounds = reject_in_rounds(e, A, problem.components(x), theta, free, problem.prior, x,
                                  problem.whiten, limit - len(rejected))
        rejected += [Outlier(current.ids[r.index], current.line_of(r.index), r.residual_mm,
                             r.statistic, r.threshold, rejected=True) for r in rounds.rejected]
        kept_poses = np.setdiff1d(np.arange(len(current)), [r.index for r in rounds.rejected])
        warm = WarmStart(fit.selection, kept_poses, rounds.x, rounds.theta)
        current = current.take(kept_poses)
    kept = [Outlier(current.ids[k], current.line_of(int(k)), float(np.linalg.norm(e[k, :3])),
                    float(test.statistic[k]), limit_T, rejected=False)
            for k in np.flatnonzero(test.statistic > limit_T)]
    estimated = None if result.noise is None or result.noise.position_std_mm is None \
        else result.noise.position_mm
    quality = {} if diagnose is not None and not diagnose(result) else data_quality(
        e, problem.joint_jacobian(x), np.degrees(current.q), test, current.ids, estimated,
        settings.stated_position_mm(), acquisition_order(current.ids, current.lines))
    return replace(result, outliers=tuple(rejected + kept), diagnostics=quality,
                   seconds=time.perf_counter() - started), current, \
        RicherFit(fit.selection, _levels(result.noise)[0], problem, x)


def _levels(noise: NoiseEstimate | None) -> tuple[Array, Index]:
    """The variance components (3,) a fit used and which of them it estimated."""
    if noise is None:  # not statistical: no rounds are asked for
        raise ValueError("outlier rounds need the statistical weighting's noise levels")
    levels = (noise.position_mm, noise.orientation_deg, noise.joint_deg)
    theta = np.nan_to_num(variance_from_levels(levels))
    stds = (noise.position_std_mm, noise.orientation_std_deg, noise.joint_std_deg)
    return theta, np.flatnonzero([s is not None for s in stds])
