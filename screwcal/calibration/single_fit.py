"""One fit of all the poses given (thesis 2.2.3, Eq. 2.4): the starting frames, the
identifiable parameters (the `select` stage), the solve with the noise levels when they are
estimated, and the result with its statistics (the `solve` stage). Both are stages of an
identification's plan (`fit_state`): they read where the fit starts from the state (from
scratch, after outlier rounds, or nested in a richer fit) and write the fit to it.

Identifiability: the weighted Jacobian of every candidate parameter at the start is factorised
by QR with column pivoting (frames and the model's preferred parameters first); the parameters
outside the numerical rank are held at their starting value and reported with the kept
parameters they cannot be told from. Nothing is "solved" that the data cannot determine.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg

from screwcal.calibration.degenerate import NEAR_AXIS_MM, data_warnings, point_axis_distance_mm
from screwcal.calibration.error_parameters import (
    ErrorModel,
    Param,
    ParamKind,
    candidate_params,
)
from screwcal.calibration.fit_state import FitState, Plan
from screwcal.calibration.identifiability import (
    GRAM_COND,
    Index,
    Residual,
    explain_removed,
    scaled_singular_values,
    select_identifiable,
    structural_rank,
)
from screwcal.calibration.identify_result import CalibrationResult, NoiseEstimate
from screwcal.calibration.identify_settings import (
    IdentifySettings,
    resolved_residual,
    variance_from_levels,
)
from screwcal.calibration.initial_frames import align_frames
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.noise_levels import Linearised, estimate_with_joint_check, fixed_levels
from screwcal.calibration.plausible import held_directions, outside_ranges
from screwcal.calibration.residual_problem import ResidualProblem, pose_errors
from screwcal.calibration.solvers import (
    Solution,
    gauss_newton_step,
    solve_de,
    solve_lm,
    stationary,
)
from screwcal.errors import IdentificationError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

POSE_ROWS = {"pose": 6, "position": 3}  # equations per pose (distances: per pair)
NOT_CONVERGED_HINT = ("; NOT converged: try a simpler model (--error-model thesis or joints), more "
                      "poses spread over the joint ranges, or a starting base frame "
                      "(--base-guess)")


@dataclass(frozen=True)
class Candidates:
    """Every candidate parameter at the start, as the choice of the identifiable ones reads
    them: the start model (the nominal with the starting frames), the parameters, the weighting
    at the start, the weighted residuals r0 and Jacobian J0 of every candidate there, the start
    model's tool poses T0 (N, 4, 4), and the QR triangle of J0's scaled columns
    (`identifiability.select_identifiable`; None: not yet factorised)."""

    start: SerialModel
    params: tuple[Param, ...]
    whiten: Array
    r0: Array
    J0: Array
    T0: Array
    triangle: Array | None = None

    def rows(self, kept: Array, k: int) -> Candidates:
        """The same candidates for the poses `kept` (`k` residual rows per pose); the
        triangle stays the one the choice was made with."""
        N = len(self.T0)
        r0 = self.r0.reshape(N, k)[kept].reshape(-1)
        return replace(self, whiten=self.whiten[kept], r0=r0, T0=self.T0[kept],
                       J0=self.J0.reshape(N, k, -1)[kept].reshape(len(r0), -1))

    def without_compliance(self) -> Candidates:
        """The candidates without the compliance: their columns of J0 and of the triangle."""
        cols = [k for k, p in enumerate(self.params) if not p.kind.is_compliance]
        return replace(self, params=tuple(self.params[k] for k in cols), J0=self.J0[:, cols],
                       triangle=None if self.triangle is None else self.triangle[:, cols])


@dataclass(frozen=True)
class Selection:
    """The candidate parameters at the start (`at`, with the triangle the choice made) and the
    identifiable ones among them."""

    at: Candidates
    errors: ErrorModel  # the kept parameters
    problem: ResidualProblem  # weighted at the start, for the kept parameters
    keep: Array
    rank: int
    removed: tuple[tuple[str, str], ...]  # (name, why)
    combinations: tuple[str, ...]
    degenerate: bool
    notes: tuple[str, ...]  # data warnings

    def rows(self, kept: Array, data: MeasurementSet, residual: Residual) -> Selection:
        """The same start and parameters for the poses `kept` of those selected on (`data`:
        them), e.g. after outliers were left out."""
        at = self.at.rows(kept, self.problem.rows)
        problem = ResidualProblem(self.errors, data, residual, at.whiten, self.problem.ranges)
        notes = data_warnings(at.start, data, residual, len(at.r0), self.rank,
                              [n for n, _ in self.removed])
        return replace(self, at=at, problem=problem, notes=tuple(notes))

    def without_compliance(self, data: MeasurementSet, residual: Residual,
                           settings: IdentifySettings) -> Selection:
        """The selection of the same start and poses (`data`) with the compliance candidates
        left out (the nested model "auto" compares): their columns of J0 and of its triangle,
        chosen again; no frames aligned, no Jacobian built, no tall factorisation."""
        return _choose(self.at.without_compliance(), data, residual, settings)


def select(state: FitState, below: Plan = ()) -> FitState:
    """Stage: the candidate parameters at the start and the identifiable ones among them, with
    where the solve starts: the poses kept after outlier rounds (`state.earlier`), when the
    noise levels are estimated by LM, keep the earlier fit's start and parameters and start
    from the rounds' estimate and levels; a fit nested in a richer one (`state.richer`, this
    fit without the compliance) takes its candidates without the compliance (the same start,
    the same Jacobian columns) and starts its noise levels from the richer fit's, found on
    its linearisation (the solve as from scratch); else from scratch."""
    settings, data = state.settings, state.data
    residual = resolved_residual(settings, data.full_pose)
    x_start = levels = at = None
    if state.earlier is not None and state.rows is not None and settings.solver == "lm" \
            and _estimates_noise(settings, residual):
        chosen = state.earlier.rows(state.rows, data, residual)
        x_start, levels = state.rounds_x, state.rounds_theta
    elif state.richer is not None and settings.compliance == "none":
        chosen = _selection_of(state.richer).without_compliance(data, residual, settings)
        levels, at = _nested_start(state.richer, chosen)
    else:
        chosen = _select(state.nominal, data, residual, settings)
    return replace(state, selection=chosen, x_start=x_start, levels=levels, at=at)


def solve(state: FitState, below: Plan = ()) -> FitState:
    """Stage: the estimate from where `select` put the start, with the noise levels as asked,
    and the result with its statistics."""
    started = time.perf_counter()
    settings, data, chosen = state.settings, state.data, _selection_of(state)
    residual = resolved_residual(settings, data.full_pose)
    solved = _solve(chosen, data, residual, settings, state.x_start, state.levels, state.at)
    solution = solved.solution
    converged, message = solution.converged, solution.message
    if not converged and stationary(solved.problem, solution.x):
        converged, message = True, f"{message}; at a stationary point of the cost (the " \
            "solver's own tolerances were not met, its steps no longer lower the cost)"
    elif not converged:
        message += NOT_CONVERGED_HINT
    solution = Solution(solution.x, converged, message, solution.nfev)
    result = _result(chosen, data, residual, settings, solved.problem, solution, solved.noise,
                     started)
    return replace(state, problem=solved.problem, x=solution.x, result=result, tested=None,
                   residuals=None, diagnosed=False)


def noise_components(noise: NoiseEstimate | None) -> tuple[Array, Index]:
    """The variance components (3,) a fit used and which of them it estimated."""
    if noise is None:  # not statistical: no rounds are asked for
        raise ValueError("outlier rounds need the statistical weighting's noise levels")
    levels = (noise.position_mm, noise.orientation_deg, noise.joint_deg)
    theta = np.nan_to_num(variance_from_levels(levels))
    stds = (noise.position_std_mm, noise.orientation_std_deg, noise.joint_std_deg)
    return theta, np.flatnonzero([s is not None for s in stds])


def _selection_of(state: FitState) -> Selection:
    if state.selection is None:
        raise ValueError("no selection yet: the plan selects before it solves")
    return state.selection


def _nested_start(richer: FitState, chosen: Selection) -> tuple[Array | None,
                                                                 Linearised | None]:
    """The variance components (3,) a nested fit (`chosen`) starts its noise levels from and
    the linearisation they are found on: the richer fit's levels, and its linearisation at its
    estimate for the nested fit's parameters (their columns, the residuals less what the
    left-out compliance columns' values put in them, their values; None when the nested fit
    keeps a parameter the richer fit did not). None, None: the richer fit estimated none."""
    result, problem, x = richer.fitted, richer.problem, richer.x
    if result.residual_kind == "distance" or not richer.settings.statistical \
            or problem is None or x is None:
        return None, None
    theta = noise_components(result.noise)[0]
    columns = {name: k for k, name in enumerate(problem.errors.names)}  # the Jacobian's own
    if any(name not in columns for name in chosen.errors.names):
        return theta, None
    cols = [columns[name] for name in chosen.errors.names]
    out = np.setdiff1d(np.arange(len(x)), cols)
    e, A = problem.raw(x)
    return theta, Linearised(x[cols], e - A[..., out] @ x[out], A[..., cols],
                             problem.components(x))


@dataclass(frozen=True)
class Solved:
    """The solve's outcome: the final problem (weighted as solved), the solution (nfev: every
    evaluation) and the noise levels used (None: not statistical)."""

    problem: ResidualProblem
    solution: Solution
    noise: NoiseEstimate | None


def _estimates_noise(settings: IdentifySettings, residual: Residual) -> bool:
    """Whether a noise level is to be estimated that these data measure (positions carry no
    orientation noise)."""
    return settings.statistical and residual != "distance" and any(
        free for k, free in enumerate(settings.noise.free) if residual == "pose" or k != 1)


def _start_model(nominal: SerialModel, data: MeasurementSet, residual: Residual,
                 settings: IdentifySettings) -> SerialModel:
    """The nominal model with the frames aligned to the data, unless they are known."""
    if settings.frames == "known":
        return nominal
    base, tool = align_frames(nominal, data.q, data.positions_mm,
                              data.rotations if residual == "pose" else None,
                              base=settings.base_guess, fit_tool=settings.frames == "unknown")
    return nominal.with_frames(base, tool)


def _select(nominal: SerialModel, data: MeasurementSet, residual: Residual,
            settings: IdentifySettings) -> Selection:
    """The candidates at the starting frames and the identifiable ones among them; refuses
    data with fewer equations than the model's identifiable parameters."""
    start = _start_model(nominal, data, residual, settings)
    frames, kind = settings.frames, settings.kind
    unknown = frames == "unknown"
    cands = candidate_params(start, kind, base=frames != "known" and residual != "distance",
                             tool_rotation=unknown and residual == "pose",
                             tool_position=unknown, link_offsets=settings.link_offsets,
                             compliance=settings.compliance)
    errors_all = ErrorModel(start, tuple(cands))
    problem_all = ResidualProblem.weighted_at(errors_all, data, residual, settings)
    r0, J0 = problem_all.weighted(np.zeros(len(cands)))
    T0 = problem_all.linearisation(np.zeros(len(cands)))[0]
    return _choose(Candidates(start, tuple(cands), problem_all.whiten, r0, J0, T0), data,
                   residual, settings)


