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
