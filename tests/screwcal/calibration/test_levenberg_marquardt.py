"""The identification's Levenberg-Marquardt on the normal equations, against scipy's MINPACK
on the same problems, from easy and hard starts, and honest about stopping short."""

import numpy as np
import pytest
from scipy.optimize import least_squares

from screwcal.calibration.error_parameters import ErrorModel, candidate_params
from screwcal.calibration.identify_settings import IdentifySettings
from screwcal.calibration.levenberg_marquardt import damped_step, levenberg_marquardt
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.residual_problem import ResidualProblem
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.robots import irb1600
from screwcal.studies.simulated_measurements import simulate_measurements


def _rosenbrock(x):
    r = np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])
    J = np.array([[-20.0 * x[0], 10.0], [-1.0, 0.0]])
    return r, J


def _exponentials(t, y):
    """Two decaying exponentials fitted to (t, y): a classic ill-conditioned NLS problem."""
    def evaluate(x):
        e1, e2 = np.exp(-x[1] * t), np.exp(-x[3] * t)
        r = x[0] * e1 + x[2] * e2 - y
        return r, np.stack([e1, -x[0] * t * e1, e2, -x[2] * t * e2], axis=1)
    return evaluate


def _minpack(evaluate, x0, prior):
    def fun(x):
        return np.r_[evaluate(x)[0], prior * x]

    def jac(x):
        return np.vstack([evaluate(x)[1], np.diag(prior)])

    return least_squares(fun, x0, jac=jac, method="lm", x_scale="jac", xtol=1e-14,
                         ftol=1e-14, gtol=1e-14).x


def test_rosenbrock_from_the_textbook_hard_start():
    fit = levenberg_marquardt(_rosenbrock, np.array([-1.2, 1.0]), np.zeros(2))
    assert fit.converged and np.allclose(fit.x, [1.0, 1.0], atol=1e-10)
    assert fit.iterations > 3  # the valley is followed, not jumped


@pytest.mark.parametrize("prior", [0.0, 0.3])
def test_agrees_with_minpack_on_an_ill_conditioned_fit_with_and_without_a_prior(prior):
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 4.0, 60)
    y = 2.0 * np.exp(-1.3 * t) + 0.7 * np.exp(-0.25 * t) + rng.normal(0, 1e-3, t.size)
    evaluate = _exponentials(t, y)
    x0, weights = np.array([1.0, 2.0, 1.0, 0.1]), np.full(4, prior)
    fit = levenberg_marquardt(evaluate, x0, weights, tol=1e-13)
    reference = _minpack(evaluate, x0, weights)
    assert fit.converged
    # the same minimum: the difference is a millionth of the estimate, in the flat direction
    # (what it adds to the cost is at round-off)
    assert np.allclose(fit.x, reference, rtol=1e-6)
    r, J = evaluate(fit.x)
    N = J.T @ J + np.diag(weights ** 2)
    d = fit.x - reference
    assert d @ N @ d < 1e-12 * (r @ r + np.sum((weights * fit.x) ** 2))


def test_agrees_with_minpack_on_an_identification_from_the_nominal_start(rng):
    """The full error model from x = 0 (the start's errors of 0.1-1 mm and deg, unweighted
    but for the prior): the same minimum as MINPACK's."""
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(80, rng), rng)
    start = irb1600()
    params = candidate_params(start, "thesis", base=False, tool_rotation=False,
                              tool_position=False)
    problem = ResidualProblem.weighted_at(ErrorModel(start, tuple(params)), data, "pose",
                                          IdentifySettings(weighting="eq2.4"))
    x0 = np.zeros(len(params))
    fit = levenberg_marquardt(problem.weighted, x0, problem.prior)
    assert fit.converged and fit.evaluations <= 10
    reference = _minpack(problem.weighted, x0, problem.prior)
    # the same minimum: the two differ by less than the Newton decrement either stopped at
    # (what the difference adds to the cost: 1e-12 of it)
    r, J = problem.weighted(fit.x)
    N = J.T @ J + np.diag(problem.prior ** 2)
    d = fit.x - reference
    assert d @ N @ d < 1e-11 * (r @ r) and np.max(np.abs(d)) < 1e-6  # rad and mm


def test_stopping_short_is_not_called_converged():
    fit = levenberg_marquardt(_rosenbrock, np.array([-1.2, 1.0]), np.zeros(2),
                              max_evaluations=3)
    assert not fit.converged and fit.evaluations == 3 and "stopped after 3" in fit.message


def test_a_refused_step_raises_the_damping():
    """A cost whose Gauss-Newton step overshoots (r = atan(x): the linear model's step from
    x = 3 lands far beyond the minimum at 0) is refused, damped and still converges."""
    def evaluate(x):
        return np.arctan(x), np.diag(1.0 / (1.0 + x ** 2))

    fit = levenberg_marquardt(evaluate, np.array([3.0]), np.zeros(1))
    assert fit.converged and abs(fit.x[0]) < 1e-8
    assert fit.evaluations > fit.iterations + 1  # refused steps were evaluated too


def test_a_singular_normal_matrix_is_damped_until_it_factors():
    N = np.array([[1.0, 1.0], [1.0, 1.0]])
    dx = damped_step(N, np.array([1.0, 1.0]), np.ones(2), 0.0)
    assert np.all(np.isfinite(dx)) and np.allclose(dx[0], dx[1])
    assert np.allclose(N @ dx, [-1.0, -1.0], rtol=1e-6)