def _choose(at: Candidates, data: MeasurementSet, residual: Residual,
            settings: IdentifySettings) -> Selection:
    """The identifiable candidates, from their weighted Jacobian J0 at the start (and the QR
    triangle of its scaled columns, when at hand); refuses data with fewer equations than the
    model's identifiable parameters."""
    kind, start, cands, r0 = settings.kind, at.start, at.params, at.r0
    errors_all = ErrorModel(start, cands)
    # The frames are unknown whatever the robot: take them first, then the model's own
    # parameters (joint and link offsets: what a controller can correct), then axis terms.
    own = (ParamKind.ZERO, ParamKind.LINK)
    priority = np.array([2 if p.group != "robot" else 1 if p.kind in own else 0 for p in cands])
    needed = structural_rank(errors_all, residual)
    m = len(r0)
    if m <= needed:
        per_pose = POSE_ROWS.get(residual)
        more = f" (at least {needed // per_pose + 1} poses)" if per_pose else ""
        raise IdentificationError(f"{len(data)} poses give {m} equations for the {needed} "
                                  f"parameters this model can identify: measure more poses{more}")
    names = [p.name for p in cands]
    keep, rank, norms, combos, Rs = select_identifiable(at.J0, priority, names, at.triangle)
    removed_idx = np.setdiff1d(np.arange(len(cands)), keep)
    removed = explain_removed(Rs, keep, removed_idx, names, norms)
    # Degenerate: the poses separate fewer parameters than well-spread data would, or (for
    # the thesis and joint models) a requested offset cannot be identified at all.
    requested_robot = [k for k, p in enumerate(cands) if p.group == "robot"]
    degenerate = rank < needed or (kind != "full" and any(k in removed_idx
                                                          for k in requested_robot))
    notes = data_warnings(start, data, residual, m, rank, [n for n, _ in removed])
    errors = errors_all.subset([int(k) for k in keep])
    problem = ResidualProblem(errors, data, residual, at.whiten, settings.prior_ranges)
    return Selection(replace(at, triangle=Rs), errors, problem, keep, rank, tuple(removed),
                     tuple(combos), degenerate, tuple(notes))


