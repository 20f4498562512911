"""Lost motion (backlash) per joint, from poses measured twice, approached from opposite sides.

A joint with lost motion b_j stops b_j / 2 short of its target on the side it came from: its
link stands at q_j - d_j b_j / 2, d_j the sign of the joint's last move (the emulated robot's
definition, `simulators.realism`). One commanded pose measured after an approach from below
(d = +1) and again after one from above (d = -1) therefore differs, to first order, by

    delta = T_B (-) T_A = J(q) (s * b),   s_j = (d_A,j - d_B,j) / 2               (Eq. B.1)

with J the flange's point Jacobian at q (rows dx, dy, dz in mm and the rotation vector in rad
per rad of joint, `kinematics.forward.point_jacobian`) and (-) the difference of the two
measurements' residuals against the calibrated model (so what the model explains, such as read
joints that differ, cancels). Stacked over the pairs, b is the weighted least-squares solution of
Eq. B.1; its covariance is (A^T W A)^-1 scaled by the pairs' reduced chi-square (Eq. B.2), so the
uncertainty is what the pairs themselves show, whatever noise levels were assumed.

Pure functions over numpy arrays: how pairs were approached is the caller's (the service's
calibration list, `service/plans.py`), or the measurement file's optional direction columns
dir1..dirn (`MeasurementSet.directions`; `direction_pairs`, `backlash_of_measurements`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from screwcal.calibration.lag import correct_lag
from screwcal.errors import InputError
from screwcal.kinematics.forward import forward_kinematics, point_jacobian, spatial_jacobian
from screwcal.kinematics.ik import pose_error
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

if TYPE_CHECKING:
    from screwcal.calibration.identify_result import CalibrationResult
    from screwcal.calibration.measurements import MeasurementSet

# What the compensation can and cannot do about lost motion, said in every result that shows it.
COMPENSATION_NOTE = (
    "lost motion is not a geometric error: the calibrated model and its compensated targets "
    "cannot remove it, because where a joint stops depends on the side it came from, not on "
    "the target. Target corrections can take it out only when every target is approached from "
    "one fixed direction (then half the lost motion is a constant offset per joint that the "
    "compensation absorbs); with free approach directions it stays in the robot as up to "
    "+-b/2 per joint")


@dataclass(frozen=True)
class BacklashEstimate:
    """Lost motion per joint (deg) with its standard error; NaN where no pair flipped a joint
    or the pairs cannot separate it from the others (`identifiable` False)."""

    backlash_deg: Array  # (n,)
    std_deg: Array  # (n,)
    identifiable: Array  # (n,) bool
    pairs: int
    chi2_reduced: float

    def to_dict(self) -> dict[str, Any]:
        joints = [{"joint": f"J{j + 1}",
                   "backlash_deg": float(v) if ok else None,
                   "std_deg": float(s) if ok else None, "identified": bool(ok)}
                  for j, (v, s, ok) in enumerate(zip(self.backlash_deg, self.std_deg,
                                                     self.identifiable, strict=True))]
        return {"joints": joints, "pairs": self.pairs, "chi2_reduced": self.chi2_reduced,
                "meaning": "lost motion per joint: the difference between where the joint "
                           "stops approached from below and from above (deg), from pairs of "
                           "measurements of one commanded pose approached from opposite "
                           "sides, least squares through the joint Jacobian (Eq. B.1)",
                "compensation": COMPENSATION_NOTE}


def pose_residuals(model: SerialModel, q_rad: ArrayLike, T_measured: ArrayLike) -> Array:
    """(N, 6) measured minus predicted flange: position (mm) and the rotation vector (rad) of
    R_measured R_predicted^T, the model's frames included."""
    residuals: Array = pose_error(np.asarray(T_measured, dtype=float),
                                  forward_kinematics(model, q_rad))
    return residuals


def pair_jacobians(model: SerialModel, q_rad: ArrayLike) -> Array:
    """(N, 6, n) the flange's point Jacobian at each pair's commanded joints (mm, rad / rad)."""
    q = np.atleast_2d(np.asarray(q_rad, dtype=float))
    return point_jacobian(spatial_jacobian(model, q), forward_kinematics(model, q))


