"""The noise levels estimated with the parameters (variance components).

Unless a level is fixed, the measuring noise (position, and orientation when measured) and the
joint noise are estimated with the parameters by Förstner's iteration: with
S_i = sum_k theta_k V_k,i, the whitened fit gives residuals e; each component's share of the
redundancy r_k = tr(W theta_k V_k) - tr(N^-1 A^T W theta_k V_k W A) and of the squared residual
Omega_k = e^T W theta_k V_k W e update theta_k <- theta_k Omega_k / r_k until they agree
(Förstner 1979; Koch, Parameter Estimation and Hypothesis Testing, 1999, 3.6), here as Fisher
scoring of the restricted likelihood. The result reports the levels with their standard
deviations (theta_k sqrt(2 / r_k)); the final fit's chi2/dof is then 1 by construction and the
standard errors are honest. With every level fixed, the standard errors are scaled by chi2/dof
when it exceeds 1 (the noise was understated).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg

from screwcal.calibration.diagnostics import loo_position_error
from screwcal.calibration.identifiability import Index
from screwcal.calibration.identify_result import NoiseEstimate
from screwcal.calibration.identify_settings import (
    PRIOR_NOISE,
    NoiseModel,
    levels_from_variance,
    variance_from_levels,
)
from screwcal.calibration.residual_problem import ResidualProblem, whitening_of_levels
from screwcal.calibration.solvers import Solution, Solve
from screwcal.calibration.variance_scoring import component_factors, scoring_step
from screwcal.kinematics.se3 import Array, Mask

VCE_MAX_ITER = 25
VCE_TOL = 0.05  # relative change of every free component at convergence
NEGLIGIBLE = 0.01  # a component under this share of the variance no longer shapes the weights
STEP_LIMIT = 20.0  # one scoring step changes a component by at most this factor
PRESS_MARGIN = 0.02  # the joint component is dropped only when that predicts clearly better
DETECTED = 1e-4  # a start's component above this share of the prior's variance is used


@dataclass(frozen=True)
class Linearised:
    """A problem's linearisation at hand at x (p,): residuals e (N, k), Jacobian A (N, k, p)
    and unit variance components V (3, N, k, k) (a nested fit's, from the richer fit's)."""

    x: Array
    e: Array
    A: Array
    V: Array


@dataclass(frozen=True)
class NoiseFit:
    """The free noise levels and the parameters found together."""

    problem: ResidualProblem  # weighted with the levels found
    solution: Solution  # the final solve with those weights (nfev: every evaluation)
    noise: NoiseEstimate


def fixed_levels(noise: NoiseModel, rows: int) -> NoiseEstimate:
    """The levels used when none is estimated (orientation not measured for positions)."""
    p, o, j = noise.filled()
    return NoiseEstimate(p, o if rows == 6 else float("nan"), j, None, None, None)


def estimate_with_joint_check(problem: ResidualProblem, noise: NoiseModel, x: Array,
                              solve: Solve, start: Array | None = None,
                              at: Linearised | None = None) -> NoiseFit:
    """The free levels estimated (`estimate_noise`, from the variance components `start`
    when given); when the joint level was estimated above zero, is it noise, or what the
    model misses (compliance, lag) soaked up, down-weighting the far poses that show the
    geometry? The weighting that predicts left-out poses better (PRESS, from this one
    linearisation) is kept. `at`: the linearisation to find the levels on (else at x)."""
    fit = estimate_noise(problem, noise, x, solve, start, at)
    if noise.joint_deg is not None or fit.noise.joint_deg <= 0.0:
        return fit
    problem, x = fit.problem, fit.solution.x
    e, A = problem.raw(x)
    theta = variance_from_levels((fit.noise.position_mm, fit.noise.orientation_deg
                                  if problem.rows == 6 else 0.0, 0.0))
    without = loo_position_error(e, A, _measuring_whitening(theta, problem, x))
    with_joint = loo_position_error(e, A, problem.whiten)
    if without >= (1.0 - PRESS_MARGIN) * with_joint:
        return fit
    refit = estimate_noise(problem, replace(noise, joint_deg=0.0), x, solve)
    solution = replace(refit.solution, nfev=fit.solution.nfev + refit.solution.nfev)
    return NoiseFit(refit.problem, solution, replace(refit.noise, note=(
        f"joint noise left out: it predicted left-out poses worse ({with_joint:.3f} vs "
        f"{without:.3f} mm, leave-one-out): what it soaked up is model error, not noise")))


def _measuring_whitening(theta: Array, problem: ResidualProblem, x: Array) -> Array:
    """The whitening (N, k, k) of the measuring noise alone (theta's joint component 0): the
    same diagonal at every pose, 1 / sqrt of the position's, then the orientation's variance
    (what the Cholesky factor of that diagonal gives, without the joint Jacobian's components
    or N factorisations); a variance at zero by the general path (which refuses it)."""
    d = np.repeat(theta[:2], 3)[:problem.rows]
    if theta[2] != 0.0 or not np.all(d > 0):
        return whitening_of_levels(theta, problem.components(x))
    return np.broadcast_to(np.diag(1.0 / np.sqrt(d)), (len(problem.data), len(d), len(d)))


def estimate_noise(problem: ResidualProblem, noise: NoiseModel, x: Array, solve: Solve,
                   start: Array | None = None, at: Linearised | None = None) -> NoiseFit:
    """The free noise levels and the parameters together, by restricted maximum likelihood
    (Fisher scoring on the variance components, a Gauss-Newton step of the parameters with the
    weights of each step, LM at the end). The free components start from `start` (3,) (a fit
    of nearly the same poses) when given, else from the priors; one below detection in
    `start` starts at the edge of detection instead (`from_start`): from the prior it would
    take a step per factor `STEP_LIMIT` to come down again, from the floor as many to rise,
    where the poses have more to say."""
    theta = variance_from_levels(noise.filled())
    free = np.array(noise.free)
    if problem.rows == 3:
        free[1] = False  # no orientation measured
        theta[1] = 0.0
    if at is None:
        e, A = problem.raw(x)
        at = Linearised(x, e, A, problem.components(x))
    if start is not None:
        theta = from_start(theta, free, start, at.V)
    idx = np.flatnonzero(free)
    # The levels are found on the problem linearised at the start (which the candidates'
    # Gauss-Newton step puts near the optimum, or the richer fit's estimate `at`), then LM
    # solves the nonlinear problem once with the final weights, taken at its own estimate.
    levels = levels_on_linearisation(at.e, at.A, at.V, theta, idx, problem.prior, at.x)
    V = problem.components(levels.x)
    problem = problem.with_whitening(whitening_of_levels(levels.theta, V))
    solution = solve(problem, levels.x)
    return NoiseFit(problem, solution, _estimate(levels.theta, idx, levels.information,
                                                 problem.rows, levels.iterations,
                                                 levels.converged))


def from_start(prior: Array, free: Mask, start: Array, V: Array) -> Array:
    """The components (3,) to start from: the free ones of `start` where it detects them
    (above `DETECTED` of the prior's: the test the levels' own estimation uses for a start);
    one below it at the edge of detection (`_at_detection`), never above `prior`'s; the
    others `prior`'s. (Not a share of the variance: the components' units differ, mm^2 and
    rad^2, and a well-determined position level can be a small share of the positions'.)"""
    theta = prior.copy()
    detected = free & (start > DETECTED * variance_from_levels(PRIOR_NOISE))
    theta[detected] = start[detected]
    below = free & ~detected
    if below.any() and detected.any():
        traces = np.einsum("knii->k", V)  # each component's total
        theta[below] = np.minimum(prior[below], _at_detection(theta, traces, below))
    return theta


def _at_detection(theta: Array, traces: Array, below: Mask) -> Array:
    """The values of the components `below` at which each holds half of `NEGLIGIBLE`'s share
    of the variance beside the others' theta (3,) (unit components with these traces (3,)):
    where `levels_on_linearisation` calls a component below detection when the data pull it
    down, and from where they raise it in a step or two when they do not."""
    others = float(traces[~below] @ theta[~below])
    at: Array = 0.5 * NEGLIGIBLE * others / traces[below]
    return at


@dataclass(frozen=True)
class LinearisedLevels:
    """Variance components found on a linearised problem, with the estimate and residuals
    carried to them."""

    theta: Array  # (3,) the components
    x: Array  # the estimate with their weights
    e: Array  # (N, k) the residuals there (to first order)
    information: Array  # (K, K) of the free components
    iterations: int
    converged: bool


def levels_on_linearisation(e: Array, A: Array, V: Array, theta: Array, idx: Index,
                            prior: Array, x: Array) -> LinearisedLevels:
    """The free components `idx` of theta (3,) by Fisher scoring on the problem linearised at x:
    residuals e (N, k), Jacobian A (N, k, p), unit components V (3, N, k, k); each iteration
    takes the weighted linear step with the components so far (Förstner's iteration, Eq. in
    the module docstring). The components not in `idx` stay as given."""
    theta = np.array(theta, dtype=float)
    floor = 1e-8 * variance_from_levels(PRIOR_NOISE)
    information = np.eye(len(idx))
    converged, iteration = False, 0
    P = prior
    factors = component_factors(V[idx])  # of the free components, for the scoring
    traces = np.einsum("knii->k", V)  # each component's total, for its share of the variance
    while iteration < VCE_MAX_ITER:
        iteration += 1
        W = whitening_of_levels(theta, V)
        # The weighted linear least-squares step by its normal equations (their inverse is
        # the scoring's too), and the residuals carried there.
        Aw = W @ A
        WA = Aw.reshape(-1, A.shape[-1])
        Ninv = scipy.linalg.pinvh(WA.T @ WA + np.diag(P ** 2))
        dx = -Ninv @ (WA.T @ (W @ e[..., None]).reshape(-1) + P ** 2 * x)
        x, e = x + dx, e + A @ dx
        if not len(idx):
            converged = True
            break
        score, information = scoring_step(e, Aw, factors, W, Ninv)
        step = np.linalg.lstsq(information, score, rcond=None)[0]
        old = theta[idx].copy()
        new = np.clip(old + step, old / STEP_LIMIT, old * STEP_LIMIT)
        theta[idx] = np.maximum(new, floor[idx])
        share = traces * theta
        share = share / share.sum()
        at_zero = (share[idx] < NEGLIGIBLE) & (step < 0)  # on the boundary: below detection
        if np.all((np.abs(theta[idx] / old - 1.0) < VCE_TOL) | at_zero):
            converged = True
            break
    return LinearisedLevels(theta, x, e, information, iteration, converged)


def _estimate(theta: Array, idx: Index, information: Array, rows: int, iterations: int,
              converged: bool) -> NoiseEstimate:
    """The levels of the variance components with the standard deviations of the free ones."""
    levels = levels_from_variance(theta)
    cov_theta = scipy.linalg.pinvh(information)
    stds: list[float | None] = [None, None, None]
    for j, c in enumerate(idx):
        # d level / d theta = level / (2 theta) for each of the three levels' scalings
        stds[c] = float(levels[c] / (2.0 * theta[c]) * np.sqrt(max(cov_theta[j, j], 0.0)))
    if rows == 3:
        levels[1] = float("nan")
    return NoiseEstimate(float(levels[0]), float(levels[1]), float(levels[2]), stds[0],
                         stds[1], stds[2], iterations=iterations, converged=converged)
