"""Pose-set design (thesis 2.2.4, future work 6.2): choose N configurations from a candidate pool
that maximise D-optimality, log det(J^T S^-1 J), of the identification Jacobian, by a greedy pass
then exchanges (Fedorov). The determinant lemma scores every candidate at once:
log det(A + J_k^T J_k) = log det(A) + log det(I + J_k A^-1 J_k^T).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from screwcal.calibration.error_parameters import ErrorModel, ModelKind, candidate_params
from screwcal.instrument import ORIENTATION_NOISE_RAD, POSITION_NOISE_MM
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array


@dataclass(frozen=True)
class Design:
    q_rad: Array  # (N, n) the chosen configurations
    log_det: float
    exchanges: int


def whitened_blocks(model: SerialModel, q_rad: Array, sigma_mm: float = POSITION_NOISE_MM,
                    sigma_rad: float = ORIENTATION_NOISE_RAD, kind: ModelKind = "thesis"
                    ) -> Array:
    """Per configuration, the (6, p) Jacobian of the error model, each row over its sigma."""
    errors = ErrorModel(model, tuple(candidate_params(model, kind, base=False,
                                                      tool_rotation=False,
                                                      tool_position=False)))
    _, J, _ = errors.linearisation(np.zeros(len(errors.params)), q_rad)
    return J / np.r_[[sigma_mm] * 3, [sigma_rad] * 3][None, :, None]


def _gains(blocks: Array, A_inv: NDArray[np.floating]) -> Array:
    M = np.einsum("kip,pq,kjq->kij", blocks, A_inv, blocks)
    return np.linalg.slogdet(np.eye(blocks.shape[1]) + M)[1]


def d_optimal(model: SerialModel, pool_rad: Array, n: int, *, exchange_passes: int = 2,
              kind: ModelKind = "thesis") -> Design:
    """N configurations of the pool for the largest log det of the information matrix."""
    blocks = whitened_blocks(model, pool_rad, kind=kind)
    p = blocks.shape[2]
    ridge = 1e-6 * np.eye(p)
    chosen: list[int] = []
    A = ridge.copy()
    for _ in range(n):
        gains = _gains(blocks, np.linalg.inv(A))
        gains[chosen] = -np.inf
        k = int(np.argmax(gains))
        chosen.append(k)
        A += blocks[k].T @ blocks[k]
    exchanges = 0
    for _ in range(exchange_passes):
        improved = False
        for slot in range(n):
            out = chosen[slot]
            A_minus = A - blocks[out].T @ blocks[out]
            gains = _gains(blocks, np.linalg.inv(A_minus))
            gains[chosen] = -np.inf
            k = int(np.argmax(gains))
            if gains[k] > _gains(blocks[out:out + 1], np.linalg.inv(A_minus))[0] + 1e-9:
                chosen[slot] = k
                A = A_minus + blocks[k].T @ blocks[k]
                exchanges += 1
                improved = True
        if not improved:
            break
    return Design(pool_rad[chosen], float(np.linalg.slogdet(A)[1]), exchanges)


def log_det(model: SerialModel, q_rad: Array, kind: ModelKind = "thesis") -> float:
    blocks = whitened_blocks(model, q_rad, kind=kind)
    A = np.einsum("kip,kiq->pq", blocks, blocks) + 1e-6 * np.eye(blocks.shape[2])
    return float(np.linalg.slogdet(A)[1])
