"""The solvers of the identification: Levenberg-Marquardt from the start (on the normal
equations, `levenberg_marquardt`), or the thesis's Differential Evolution within its bounds
(thesis 2.2.3) with a bounded least-squares polish; and whether a stopped solver sits at the
cost's minimum all the same.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.optimize import differential_evolution, least_squares

from screwcal.calibration.error_parameters import ErrorModel
from screwcal.calibration.levenberg_marquardt import levenberg_marquardt
from screwcal.calibration.residual_problem import ResidualProblem
from screwcal.kinematics.se3 import Array

# The thesis's DE bounds (numeric units: rad, mm); links from the settings (default (0, 1) mm)
DE_ZERO_RAD = np.radians(5)  # joint offsets within +-5 deg
DE_ZERO_MM = 5.0  # ...and prismatic ones within +-5 mm
DE_FRAME_ROT_RAD = np.radians(2)  # frames within +-2 deg of the starting alignment
DE_FRAME_POS_MM = 20.0  # ...and +-20 mm
DE_AXIS_DIR_RAD = np.radians(1)  # full-model axis terms within +-1 deg
DE_AXIS_POS_MM = 5.0  # ...and +-5 mm
STATIONARY_GAIN = 1e-6  # a Gauss-Newton step that lowers the cost less than this share: minimum


@dataclass(frozen=True)
class Solution:
    """A solver's answer: the estimate, whether it converged, its message, its evaluations."""

    x: Array
    converged: bool
    message: str
    nfev: int


Solve = Callable[[ResidualProblem, Array], Solution]


def solve_lm(problem: ResidualProblem, x_start: Array, tol: float = 1e-12) -> Solution:
    """Levenberg-Marquardt on the posterior from x_start, on the normal equations of the
    problem's own linearisation (`levenberg_marquardt`); nfev: its evaluations of the
    residuals with their Jacobian."""
    fit = levenberg_marquardt(problem.weighted, x_start, problem.prior, tol)
    return Solution(fit.x, fit.converged, f"{fit.message}; {fit.iterations} steps",
                    fit.evaluations)


def de_bounds(errors: ErrorModel, link_bounds_mm: tuple[float, float]
              ) -> list[tuple[float, float]]:
    """The thesis's bounds: joint offsets [-5, 5] deg, link offsets (0, 1) mm by default;
    frames within +-2 deg and +-20 mm of the starting alignment; full-model axis terms within
    +-1 deg and +-5 mm."""
    out = []
    for p in errors.params:
        if p.kind == "zero":
            out.append((-DE_ZERO_RAD, DE_ZERO_RAD) if p.is_angle else (-DE_ZERO_MM, DE_ZERO_MM))
        elif p.kind == "link":
            out.append(link_bounds_mm)
        elif p.kind.endswith("rot"):
            out.append((-DE_FRAME_ROT_RAD, DE_FRAME_ROT_RAD))
        elif p.kind.endswith("pos"):
            out.append((-DE_FRAME_POS_MM, DE_FRAME_POS_MM))
        elif p.kind == "dir":
            out.append((-DE_AXIS_DIR_RAD, DE_AXIS_DIR_RAD))
        else:
            out.append((-DE_AXIS_POS_MM, DE_AXIS_POS_MM))
    return out


def solve_de(problem: ResidualProblem, link_bounds_mm: tuple[float, float], seed: int,
             polish: bool) -> Solution:
    """DE searches the robot's parameters within the thesis's bounds, the frames held at
    their starting alignment (the thesis's DE had an aligned base); a bounded trust-region
    polish then refines everything together (`polish=False`: DE's own best)."""
    errors = problem.errors
    p = len(errors.params)
    bounds = de_bounds(errors, link_bounds_mm)
    robot = np.array([q.group == "robot" for q in errors.params])
    searched = robot if robot.any() else np.ones(p, bool)

    def cost_robot(X: Array) -> Array:
        full = np.zeros((p, X.shape[1]))
        full[searched] = X
        return problem.cost_batch(full)

    de = differential_evolution(cost_robot, [b for b, s in zip(bounds, searched, strict=True)
                                             if s],
                                seed=seed, tol=1e-7, atol=0, maxiter=1000, popsize=15,
                                polish=False, init="sobol", vectorized=True,
                                updating="deferred")
    start_x = np.zeros(p)
    start_x[searched] = de.x
    if not polish:
        return Solution(start_x, bool(de.success), f"DE: {de.message}", int(de.nfev))
    lower, upper = zip(*bounds, strict=True)
    refined = least_squares(problem.posterior_residuals, start_x,
                            jac=problem.posterior_jacobian, method="trf", x_scale="jac",
                            bounds=(lower, upper), xtol=1e-12, ftol=1e-12)
    return Solution(refined.x, bool(de.success or refined.status > 0),
                    f"DE: {de.message}; polished: {refined.message}",
                    int(de.nfev + refined.nfev))


def gauss_newton_step(J: Array, r: Array, prior: Array, x: Array) -> Array:
    """The Gauss-Newton step from x of weighted residuals r (m,) with Jacobian J (m, p) and the
    prior's rows (`prior` * x) below, by the normal equations of the column-scaled J (a (p, p)
    Cholesky instead of a tall factorisation); by least squares when they are not positive
    definite to working precision."""
    scale = np.linalg.norm(J, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    Js = J / scale
    P = prior / scale
    try:
        factor = scipy.linalg.cho_factor(Js.T @ Js + np.diag(P ** 2))
        return -scipy.linalg.cho_solve(factor, Js.T @ r + P * (prior * x)) / scale
    except np.linalg.LinAlgError:
        return -np.linalg.lstsq(np.vstack([J, np.diag(prior)]), np.r_[r, prior * x],
                                rcond=None)[0]


def stationary(problem: ResidualProblem, x: Array) -> bool:
    """Whether x is a stationary point of the (posterior) cost: a Gauss-Newton step from it
    would lower the cost by less than a millionth (the solver stopped on its evaluation count
    or step tolerances, not short of the minimum)."""
    r, J = problem.posterior(x)
    dx = np.linalg.lstsq(J, -r, rcond=None)[0]
    cost = float(r @ r)
    gain = cost - float(np.sum((r + J @ dx) ** 2))
    return bool(gain <= STATIONARY_GAIN * max(cost, 1.0))
