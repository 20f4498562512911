"""The outlier rounds' rule for rejecting several poses at once (issue 29): a pose still beyond
the limit without what the others' errors can leak into its residual."""

import numpy as np
import pytest

from screwcal.calibration.diagnostics import PoseTest, whitened_pose_tests
from screwcal.calibration.outlier_rounds import without_leaks, worst_poses


def _linear_fit(rng, N, p, gross):
    """Whitened residuals of a linear least-squares fit of N poses (3 rows, p parameters)
    with unit noise and the gross errors `gross` {pose: size}: the pose tests, and per pose
    its statistic when only its own gross error is in the data (what the rule bounds)."""
    A = rng.normal(size=(N, 3, p)) * rng.uniform(0.2, 3.0, (N, 1, 1))  # uneven leverage
    noise = rng.normal(size=(N, 3))
    errors = np.zeros((N, 3))
    for k, size in gross.items():
        direction = rng.normal(size=3)
        errors[k] = size * direction / np.linalg.norm(direction)
    flat = A.reshape(-1, p)

    def residuals(eps):
        x = np.linalg.lstsq(flat, eps.reshape(-1), rcond=None)[0]
        return (eps.reshape(-1) - flat @ x).reshape(N, 3, 1)

    test = whitened_pose_tests(residuals(noise + errors), A)
    own = np.empty(N)
    clean = whitened_pose_tests(residuals(noise), A).statistic
    for j in range(N):
        own[j] = clean[j]
        if j in gross:
            only = errors * 0.0
            only[j] = errors[j]
            own[j] = whitened_pose_tests(residuals(noise + only), A).statistic[j]
    return test, own


@pytest.mark.parametrize(("N", "p", "seed"), [(400, 30, 1), (400, 30, 2), (60, 30, 3),
                                              (2000, 40, 4)])
def test_the_bound_never_exceeds_a_poses_own_statistic(N, p, seed):
    """Whatever the others' gross errors (0.5-500 sigma, a decade of them), a pose's bound
    without their leaks stays under the statistic its own error alone gives it: a clean pose
    is never rejected for what another pose put into it."""
    rng = np.random.default_rng(seed)
    bad = rng.choice(N, max(2, N // 50), replace=False)
    gross = dict(zip(bad.tolist(), np.geomspace(0.5, 500.0, len(bad)).tolist(), strict=True))
    test, own = _linear_fit(rng, N, p, gross)
    limit = test.threshold()
    bound = without_leaks(test.statistic, test.leverage, test.statistic > limit)
    assert np.all(bound <= own + 1e-9)
    clean = np.setdiff1d(np.arange(N), bad)
    assert not np.any(bound[clean] > limit)


def test_a_round_rejects_every_pose_clearly_beyond_the_leaks_with_the_worst():
    """Many poses, a decade of gross errors: the first round takes the large ones together
    (the halving rule alone takes those within half of the worst), never a clean pose."""
    rng = np.random.default_rng(5)
    N = 2000
    bad = rng.choice(N, 20, replace=False)
    gross = dict(zip(bad.tolist(), np.geomspace(20.0, 2000.0, 20).tolist(), strict=True))
    test, _ = _linear_fit(rng, N, 40, gross)
    limit = test.threshold()
    dropped = worst_poses(test, limit, cap=200)
    halving = np.flatnonzero(test.statistic >= 0.5 * test.statistic.max())
    assert set(dropped.tolist()) <= set(bad.tolist())
    assert len(dropped) > 2 * len(halving)
    assert list(test.statistic[dropped]) == sorted(test.statistic[dropped], reverse=True)


def test_with_high_leverage_the_rule_falls_back_to_the_worst():
    """Few poses for the parameters (leverage near 1): the bound says nothing, a round takes
    the worst (within half of it) as before."""
    statistic = np.array([400.0, 300.0, 150.0, 5.0])
    test = PoseTest(statistic, np.array([0.9, 0.9, 0.9, 0.9]), 3)
    assert worst_poses(test, 20.0, cap=10).tolist() == [0, 1]
