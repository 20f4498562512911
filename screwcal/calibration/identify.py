"""Parameter identification (thesis 2.2.3, Eq. 2.4): Levenberg-Marquardt and Differential
Evolution on an error model, with an honest account of what the data can tell.

`identify(nominal, data, settings)` is what users call. It builds the plan its settings ask for
(`plan`: a sequence of stages over one `fit_state.FitState`) and runs it (`fit_state.run`):

- `single_fit.select`: the starting frames and the identifiable parameters;
- `single_fit.solve`: LM (or DE) with the noise levels (`noise_levels`) and the statistics;
- `identify_stages.reject_outliers`: the poses that do not belong, rejected (`outlier_rounds`);
- `model_choice.choose_compliance` (`compliance="auto"`): the joint compliance the data
  support, among its table of candidates with their tests;
- `identify_stages.correct_readings_lag` (`lag="auto"`): the readings' lag corrected;
- `identify_stages.learn_prior` (`prior_scale="learned"`): the prior's scales on a small set;
- `identify_stages.diagnose`: the data-quality diagnostics of the fit returned;
- `identify_stages.floor_compliance`: a compliance below zero held at 0 in the model.

A stage is a function `(state, below) -> state`; one that needs another fit (a refit of the
poses kept, another model, corrected readings, a narrower prior) runs the stages before it
(`below`) on that fit's start. Adding a stage is adding its line to `STAGES`, with when the
settings ask for it: e.g. a stage after the identification, `(learn_residual_stage, always)`
at the end, is given the final state (its result, the poses kept, `state.given`).

Other parts, each in its own module: `identify_settings` (the options as one frozen
`IdentifySettings`, the `NoiseModel`), `residual_problem` (the residuals, their Jacobian and
weighting, the prior's rows), `solvers` (LM, and DE within the thesis's bounds),
`identify_result` (`CalibrationResult`, `NoiseEstimate`, `Outlier`).

It leaves the process as it finds it: the BLAS threads, the C heap's thresholds and the garbage
collector are the program's to set, at its door (`screwcal.runtime.policy`: a program that
identifies often in one thread calls `runtime.policy.for_worker()` once).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TypedDict, Unpack

from screwcal.calibration.error_parameters import ModelKind
from screwcal.calibration.fit_state import Plan, Stage, run
from screwcal.calibration.identifiability import Residual
from screwcal.calibration.identify_result import CalibrationResult, NoiseEstimate, Outlier
from screwcal.calibration.identify_settings import (
    Frames,
    IdentifySettings,
    Lag,
    NoiseModel,
    Outliers,
    PriorScale,
    Solver,
)
from screwcal.calibration.identify_stages import (
    begin,
    correct_readings_lag,
    diagnose,
    floor_compliance,
    learn_prior,
    reject_outliers,
)
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.model_choice import AUTO, choose_compliance
from screwcal.calibration.plausible import PlausibleRanges
from screwcal.calibration.single_fit import select, solve
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

__all__ = ["STAGES", "CalibrationResult", "Frames", "IdentifyOptions", "IdentifySettings",
           "NoiseEstimate", "NoiseModel", "Outlier", "PriorScale", "identify", "plan"]


def always(settings: IdentifySettings) -> bool:
    return True


def _learns_prior(settings: IdentifySettings) -> bool:
    return settings.prior_scale == "learned" and settings.ranges is not None \
        and settings.solver == "lm" and settings.kind != "frames"


# The stages an identification runs, in order, each with when its settings ask for it.
STAGES: tuple[tuple[Stage, Callable[[IdentifySettings], bool]], ...] = (
    (select, always),
    (solve, always),
    (reject_outliers, always),
    (choose_compliance, lambda settings: settings.compliance == AUTO),
    (correct_readings_lag, lambda settings: settings.lag == "auto"),
    (learn_prior, _learns_prior),
    (diagnose, always),
    (floor_compliance, always),
)


def plan(settings: IdentifySettings) -> Plan:
    """The stages an identification with `settings` runs, in order."""
    return tuple(stage for stage, asked in STAGES if asked(settings))


class IdentifyOptions(TypedDict, total=False):
    """`identify`'s keyword options: `IdentifySettings`' fields (`plausible`: its `ranges`)."""

    kind: ModelKind
    residual: Residual | None
    frames: Frames
    solver: Solver
    weighting: str
    weight_mm: float
    noise: NoiseModel | None
    de_link_bounds_mm: tuple[float, float]
    seed: int
    base_guess: Array | None
    link_offsets: Sequence[str] | None
    outliers: Outliers
    de_polish: bool
    compliance: str
    lag: Lag
    plausible: PlausibleRanges | None
    prior_scale: PriorScale


def identify(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings | None = None,
             **options: Unpack[IdentifyOptions]) -> CalibrationResult:
    """Identify the error model `kind` of `nominal` from measured data, with `settings` or
    the same as keyword options (`IdentifyOptions`; not both). With unknown frames,
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
    motion and the data know each pose's previous readings, the lag per joint and the lost
    motion (backlash) the same move carries are estimated with the fit's parameters and the
    readings corrected, in a few rounds while the residual falls (`reading_lag`,
    `reading_lost_motion`, `lag_note`; `screwcal.calibration.lag`).

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
    if settings is not None and options:
        raise TypeError("identify: give the settings or keyword options, not both")
    settings = settings if settings is not None else IdentifySettings.of(**options)
    started = time.perf_counter()
    final = run(plan(settings), begin(nominal, data, settings))
    return replace(final.fitted, seconds=time.perf_counter() - started)
