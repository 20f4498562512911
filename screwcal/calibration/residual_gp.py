"""Gaussian-process regression of the physical model's position residual on the joint angles:
the numerics behind `residual_model`.

Features: sin and cos of every joint angle (`joint_features`, shape (N, 2n)): a residual that is
a smooth periodic function of the joints is a smooth function of them, and a joint that turns
by a whole turn lands on the same point. Kernel: the squared exponential over those features,

    k(a, b) = signal^2 exp(-|phi(a) - phi(b)|^2 / (2 length^2)),

one kernel for the three Cartesian components, each an independent output with the same
hyperparameters (three numbers: length scale, signal and noise level). Why a Gaussian process
and not another kernel method: with a few hundred poses its exact solution is a few small dense
factorisations, it gives each prediction its standard deviation, and its marginal likelihood
chooses the hyperparameters from the calibration poses alone, with no held-out set.

The hyperparameters maximise the marginal likelihood (`fit_hyperparameters`): for a length
scale, one eigendecomposition of the unit-signal kernel matrix makes the likelihood of any
(signal, noise) pair a sum over its eigenvalues; the signal is then in closed form given the
noise-to-signal ratio, the ratio a bounded search, and the length scale a bounded search
outside. `fold_predictions` gives the exact k-fold cross-validated predictions of those
hyperparameters from one inverse (the held-out block's predictive mean and variance from the
inverse's block, no refit per fold).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from screwcal.kinematics.se3 import Array

LENGTH_BOUNDS = (0.05, 20.0)  # feature-space length scales searched (6 joints: distances <= 4.9)
RATIO_BOUNDS = (1e-6, 1e4)  # noise variance / signal variance searched
CHUNK_ROWS = 4096  # predictions in blocks of this many configurations (memory: rows x poses)
LENGTH_TOL = 0.08  # the length scale's search stops within 8 % of the best (a flat maximum)
RATIO_TOL = 0.03  # the noise-to-signal ratio's within 3 %


@dataclass(frozen=True)
class Hyperparameters:
    length: float  # in feature units (sin/cos of the joints)
    signal_mm: float  # prior standard deviation of each component of the residual
    noise_mm: float  # standard deviation of what the joints do not explain, per component


def joint_features(q_rad: Array) -> Array:
    """(N, 2n) sin and cos of each joint angle of q_rad (N, n)."""
    q = np.asarray(q_rad, float)
    return np.concatenate([np.sin(q), np.cos(q)], axis=-1)


def squared_distances(A: Array, B: Array) -> Array:
    """(N, M) squared Euclidean distances between the rows of A (N, d) and B (M, d)."""
    d2 = (A * A).sum(1)[:, None] + (B * B).sum(1)[None, :] - 2.0 * A @ B.T
    return np.maximum(d2, 0.0)


def _profile(eigenvalues: Array, z2: Array, outputs: int) -> tuple[float, float, float]:
    """(negative log marginal likelihood, signal variance, noise variance) at the best
    noise-to-signal ratio for a kernel with these unit-signal eigenvalues; z2 (n,): the squared
    projections of the outputs on the eigenvectors, summed over the outputs."""
    from scipy.optimize import minimize_scalar  # fitting only: predictions need numpy alone

    count = eigenvalues.size * outputs

    def nll(log_ratio: float) -> float:
        d = eigenvalues + np.exp(log_ratio)
        signal2 = float(np.sum(z2 / d)) / count
        return 0.5 * count * (1.0 + np.log(signal2)) + 0.5 * outputs * float(np.sum(np.log(d)))

    best = minimize_scalar(nll, bounds=np.log(RATIO_BOUNDS), method="bounded",
                           options={"xatol": RATIO_TOL})
    ratio = float(np.exp(best.x))
    signal2 = float(np.sum(z2 / (eigenvalues + ratio))) / count
    return float(best.fun), signal2, ratio * signal2


def fit_hyperparameters(X: Array, Y: Array) -> Hyperparameters:
    """The length scale, signal and noise that maximise the marginal likelihood of the outputs
    Y (N, m) at the features X (N, d) (zero-mean process, outputs independent)."""
    return fit_with_evidence(X, Y)[0]


def fit_with_evidence(X: Array, Y: Array) -> tuple[Hyperparameters, float]:
    """`fit_hyperparameters`, and the negative log marginal likelihood they reach (up to the
    constant N m log(2 pi) / 2): features are compared by it."""
    from scipy.optimize import minimize_scalar

    D2 = squared_distances(X, X)
    found: dict[float, tuple[float, float]] = {}

    def nll(log_length: float) -> float:
        K0 = np.exp(-0.5 * D2 / np.exp(2.0 * log_length))
        eigenvalues, V = np.linalg.eigh(K0)
        z2 = np.sum((V.T @ Y) ** 2, axis=1)
        value, signal2, noise2 = _profile(np.maximum(eigenvalues, 0.0), z2, Y.shape[1])
        found[log_length] = (signal2, noise2)
        return value

    best = minimize_scalar(nll, bounds=np.log(LENGTH_BOUNDS), method="bounded",
                           options={"xatol": LENGTH_TOL})
    signal2, noise2 = found[float(best.x)]
    return Hyperparameters(float(np.exp(best.x)), float(np.sqrt(signal2)),
                           float(np.sqrt(noise2))), float(best.fun)


def kernel(A: Array, B: Array, h: Hyperparameters) -> Array:
    """(N, M) the kernel between the feature rows of A and B."""
    return h.signal_mm ** 2 * np.exp(-0.5 * squared_distances(A, B) / h.length ** 2)


def _inverse(Ky: Array) -> Array:
    """The inverse of a symmetric positive definite matrix, through its Cholesky factor."""
    Linv = np.linalg.inv(np.linalg.cholesky(Ky))
    return Linv.T @ Linv


def fold_predictions(posterior: Posterior, Y: Array, folds: NDArray[np.integer]
                     ) -> tuple[Array, Array]:
    """k-fold cross-validated predictions: for each pose, the predictive mean (N, m) and
    variance (N,) (noise included, per component) of a process trained on the other folds,
    `folds` (N,) the fold of each pose; `posterior`: the process trained on all the poses, Y
    its outputs. Exact, from the inverse of the full kernel matrix."""
    Kinv, alpha = posterior.Kinv, posterior.alpha
    mean, var = np.empty_like(Y), np.empty(len(Y))
    for f in np.unique(folds):
        block = folds == f
        S = np.linalg.inv(Kinv[np.ix_(block, block)])
        mean[block] = Y[block] - S @ alpha[block]
        var[block] = np.diag(S)
    return mean, var


@dataclass(frozen=True)
class Posterior:
    """A trained process: predicts the residual and its variance at new features."""

    X: Array  # (N, d) training features
    h: Hyperparameters
    alpha: Array  # (N, m) K_y^-1 Y
    Kinv: Array  # (N, N) K_y^-1

    @classmethod
    def train(cls, X: Array, Y: Array, h: Hyperparameters) -> Posterior:
        Kinv = _inverse(kernel(X, X, h) + h.noise_mm ** 2 * np.eye(len(X)))
        return cls(X, h, Kinv @ Y, Kinv)

    def mean(self, Xs: Array) -> Array:
        """Predictive mean (M, m) at Xs (M, d)."""
        return kernel(Xs, self.X, self.h) @ self.alpha

    def predict(self, Xs: Array) -> tuple[Array, Array, Array]:
        """Predictive mean (M, m), latent variance (M,) (noise excluded) and the distance to
        the nearest training row in length scales (M,) at Xs (M, d), in blocks of
        `CHUNK_ROWS` rows."""
        mean = np.empty((len(Xs), self.alpha.shape[1]))
        latent, nearest = np.empty(len(Xs)), np.empty(len(Xs))
        for a in range(0, len(Xs), CHUNK_ROWS):
            block = slice(a, a + CHUNK_ROWS)
            D2 = squared_distances(Xs[block], self.X)
            Ks = self.h.signal_mm ** 2 * np.exp(-0.5 * D2 / self.h.length ** 2)
            mean[block] = Ks @ self.alpha
            latent[block] = self.h.signal_mm ** 2 - np.einsum("ij,ij->i", Ks @ self.Kinv, Ks)
            nearest[block] = np.sqrt(D2.min(axis=1)) / self.h.length
        return mean, np.maximum(latent, 0.0), nearest