def _solve(chosen: Selection, data: MeasurementSet, residual: Residual,
           settings: IdentifySettings, x_start: Array | None = None,
           levels: Array | None = None, at: Linearised | None = None) -> Solved:
    """The estimate from the start (`x_start`: from the rounds' estimate; `at`: from a richer
    fit's, its levels found on that fit's linearisation), re-weighted and with the noise
    levels as asked (estimated from the variance components `levels` when given)."""
    problem, statistical, noise = chosen.problem, settings.statistical, settings.noise
    estimate_noise = _estimates_noise(settings, residual)
    reweighted = False
    if x_start is not None:  # (LM, noise estimated: select)
        solution = Solution(x_start, True, "", 0)
    elif at is not None and estimate_noise:  # (LM: select)
        solution = Solution(at.x, True, "", 0)
    elif settings.solver == "lm":
        problem, solution, reweighted = _solve_lm_from_start(chosen, data, residual, settings,
                                                             estimate_noise)
    else:
        solution = solve_de(problem, settings.de_link_bounds_mm, settings.seed,
                            settings.de_polish)
    noise_used = None
    if estimate_noise:
        # Re-weighted at every estimate while the noise levels are found (variance components).
        def solve(pr: ResidualProblem, x_start: Array) -> Solution:
            return solve_lm(pr, x_start, 1e-10)

        fit = estimate_with_joint_check(problem, noise, solution.x, solve, levels, at)
        problem, noise_used = fit.problem, fit.noise
        solution = Solution(fit.solution.x, fit.solution.converged, fit.solution.message,
                            solution.nfev + fit.solution.nfev)
        if not noise_used.converged:
            solution = Solution(solution.x, solution.converged, solution.message
                                + "; noise levels did not settle (see noise)", solution.nfev)
    elif statistical and not reweighted:
        # Re-weight at the estimate and solve again (iteratively re-weighted GLS; one pass is
        # enough, the weights' own error is then second order).
        problem = ResidualProblem.weighted_at(chosen.errors, data, residual, settings,
                                              at=solution.x)
        again = solve_lm(problem, solution.x)
        solution = Solution(again.x, solution.converged and again.converged,
                            f"{solution.message}; re-weighted: {again.message}",
                            solution.nfev + again.nfev)
    if statistical and noise_used is None:
        noise_used = fixed_levels(noise, problem.rows)
    return Solved(problem, solution, noise_used)


