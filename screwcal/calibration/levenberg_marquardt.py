"""Levenberg-Marquardt on the normal equations: the identification's own solver.

The identification's residuals are whitened measurement rows r(x) (m,) with the Jacobian J(x)
(m, p) of `ErrorModel.linearisation`, and the prior's rows `prior * x` below them
(`residual_problem`); the cost is f(x) = |r|^2 + |prior x|^2. Each iteration takes one
evaluation of r and J at the trial point and solves the damped normal equations

    (N + lambda D^2) dx = -g,   N = J^T J + diag(prior^2),   g = J^T r + prior^2 x,

with D^2 the largest diagonal of N met so far (the columns' scale, as MINPACK's with
`x_scale="jac"`), by a (p, p) Cholesky: m * p^2 operations for N instead of a QR of the tall
(m + p, p) matrix per step, and no evaluation of the residuals alone (the identification's
Jacobian comes with its residuals from one chain). Near its minimum the problem is nearly
linear, so lambda starts at 0 (a Gauss-Newton step): from a Gauss-Newton start the fit
converges in two or three evaluations. A step that does not lower the cost (ratio of the actual
to the predicted reduction under `ACCEPT`) is refused and lambda raised (Nielsen's rule: x2,
x4, ...); an accepted one lowers it (Nielsen's
1 - (2 rho - 1)^3, at most x`LAMBDA_DOWN`, and to 0 again under `LAMBDA_FLOOR`).

Stopping, as MINPACK's tests (Moré 1978), all relative and with one tolerance `tol`:

- the Gauss-Newton step from the estimate predicted to lower the cost by under tol * f (the
  Newton decrement g^T N^-1 g: it needs no evaluation at the step, whose linearisation the
  caller would not use; from a Gauss-Newton start the estimate is then one step after it);
- the cost's actual and predicted reductions both under tol * f ("ftol");
- the scaled step under tol * the scaled estimate ("xtol");
- the cosine between the residuals and every scaled column under tol ("gtol").

Otherwise the solver stops after `max_evaluations` (not converged), or when a refused step is
already under the step tolerance (no step lowers the cost: not converged either; the caller's
`solvers.stationary` says whether that is the minimum all the same).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from screwcal.kinematics.se3 import Array

ACCEPT = 1e-4  # a step is taken when it achieves this share of its predicted reduction
LAMBDA_FLOOR = 1e-9  # damping under this (relative to the scaled diagonal) is dropped: GN
LAMBDA_FIRST = 1e-3  # the damping after a refused Gauss-Newton step
LAMBDA_DOWN = 0.1  # an accepted step lowers the damping by at least this factor
MAX_EVALUATIONS = 200

Evaluate = Callable[[Array], tuple[Array, Array]]  # x -> weighted residuals (m,), Jacobian (m, p)


@dataclass(frozen=True)
class LMResult:
    """The estimate, whether a convergence test held, why it stopped, the evaluations of r and
    J (the start's included) and the steps taken."""

    x: Array
    converged: bool
    message: str
    evaluations: int
    iterations: int


@dataclass
class _Point:
    """An estimate with its cost and normal equations."""

    x: Array
    cost: float
    N: Array  # (p, p)
    g: Array  # (p,)


def _point(evaluate: Evaluate, x: Array, prior: Array) -> _Point:
    r, J = evaluate(x)
    px = prior * x
    return _Point(x, float(r @ r + px @ px), J.T @ J + np.diag(prior ** 2), J.T @ r + prior * px)


def damped_step(N: Array, g: Array, D: Array, lam: float) -> Array:
    """The solution of (N + lam D^2) dx = -g by Cholesky of the scaled matrix (unit diagonal
    where D is N's); when that is not positive definite to working precision, the smallest
    damping from 1e-9 up (x10) that is."""
    Ns = N / np.outer(D, D)
    gs = g / D
    eye = np.eye(len(g))
    while True:
        try:
            factor = scipy.linalg.cho_factor(Ns + lam * eye)
            return -scipy.linalg.cho_solve(factor, gs) / D
        except np.linalg.LinAlgError:
            lam = max(10.0 * lam, LAMBDA_FLOOR)


def levenberg_marquardt(evaluate: Evaluate, x0: Array, prior: Array, tol: float = 1e-12,
                        max_evaluations: int = MAX_EVALUATIONS) -> LMResult:
    """Minimise |r(x)|^2 + |prior x|^2 from x0 (see the module docstring); `evaluate` gives the
    weighted residuals and their Jacobian at x."""
    here = _point(evaluate, np.asarray(x0, dtype=float), prior)
    evaluations, iterations = 1, 0
    D = np.zeros(len(here.g))
    lam, nu = 0.0, 2.0
    while True:
        D = np.maximum(D, np.sqrt(np.diag(here.N)))
        D = np.where(D > 0, D, 1.0)
        dx = damped_step(here.N, here.g, D, lam)
        predicted = -float(2.0 * here.g @ dx + dx @ here.N @ dx)
        stop = _converged_here(here, D, lam, predicted, tol)
        if stop or evaluations >= max_evaluations:
            return LMResult(here.x, bool(stop), stop or f"stopped after {evaluations} "
                            "evaluations", evaluations, iterations)
        trial = _point(evaluate, here.x + dx, prior)
        evaluations += 1
        actual = here.cost - trial.cost if np.isfinite(trial.cost) else -np.inf
        rho = actual / predicted if predicted > 0 else -np.inf
        small = bool(np.linalg.norm(D * dx) <= tol * (np.linalg.norm(D * here.x) + tol))
        if rho > ACCEPT:
            iterations += 1
            here, lam, nu = trial, lam * max(LAMBDA_DOWN, 1 - (2 * rho - 1) ** 3), 2.0
            lam = 0.0 if lam < LAMBDA_FLOOR else lam
        stop = _converged_after(actual, predicted, here.cost, small and rho > ACCEPT, tol)
        if stop or small:
            return LMResult(here.x, bool(stop), stop or "no step lowers the cost (the step "
                            f"is under {tol:g} of the estimate)", evaluations, iterations)
        if rho <= ACCEPT:
            lam, nu = max(lam * nu, LAMBDA_FIRST), 2.0 * nu


def _converged_here(here: _Point, D: Array, lam: float, predicted: float, tol: float) -> str:
    """Why the estimate is converged before its next step is tried, or "": the residuals
    orthogonal to the scaled columns (gtol), or the Gauss-Newton step from it predicted to
    lower the cost by under tol of it (its Newton decrement: the gradient in the metric of the
    normal matrix; the step would move the estimate by about sqrt(tol * cost) standard
    errors at most)."""
    if here.cost <= 0 or np.max(np.abs(here.g) / D) <= tol * np.sqrt(here.cost):
        return f"converged: the residuals are orthogonal to the Jacobian's columns within " \
            f"{tol:g} (gtol)"
    if lam == 0.0 and predicted <= tol * here.cost:
        return f"converged: the Gauss-Newton step would lower the cost by under {tol:g} of it"
    return ""


def _converged_after(actual: float, predicted: float, cost: float, small_accepted: bool,
                     tol: float) -> str:
    """Why the estimate after a step is converged, or "": the step's actual and predicted
    reductions under tol of the cost (ftol), or an accepted step under tol of the estimate
    (xtol)."""
    if abs(actual) <= tol * cost and predicted <= tol * cost:
        return f"converged: the cost's actual and predicted reductions under {tol:g} of it " \
            "(ftol)"
    if small_accepted:
        return f"converged: the step under {tol:g} of the estimate (xtol)"
    return ""
