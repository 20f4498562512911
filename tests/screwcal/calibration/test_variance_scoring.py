"""The variance components' scoring step in whitened, factored form against the textbook
formulas with explicit per-pose covariances (Koch 1999, 3.6)."""

import numpy as np
import pytest

from screwcal.calibration import variance_scoring
from screwcal.calibration.residual_problem import whitening
from screwcal.calibration.variance_scoring import component_factors, scoring_step


def _textbook(e, A, V, theta, prior):
    """Score and information from C_i = sum theta_k V_k,i by dense per-pose algebra."""
    C = np.einsum("k,knij->nij", theta, V)
    Ci = np.linalg.inv(C)
    Nm = np.einsum("nip,nij,njq->pq", A, Ci, A) + np.diag(prior ** 2)
    Ninv = np.linalg.inv(Nm)
    K = len(V)
    score, info = np.zeros(K), np.zeros((K, K))
    S = np.einsum("nij,njp,pq,nrq,nrs->nis", Ci, A, Ninv, A, Ci)  # C^-1 A N^-1 A^T C^-1
    M = Ci @ V  # (K, N, k, k)
    G = np.einsum("nip,knij,njq->kpq", Ci @ A, V, Ci @ A)
    Ce = np.einsum("nij,nj->ni", Ci, e)
    for k in range(K):
        score[k] = 0.5 * (np.einsum("ni,nij,nj->", Ce, V[k], Ce) - np.trace(M[k], axis1=1,
                                                                          axis2=2).sum()
                          + np.einsum("nij,nji->", V[k], S))
        for m in range(K):
            info[k, m] = 0.5 * (np.einsum("nij,nji->", M[k], M[m])
                                - 2.0 * np.einsum("nij,njk,nki->", V[k], Ci @ V[m], S)
                                + np.trace(G[k] @ Ninv @ G[m] @ Ninv))
    return score, info, Ci, Ninv


@pytest.mark.parametrize(("rows", "block"), [(6, 200), (3, 200), (6, 7)])
def test_the_factored_step_is_the_textbook_step(rng, rows, block, monkeypatch):
    """Pose rows and position rows; summed in one block, and in blocks of 7 (the last one
    shorter)."""
    monkeypatch.setattr(variance_scoring, "BLOCK", block)
    N, p = 30, 5
    Jq = rng.normal(size=(N, rows, 6))
    Jq[4, :, 5] = Jq[4, :, 3]  # a pose at a singularity: its joint component is singular
    V = np.zeros((3, N, rows, rows))
    V[0][:, range(3), range(3)] = 1.0
    if rows == 6:
        V[1][:, range(3, 6), range(3, 6)] = 1.0
    else:
        V[1][:, range(3), range(3)] = 2.0  # a diagonal that is not a selection
    V[2] = Jq @ np.swapaxes(Jq, 1, 2)
    theta = np.array([0.02, 0.01, 0.003])
    A = rng.normal(size=(N, rows, p))
    e = rng.normal(size=(N, rows))
    prior = np.full(p, 0.1)
    score, info, Ci, Ninv = _textbook(e, A, V, theta, prior)
    W = whitening(np.linalg.inv(Ci))
    fast_score, fast_info = scoring_step(e, W @ A, component_factors(V), W, Ninv)
    assert np.allclose(fast_score, score, rtol=1e-9, atol=1e-9 * np.abs(score).max())
    assert np.allclose(fast_info, info, rtol=1e-9, atol=1e-9 * np.abs(info).max())


def test_factors_rebuild_the_components(rng):
    Jq = rng.normal(size=(10, 6, 6))
    Jq[2, :, 1] = 0.0  # singular: no Cholesky factor for that pose
    V = np.stack([np.broadcast_to(np.diag([1.0, 1, 1, 0, 0, 0]), (10, 6, 6)),
                  np.broadcast_to(np.diag([0.0, 0, 0, 4, 4, 4]), (10, 6, 6)),
                  Jq @ np.swapaxes(Jq, 1, 2)])
    factors = component_factors(V)
    assert [f.B is None for f in factors] == [True, True, False]
    identity = np.broadcast_to(np.eye(6), (10, 6, 6))
    for f, Vc in zip(factors, V, strict=True):
        B = f.whitened(identity, slice(0, 10))
        assert np.allclose(B @ np.swapaxes(B, 1, 2), Vc, atol=1e-10)
    W = np.tril(rng.normal(size=(4, 6, 6)))  # the whitened factor of some poses
    assert np.allclose(factors[2].whitened(W, slice(3, 7)), W @ factors[2].B[3:7])
    assert np.allclose(factors[1].whitened(W, slice(3, 7)), W[:, :, 3:] * 2.0)
