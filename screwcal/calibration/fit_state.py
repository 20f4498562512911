"""The one state an identification's stages pass on, and the loop that runs them.

An identification is a plan: a sequence of stages (`identify.plan`), each a function
`(state, below) -> state` of a `FitState`. The loop (`run`) calls them in order, giving each the
stages before it (`below`): a stage that needs another fit (the poses kept after outlier rounds,
a model with another compliance, the readings corrected for their lag, a narrower prior) builds
the state it starts from and runs `below` on it. Everything one stage tells the next is a field
of the state: no fit starts from an argument passed along beside it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from screwcal.calibration.identify_result import CalibrationResult, Outlier
from screwcal.calibration.identify_settings import IdentifySettings
from screwcal.calibration.measurements import MeasurementSet
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

if TYPE_CHECKING:
    from screwcal.calibration.diagnostics import PoseTest
    from screwcal.calibration.noise_levels import Linearised
    from screwcal.calibration.residual_problem import ResidualProblem
    from screwcal.calibration.single_fit import Selection


@dataclass(frozen=True, eq=False)
class FitState:
    """One fit of an identification, from what it is asked to where it stands.

    Set when the fit is started (`start`, `refit`): the robot, the poses, the settings.
    Where it starts, when not from scratch (the `select` stage reads them):
    - after outlier rounds (`earlier`, `rows`, `rounds_x`, `rounds_theta`): the poses are the
      `rows` of an earlier fit's selection; its start and parameters are kept and the solve
      starts from the rounds' estimate and variance components;
    - nested (`richer`): the fit of the same poses with the joint-2/3 compliance; this fit's
      candidates are its without the compliance, its noise levels start from its levels and
      are found on its linearisation.
    The solve's start (`x_start`, `levels`, `at`: set by `select`), the fit itself
    (`selection`, `problem`, `x`, `result`: set by `select` and `solve`), and what later stages
    found of it (`tested`, `residuals`: the pose tests the outliers were last tested with;
    `diagnosed`)."""

    nominal: SerialModel
    data: MeasurementSet  # the poses fitted (those kept; their readings corrected for a lag)
    settings: IdentifySettings  # this fit's: its compliance is the model fitted, never "auto"
    asked: IdentifySettings  # the identification's as asked (a learned prior's refits)
    given: MeasurementSet  # the measurements the identification was given
    choose_compliance: bool = False  # "auto": the `choose_compliance` stage is to choose it
    found: tuple[Outlier, ...] = ()  # poses rejected before this fit
    earlier: Selection | None = None
    rows: Array | None = None
    rounds_x: Array | None = None
    rounds_theta: Array | None = None  # (3,) variance components
    richer: FitState | None = None
    x_start: Array | None = None  # None: from the selection's start (Gauss-Newton, or DE)
    levels: Array | None = None  # (3,) variance components the noise levels start from
    at: Linearised | None = None  # the linearisation the noise levels are found on
    selection: Selection | None = None
    problem: ResidualProblem | None = None  # the final problem, weighted as solved
    x: Array | None = None  # the estimate
    result: CalibrationResult | None = None
    tested: PoseTest | None = None  # the fit's pose tests at x (after `reject_outliers`)
    residuals: Array | None = None  # (N, k) its unweighted residuals at x, with them
    diagnosed: bool = False  # its result carries its data-quality diagnostics

    def refit(self, data: MeasurementSet, settings: IdentifySettings,
              found: tuple[Outlier, ...], richer: FitState | None = None) -> FitState:
        """A new fit of the same identification: `data` with `settings` (`found`: rejected
        before; `richer`: nested in that fit), from scratch unless nested."""
        return FitState(self.nominal, data, settings, self.asked, self.given, found=found,
                        richer=richer)

    @property
    def fitted(self) -> CalibrationResult:
        """The result of the fit (after `solve`)."""
        if self.result is None:
            raise ValueError("no fit yet: the plan solves before this stage")
        return self.result

    def rejected(self) -> tuple[Outlier, ...]:
        """The poses the fit's result rejected (with those rejected before it)."""
        return tuple(o for o in self.fitted.outliers if o.rejected)

    def with_result(self, **changes: Any) -> FitState:
        """The same fit, its result with `changes` (result fields)."""
        return replace(self, result=replace(self.fitted, **changes))


Plan = tuple["Stage", ...]
Stage = Callable[[FitState, Plan], FitState]


def run(plan: Plan, state: FitState) -> FitState:
    """The stages of `plan` in order, each given the state and the stages before it."""
    for k, stage in enumerate(plan):
        state = stage(state, plan[:k])
    return state