def estimate_backlash(jacobians: ArrayLike, delta: ArrayLike, flipped: ArrayLike,
                      sigma_mm: float = 0.02, sigma_rad: float = 2e-4) -> BacklashEstimate:
    """Eq. B.1 solved over the pairs. `jacobians` (N, 6, n) at each pair's joints; `delta`
    (N, 6) the second measurement's residual minus the first's (position mm, rotation vector
    rad), or (N, 3) positions only; `flipped` (N, n) s_j = (d_A - d_B) / 2: +1 where the joint
    came from below first and from above second, -1 the other way, 0 where both came from one
    side. `sigma_mm`, `sigma_rad`: the noise of one measurement, which only weighs position
    against rotation (Eq. B.2 rescales by the misfit)."""
    J = np.asarray(jacobians, dtype=float)
    d = np.asarray(delta, dtype=float)
    s = np.asarray(flipped, dtype=float)
    if J.ndim != 3 or J.shape[1] != 6 or d.ndim != 2 or d.shape[1] not in (3, 6) \
            or s.shape != (J.shape[0], J.shape[2]) or d.shape[0] != J.shape[0]:
        raise InputError(f"backlash pairs: jacobians (N, 6, n), delta (N, 3 or 6) and flipped "
                         f"(N, n); got {J.shape}, {d.shape} and {s.shape}")
    if not np.all(np.isfinite(d)) or not np.all(np.isfinite(J)):
        raise InputError("backlash pairs: the differences and Jacobians must be finite")
    rows = d.shape[1]
    sigma = np.array([sigma_mm] * 3 + [sigma_rad] * 3)[:rows]
    A = (J[:, :rows, :] * s[:, None, :]) / sigma[None, :, None]  # (N, rows, n), Eq. B.1
    y = d / sigma[None, :]
    A2, y2 = A.reshape(-1, A.shape[2]), y.reshape(-1)
    n = A2.shape[1]
    used = np.any(s != 0, axis=0)
    out = np.full(n, np.nan)
    std = np.full(n, np.nan)
    ok = np.zeros(n, dtype=bool)
    cols = np.flatnonzero(used)
    chi2 = float("nan")
    if len(cols):
        U, sv, Vt = np.linalg.svd(A2[:, cols], full_matrices=False)
        good = sv > sv[0] * 1e-8
        if np.all(good) and A2.shape[0] > len(cols):
            x = Vt.T @ ((U.T @ y2) / sv)
            dof = A2.shape[0] - len(cols)
            chi2 = float(np.sum((y2 - A2[:, cols] @ x) ** 2) / dof)
            cov = (Vt.T / sv**2) @ Vt * max(chi2, 0.0)  # Eq. B.2
            out[cols], std[cols] = x, np.sqrt(np.diag(cov))
            ok[cols] = True
    return BacklashEstimate(np.degrees(out), np.degrees(std), ok, int(J.shape[0]), chi2)


def backlash_from_pairs(model: SerialModel, q_a_rad: ArrayLike, q_b_rad: ArrayLike,
                        T_a: ArrayLike, T_b: ArrayLike, flipped: ArrayLike,
                        position_only: bool = False, sigma_mm: float = 0.02,
                        sigma_rad: float = 2e-4) -> BacklashEstimate:
    """Backlash from pairs of measured flanges T_a, T_b (N, 4, 4), the model's frame, of one
    commanded pose each, read at joints q_a_rad, q_b_rad (N, n): their residual difference
    against the calibrated `model` (Eq. B.1), the Jacobian at the pair's mean joints."""
    q_a, q_b = np.atleast_2d(q_a_rad), np.atleast_2d(q_b_rad)
    delta = pose_residuals(model, q_b, T_b) - pose_residuals(model, q_a, T_a)
    if position_only:
        delta = delta[:, :3]
    return estimate_backlash(pair_jacobians(model, (q_a + q_b) / 2.0), delta, flipped,
                             sigma_mm, sigma_rad)


SAME_POSE_DEG = 0.01  # two rows whose joints all agree this closely: one commanded pose


def direction_pairs(q_deg: ArrayLike, directions: ArrayLike,
                    same_pose_deg: float = SAME_POSE_DEG) -> tuple[Array, Array, Array]:
    """Pairs of rows measuring one commanded pose from opposite sides: rows i < j whose joints
    (N, n) deg agree within `same_pose_deg` and whose approach directions (N, n) (the sign of
    each joint's last move: +1 from below, -1 from above, 0 unknown) differ on some joint.
    Returns the first rows (P,), the second rows (P,) and flipped s (P, n) (Eq. B.1); each row
    in one pair at most, taken in the file's order."""
    q = np.asarray(q_deg, dtype=float)
    d = np.asarray(directions, dtype=float)
    if d.shape != q.shape or not np.all(np.isin(d, (-1.0, 0.0, 1.0))):
        raise InputError(f"approach directions: one of -1, 0, +1 per joint and row, shaped as "
                         f"the joints {q.shape}; got {d.shape}")
    close = np.all(np.abs(q[:, None, :] - q[None, :, :]) <= same_pose_deg, axis=2)
    flips = (d[:, None, :] - d[None, :, :]) / 2.0  # (N, N, n)
    known = (d[:, None, :] != 0) & (d[None, :, :] != 0)
    flips = np.where(known, flips, 0.0)
    candidate = np.triu(close & np.any(flips != 0, axis=2), k=1)
    first, second, used = [], [], np.zeros(len(q), dtype=bool)
    for i, j in zip(*np.nonzero(candidate), strict=True):
        if not (used[i] or used[j]):
            first.append(int(i))
            second.append(int(j))
            used[[i, j]] = True
    a, b = np.array(first, dtype=int), np.array(second, dtype=int)
    return a, b, flips[a, b] if len(a) else np.zeros((0, q.shape[1]))


def backlash_of_measurements(result: CalibrationResult, data: MeasurementSet
                             ) -> dict[str, Any] | None:
    """Lost motion per joint when the measurements `data` carry their approach directions
    (the file's optional dir1..dirn) and poses measured from both sides (`direction_pairs`),
    against the calibrated model (its readings corrected for the lag it found, `calibration.lag`);
    None otherwise."""
    if data.directions is None:
        return None
    a, b, flipped = direction_pairs(np.degrees(data.q), data.directions)
    if len(a) < 2:
        return None
    q = data.q if result.reading_lag is None else correct_lag(data, result.reading_lag).q
    T = forward_kinematics(result.model, q)  # the orientation where only positions are measured
    T[:, :3, 3] = data.positions_mm
    if data.rotations is not None:
        T[:, :3, :3] = data.rotations
    return backlash_from_pairs(result.model, q[a], q[b], T[a], T[b], flipped,
                               position_only=data.rotations is None).to_dict()
