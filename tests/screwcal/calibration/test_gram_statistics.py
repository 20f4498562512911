"""The fit's statistics read from the Gram matrix J^T J (p, p) instead of the tall J: the same
singular values, unabsorbed shares and held directions, and the tall J's SVD where the
Gram matrix would lose them."""

import numpy as np

from screwcal.calibration.error_parameters import Param
from screwcal.calibration.identifiability import scaled_singular_values, singular_values
from screwcal.calibration.plausible import held_directions
from screwcal.calibration.single_fit import unabsorbed


def _columns(rng, condition):
    """(3000, 8) with scaled columns of about this condition number and unequal lengths."""
    U = np.linalg.qr(rng.normal(size=(3000, 8)))[0]
    V = np.linalg.qr(rng.normal(size=(8, 8)))[0]
    J = U @ np.diag(np.geomspace(1.0, 1.0 / condition, 8)) @ V
    return J * np.geomspace(0.01, 100.0, 8)


def _scaled_svd(J):
    return singular_values(J / np.linalg.norm(J, axis=0))


def test_singular_values_from_the_gram_matrix(rng):
    J = _columns(rng, 300.0)
    assert np.allclose(scaled_singular_values(J, J.T @ J), _scaled_svd(J), rtol=1e-10)


def test_an_ill_conditioned_jacobian_goes_to_the_svd(rng):
    """At a condition number of 1e7 the Gram matrix's smallest eigenvalue is at round-off:
    its square root would be wrong by percents."""
    J = _columns(rng, 1e7)
    s = scaled_singular_values(J, J.T @ J)
    assert np.allclose(s, _scaled_svd(J), rtol=1e-9)
    assert s[0] / s[-1] > 1e5


def test_unabsorbed_shares_from_the_gram_matrix_equal_the_projections(rng):
    J = _columns(rng, 50.0)
    params = [Param(f"p{k}", "mm", "compliance" if k in (2, 5) else "link") for k in range(8)]
    fast = unabsorbed(J, J.T @ J, params, condition=50.0)
    slow = unabsorbed(J, J.T @ J, params, condition=np.inf)  # least squares, column by column
    assert set(fast) == {"p2", "p5"}
    assert all(abs(fast[n] - slow[n]) < 1e-10 for n in fast) and 0 < fast["p2"] < 1


def test_held_directions_from_the_information_matrix(rng):
    """The prior decides the direction the data barely see (two nearly equal columns)."""
    J = rng.normal(size=(500, 4))
    J[:, 3] = J[:, 2] + 1e-5 * rng.normal(size=500)
    held = held_directions(J.T @ J, np.full(4, 1.0), ["a", "b", "c", "d"])
    assert len(held) == 1 and "c" in held[0] and "d" in held[0]


def test_the_scaled_triangle_is_the_qr_factors_top_rows(rng):
    """Issue 29: the triangle of the column-scaled candidate Jacobian from LAPACK's factor's
    top rows (scipy's qr mode "r" zeroed below the diagonal of the whole tall matrix, a copy
    of it): the same R, a dead column zero."""
    import scipy.linalg

    from screwcal.calibration.identifiability import _scaled_triangle

    J = _columns(rng, 1e4)
    J[:, 3] = 0.0
    norms = np.linalg.norm(J, axis=0)
    live = norms > 0
    R = _scaled_triangle(J, norms, live)
    Js = J / np.where(live, norms, 1.0)
    expected = scipy.linalg.qr(Js, mode="r")[0][:8]
    assert R.shape == (8, 8)
    np.testing.assert_array_equal(R, expected)
    assert not R[:, 3].any()