def _solve_lm_from_start(chosen: Selection, data: MeasurementSet, residual: Residual,
                         settings: IdentifySettings, estimate_noise: bool
                         ) -> tuple[ResidualProblem, Solution, bool]:
    """The candidate Jacobian at the start gives one Gauss-Newton step for free; with
    statistical weights, take the weights there (the joint noise is very directional: weights
    at the starting model mis-shape it by the size of the errors being identified) and solve
    once. If that step does not lower the cost, solve from the start and re-weight afterwards.
    Returns the problem, the solution and whether it was re-weighted at the step."""
    problem, keep = chosen.problem, chosen.keep
    p = len(keep)
    x_gn = gauss_newton_step(chosen.at.J0[:, keep], chosen.at.r0, problem.prior, np.zeros(p))
    if estimate_noise:  # the noise levels' own loop re-weights and solves from there
        return problem, Solution(x_gn, True, "", 0), True
    if settings.statistical and problem.cost(x_gn) < float(chosen.at.r0 @ chosen.at.r0):
        problem = ResidualProblem.weighted_at(chosen.errors, data, residual, settings, at=x_gn)
        return problem, solve_lm(problem, x_gn), True
    return problem, solve_lm(problem, np.zeros(p), 1e-6 if settings.statistical else 1e-12), \
        False


