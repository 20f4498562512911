"""One fit of all the poses given (thesis 2.2.3, Eq. 2.4): the starting frames, the
identifiable parameters, the solve (with the noise levels when they are estimated), and the
result with its statistics.

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
from screwcal.calibration.error_parameters import ErrorModel, Param, candidate_params
from screwcal.calibration.identifiability import (
    GRAM_COND,
    Residual,
    explain_removed,
    scaled_singular_values,
    select_identifiable,
    structural_rank,
)
from screwcal.calibration.identify_result import CalibrationResult, NoiseEstimate
from screwcal.calibration.identify_settings import IdentifySettings, resolved_residual
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
class Selection:
    """The candidate parameters at the start and the identifiable ones among them."""

    start: SerialModel  # the nominal model with the starting frames
    candidates: tuple[Param, ...]
    errors: ErrorModel  # the kept parameters
    problem: ResidualProblem  # weighted at the start, for the kept parameters
    r0: Array  # weighted residuals at the start
    J0: Array  # weighted Jacobian of every candidate at the start
    T0: Array  # (N, 4, 4) the start model's tool poses
    Rs: Array  # the QR triangle of J0's scaled columns (identifiability.select_identifiable)
    keep: Array
    rank: int
    removed: tuple[tuple[str, str], ...]  # (name, why)
    combinations: tuple[str, ...]
    degenerate: bool
    notes: tuple[str, ...]  # data warnings

    def rows(self, kept: Array, data: MeasurementSet, residual: Residual) -> Selection:
        """The same start and parameters for the poses `kept` of those selected on (`data`:
        them), e.g. after outliers were left out."""
        k = self.problem.rows
        N = len(self.T0)
        problem = ResidualProblem(self.errors, data, residual, self.problem.whiten[kept],
                                  self.problem.ranges)
        r0 = self.r0.reshape(N, k)[kept].reshape(-1)
        notes = data_warnings(self.start, data, residual, len(r0), self.rank,
                              [n for n, _ in self.removed])
        return replace(self, problem=problem, r0=r0,
                       J0=self.J0.reshape(N, k, -1)[kept].reshape(len(r0), -1),
                       T0=self.T0[kept], notes=tuple(notes))


    def without_compliance(self, data: MeasurementSet, residual: Residual,
                           settings: IdentifySettings) -> Selection:
        """The selection of the same start and poses (`data`) with the compliance candidates
        left out (the nested model "auto" compares): their columns of J0 and of its triangle,
        chosen again; no frames aligned, no Jacobian built, no tall factorisation."""
        cols = [k for k, p in enumerate(self.candidates) if not p.kind.startswith("compliance")]
        return _choose(self.start, tuple(self.candidates[k] for k in cols), self.problem.whiten,
                       self.r0, self.J0[:, cols], self.T0, self.Rs[:, cols], data, residual,
                       settings)


@dataclass(frozen=True)
class WarmStart:
    """A fit of most of the poses of an earlier one (after outlier rounds): the earlier fit's
    selection, which of its poses are kept, and the estimate and variance components (3,) the
    rounds found for them."""

    selection: Selection
    kept: Array
    x: Array
    theta: Array


@dataclass(frozen=True)
class RicherFit:
    """A fit of the same poses with the joint-2/3 compliance, for the nested fit without it
    ("auto"): its selection (the nested fit's start and Jacobian columns) and the variance
    components (3,) it found (the nested fit's levels start there; None: none estimated)."""

    selection: Selection
    theta: Array | None
    problem: ResidualProblem | None = None  # its final problem and estimate: the nested
    x: Array | None = None  # fit's levels are found on its linearisation there

    def linearised_for(self, chosen: Selection) -> Linearised | None:
        """The richer fit's linearisation at its estimate for the nested fit's parameters
        (`chosen`, the same poses): their columns, the residuals less what the left-out
        (compliance) columns' values put in them, their values; None when the nested fit
        keeps a parameter the richer fit did not."""
        if self.problem is None or self.x is None:
            return None
        richer = {name: k for k, name in enumerate(self.problem.errors.names)}  # A's columns
        if any(name not in richer for name in chosen.errors.names):
            return None
        cols = [richer[name] for name in chosen.errors.names]
        out = np.setdiff1d(np.arange(len(self.x)), cols)
        e, A = self.problem.raw(self.x)
        return Linearised(self.x[cols], e - A[..., out] @ self.x[out], A[..., cols],
                          self.problem.components(self.x))


@dataclass(frozen=True)
class SingleFit:
    """One fit: the result, the final problem, its estimate and the selection it started
    from."""

    result: CalibrationResult
    problem: ResidualProblem
    x: Array
    selection: Selection


def fit_once(nominal: SerialModel, data: MeasurementSet, settings: IdentifySettings,
             warm: WarmStart | None = None, richer: RicherFit | None = None) -> SingleFit:
    """One fit of all the poses given. `warm`: the poses are those an earlier fit kept; its
    start, frames and identifiable parameters are kept, and the solve (LM with the noise
    levels) starts from the rounds' estimate and levels instead of the start's Gauss-Newton
    step and the priors. `richer`: a fit of the same model with a compliance, on these poses:
    this fit's candidates are its without the compliance (the same start, the same Jacobian
    columns), its noise levels start from the richer fit's (the solve as from scratch)."""
    started = time.perf_counter()
    residual = resolved_residual(settings, data.full_pose)
    levels, at = None, None  # the variance components to start from, a linearisation
    if warm is not None and settings.solver == "lm" and _estimates_noise(settings, residual):
        chosen, levels = warm.selection.rows(warm.kept, data, residual), warm.theta
    elif richer is not None and settings.compliance == "none":
        chosen, warm = richer.selection.without_compliance(data, residual, settings), None
        levels, at = richer.theta, richer.linearised_for(chosen)
    else:
        chosen, warm = _select(nominal, data, residual, settings), None
    problem, solution, noise = _solve(chosen, data, residual, settings, warm, levels, at)
    converged, message = solution.converged, solution.message
    if not converged and stationary(problem, solution.x):
        converged, message = True, f"{message}; at a stationary point of the cost (the " \
            "solver's own tolerances were not met, its steps no longer lower the cost)"
    elif not converged:
        message += NOT_CONVERGED_HINT
    solution = Solution(solution.x, converged, message, solution.nfev)
    result = _result(chosen, data, residual, settings, problem, solution, noise, started)
    return SingleFit(result, problem, solution.x, chosen)


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
    return _choose(start, tuple(cands), problem_all.whiten, r0, J0, T0, None, data, residual,
                   settings)


def _choose(start: SerialModel, cands: tuple[Param, ...], whiten: Array, r0: Array, J0: Array,
            T0: Array, triangle: Array | None, data: MeasurementSet, residual: Residual,
            settings: IdentifySettings) -> Selection:
    """The identifiable candidates, from their weighted Jacobian J0 at the start (`triangle`:
    the QR triangle of its scaled columns, when at hand); refuses data with fewer equations
    than the model's identifiable parameters."""
    kind = settings.kind
    errors_all = ErrorModel(start, cands)
    # The frames are unknown whatever the robot: take them first, then the model's own
    # parameters (joint and link offsets: what a controller can correct), then axis terms.
    priority = np.array([2 if p.group != "robot" else 1 if p.kind in ("zero", "link") else 0
                         for p in cands])
    needed = structural_rank(errors_all, residual)
    m = len(r0)
    if m <= needed:
        per_pose = POSE_ROWS.get(residual)
        more = f" (at least {needed // per_pose + 1} poses)" if per_pose else ""
        raise IdentificationError(f"{len(data)} poses give {m} equations for the {needed} "
                                  f"parameters this model can identify: measure more poses{more}")
    names = [p.name for p in cands]
    keep, rank, norms, combos, Rs = select_identifiable(J0, priority, names, triangle)
    removed_idx = np.setdiff1d(np.arange(len(cands)), keep)
    removed = explain_removed(Rs, keep, removed_idx, names, norms)
    # Degenerate: the poses separate fewer parameters than well-spread data would, or (for
    # the thesis and joint models) a requested offset cannot be identified at all.
    requested_robot = [k for k, p in enumerate(cands) if p.group == "robot"]
    degenerate = rank < needed or (kind != "full" and any(k in removed_idx
                                                          for k in requested_robot))
    notes = data_warnings(start, data, residual, m, rank, [n for n, _ in removed])
    errors = errors_all.subset([int(k) for k in keep])
    return Selection(start, cands, errors,
                     ResidualProblem(errors, data, residual, whiten, settings.prior_ranges), r0, J0,
                     T0, Rs, keep, rank, tuple(removed), tuple(combos), degenerate, tuple(notes))


def _solve(chosen: Selection, data: MeasurementSet, residual: Residual,
           settings: IdentifySettings, warm: WarmStart | None = None,
           levels: Array | None = None, at: Linearised | None = None
           ) -> tuple[ResidualProblem, Solution, NoiseEstimate | None]:
    """The estimate from the start (`warm`: from the rounds' estimate; `at`: from a richer
    fit's, its levels found on that fit's linearisation), re-weighted and with the noise
    levels as asked (estimated from the variance components `levels` when given); the final
    problem, the solution (nfev: every evaluation) and the noise levels used."""
    problem, statistical, noise = chosen.problem, settings.statistical, settings.noise
    estimate_noise = _estimates_noise(settings, residual)
    reweighted = False
    if warm is not None:  # (LM, noise estimated: fit_once)
        solution = Solution(warm.x, True, "", 0)
    elif at is not None and estimate_noise:  # (LM: fit_once)
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
    return problem, solution, noise_used


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
    x_gn = gauss_newton_step(chosen.J0[:, keep], chosen.r0, problem.prior, np.zeros(p))
    if estimate_noise:  # the noise levels' own loop re-weights and solves from there
        return problem, Solution(x_gn, True, "", 0), True
    if settings.statistical and problem.cost(x_gn) < float(chosen.r0 @ chosen.r0):
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
    before = pose_errors(chosen.start, data, residual, chosen.T0)
    after = pose_errors(calibrated, data, residual, problem.linearisation(x)[0])
    return CalibrationResult(
        model=calibrated, start_model=chosen.start, params=errors.params, values=to_if(x),
        std_errors=to_if(std), correlation=corr, removed=chosen.removed,
        unidentifiable_combinations=chosen.combinations, residual_kind=residual,
        weighting=settings.weighting, solver=settings.solver, rank=chosen.rank,
        n_candidates=len(chosen.candidates), condition_number=float(s[0] / s[-1]),
        o1=float(np.prod(s ** (1.0 / p)) / np.sqrt(m)), min_singular_value=float(s[-1]),
        chi2_reduced=chi2, residuals_before=before[0], residuals_after=after[0],
        rotation_before_deg=before[1], rotation_after_deg=after[1],
        degenerate=chosen.degenerate, covariance=cov, noise=noise,
        unabsorbed=unabsorbed(Jw, gram, errors.params, float(s[0] / s[-1])),
        data_warnings=chosen.notes,
        held_by_prior=tuple(held_directions(gram, 1.0 / problem.prior, list(errors.names))
                            if ranges is not None else ()),
        implausible=tuple(outside_ranges(errors.params, to_if(x), to_if(std), ranges)
                          if ranges is not None else ()),
        orientation_unknown=orientation_unknown(residual, calibrated),
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
    cols = [k for k, p in enumerate(params) if p.kind == "compliance"]
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
