"""The per-pose whitening: W_i^T W_i = C_i^-1 with W_i the inverse of C_i's Cholesky factor."""

import numpy as np
import pytest

from screwcal.calibration.residual_problem import lower_inverse, whitening


@pytest.mark.parametrize("k", [3, 6])
def test_whitening_inverts_each_covariance(rng, k):
    J = rng.normal(size=(40, k, 6))
    cov = J @ np.swapaxes(J, 1, 2) + 1e-4 * np.eye(k)  # a joint part and a little noise
    W = whitening(cov)
    assert np.allclose(np.swapaxes(W, 1, 2) @ W, np.linalg.inv(cov), rtol=1e-8, atol=1e-8)
    assert np.all(np.triu(W, 1) == 0.0)  # lower triangular: the inverse of a Cholesky factor


def test_lower_inverse_equals_the_general_inverse(rng):
    L = np.tril(rng.normal(size=(25, 6, 6))) + 3.0 * np.eye(6)
    assert np.allclose(lower_inverse(L), np.linalg.inv(L), rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("k", [3, 6])
def test_the_measuring_noise_whitening_is_the_general_one(rng, k):
    """Issue 29: the joint-noise check's weighting without joint noise is one diagonal at every
    pose, formed directly: exactly the general path's (components, N Cholesky factors)."""
    from types import SimpleNamespace

    from screwcal.calibration.noise_levels import _measuring_whitening
    from screwcal.calibration.residual_problem import covariance_components, whitening_of_levels

    Jq = rng.normal(size=(30, k, 6))
    V = covariance_components(Jq)
    problem = SimpleNamespace(rows=k, data=np.zeros(30), components=lambda x: V)
    theta = np.array([0.013 ** 2, 1e-7 if k == 6 else 0.0, 0.0])
    W = _measuring_whitening(theta, problem, np.zeros(3))  # type: ignore[arg-type]
    np.testing.assert_array_equal(W, whitening_of_levels(theta, V))
    joint = theta + np.array([0.0, 0.0, 1e-8])  # with joint noise: the general path
    np.testing.assert_array_equal(_measuring_whitening(joint, problem, np.zeros(3)),
                                  whitening_of_levels(joint, V))