def _result(chosen: Selection, data: MeasurementSet, residual: Residual,
            settings: IdentifySettings, problem: ResidualProblem, solution: Solution,
            noise: NoiseEstimate | None, started: float) -> CalibrationResult:
    """The calibrated model with its standard errors and correlations, conditioning and
    warnings, from the final problem at the solution."""
    errors, ranges, x = chosen.errors, settings.ranges, solution.x
    r, Jw = problem.weighted(x)
    m, p = len(r), len(chosen.keep)
    chi2 = float(r @ r) / max(m - p, 1)
    gram = Jw.T @ Jw  # the data's information: the statistics below read it, not Jw
    cov = scipy.linalg.pinvh(gram + np.diag(problem.prior ** 2))  # the posterior's
    if settings.weighting == "eq2.4" or (settings.statistical and chi2 > 1.0
                                          and not _estimates_noise(settings, residual)):
        cov = cov * chi2  # the noise was understated: the a-posteriori variance factor
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    corr = cov / np.outer(np.where(std > 0, std, 1), np.where(std > 0, std, 1))
    s = scaled_singular_values(Jw, gram)
    to_if = errors.to_interface
    calibrated = errors.apply(x)
    before = pose_errors(chosen.at.start, data, residual, chosen.at.T0)
    after = pose_errors(calibrated, data, residual, problem.linearisation(x)[0])
    return CalibrationResult(
        model=calibrated, start_model=chosen.at.start, params=errors.params, values=to_if(x),
        std_errors=to_if(std), correlation=corr, removed=chosen.removed,
        unidentifiable_combinations=chosen.combinations, residual_kind=residual,
        weighting=settings.weighting, solver=settings.solver, rank=chosen.rank,
        n_candidates=len(chosen.at.params), condition_number=float(s[0] / s[-1]),
        o1=float(np.prod(s ** (1.0 / p)) / np.sqrt(m)), min_singular_value=float(s[-1]),
        chi2_reduced=chi2, residuals_before=before[0], residuals_after=after[0],
        pose_ids=tuple(str(i) for i in data.ids),
        rotation_before_deg=before[1], rotation_after_deg=after[1],
        degenerate=chosen.degenerate, covariance=cov, noise=noise,
        unabsorbed=unabsorbed(Jw, gram, errors.params, float(s[0] / s[-1])),
        data_warnings=chosen.notes,
        held_by_prior=tuple(held_directions(gram, 1.0 / problem.prior, list(errors.names))
                            if ranges is not None else ()),
        implausible=tuple(outside_ranges(errors.params, to_if(x), to_if(std), ranges)
                          if ranges is not None else ()),
        orientation_unknown=orientation_unknown(residual, calibrated),
        compliance=settings.compliance,
        converged=bool(solution.converged), message=str(solution.message),
        n_evaluations=solution.nfev, seconds=time.perf_counter() - started)


def orientation_unknown(residual: str, model: SerialModel) -> str:
    """Why a model fitted to positions predicts no orientation, or "". Positions of a point
    on (or near) the last joint's axis see neither that axis' tilt nor its zero; a point off
    it sees the tilt, and only the zero stays with the measured point's unknown place on the
    flange (held at nominal: the orientation is then known but for the turn about the last
    axis, as the nominal robot's)."""
    if residual == "pose":
        return ""
    n = model.n_joints
    d = point_axis_distance_mm(model)
    if d >= NEAR_AXIS_MM:
        return ""
    return (f"the measured point is {d:.1f} mm from joint {n}'s axis (under "
            f"{NEAR_AXIS_MM:g} mm) and the data are positions only: they see neither the "
            f"tilt of that axis nor joint {n}'s zero, so the model does not know the "
            "orientation")


def unabsorbed(Jw: Array, gram: Array, params: Sequence[Param], condition: float
               ) -> dict[str, float]:
    """Per compliance parameter, the share of its effect on the measurements that the other
    parameters cannot reproduce: 1 - |projection of its column on theirs|^2 / |column|^2
    (1: nothing of the geometry can imitate it; near 0: the geometry would absorb it). From
    the Gram matrix `gram` = Jw^T Jw: |column|^2 - |projection|^2 = 1 / (gram^-1)_kk (the
    Schur complement), when the scaled columns' `condition` number is under `GRAM_COND`;
    else by least squares of the column on the others."""
    out = {}
    cols = [k for k, p in enumerate(params) if p.kind is ParamKind.COMPLIANCE]
    if cols and condition < GRAM_COND:
        d = np.sqrt(np.diag(gram))
        inverse = scipy.linalg.inv(gram / np.outer(d, d))
        return {params[k].name: float(1.0 / inverse[k, k]) for k in cols}
    for k in cols:
        col = Jw[:, k]
        others = np.delete(Jw, k, axis=1)
        fit = others @ np.linalg.lstsq(others, col, rcond=None)[0]
        out[params[k].name] = float(1.0 - (fit @ fit) / max(col @ col, 1e-300))
    return out
