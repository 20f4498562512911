"""The errors the thesis reports for a set of configurations, computed as the thesis computes them.

- T_PO (Eq. 2.5 applied over a set, Tables 4-10): the per-axis means of |error|, then
  sqrt(eps_x^2 + eps_y^2 + eps_z^2). Table 4: sqrt(0.193^2 + 0.339^2) = 0.390; Table 5 agrees.
- TOr_i, TOr_j, TOr_k (Eq. 2.9): the mean |difference| of the Euler angles (rx, ry, rz) of the
  flange, R = Rz(rz) Ry(ry) Rx(rx), each difference wrapped to (-180, 180] deg. "Norma" (Table
  10) is sqrt(TOr_i^2 + TOr_j^2 + TOr_k^2).
- The thesis's "after" figures carry the random joint error (uniform +-0.05 deg, Table 2): the
  corrected model at the reported joints against the true robot at the joints it really took.
  `joint_error` draws it; without it the comparison is model against truth.

Ours, kept beside them: `norm_mm`, the mean over poses of the position error's length, and
`rot_deg`, the mean angle of the rotation error (both invariant to the frame's axes).
"""

from __future__ import annotations

import numpy as np

from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, rotation_angle_deg
from screwcal.kinematics.se3 import Array
from screwcal.studies.simulated_measurements import JOINT_NOISE_DEG


def joint_error(model: SerialModel, q: Array, rng: np.random.Generator,
                half_width_deg: float = JOINT_NOISE_DEG) -> Array:
    """The random joint error (rad), uniform +-half_width on every revolute joint (Table 2)."""
    return np.radians(rng.uniform(-half_width_deg, half_width_deg, q.shape)) * model.is_revolute


def euler_difference_deg(R_model: Array, R_true: Array) -> Array:
    """(N, 3) differences of the Euler angles (rx, ry, rz), wrapped to (-180, 180] deg."""
    d = euler_zyx_deg_from_rotation(R_model) - euler_zyx_deg_from_rotation(R_true)
    return -((-d + 180.0) % 360.0 - 180.0)


def set_errors(T_model: Array, T_true: Array) -> dict[str, float]:
    """The thesis's figures (and ours) for model poses against true poses, (N, 4, 4) each."""
    e = np.abs(T_model[:, :3, 3] - T_true[:, :3, 3]).mean(axis=0)  # eps_x, eps_y, eps_z
    tor = np.abs(euler_difference_deg(T_model[:, :3, :3], T_true[:, :3, :3])).mean(axis=0)
    return {"tpo_mm": float(np.linalg.norm(e)),  # Eq. 2.5 over the set (Table 4)
            "ex_mm": float(e[0]), "ey_mm": float(e[1]), "ez_mm": float(e[2]),
            "tor_i": float(tor[0]), "tor_j": float(tor[1]), "tor_k": float(tor[2]),  # Eq. 2.9
            "tor_norm": float(np.linalg.norm(tor)),  # Table 10's "Norma"
            "norm_mm": float(np.linalg.norm(T_model[:, :3, 3] - T_true[:, :3, 3],
                                            axis=1).mean()),
            "rot_deg": float(rotation_angle_deg(T_model[:, :3, :3], T_true[:, :3, :3]).mean())}


def pose_errors(model: SerialModel, truth: SerialModel, q: Array,
                joint_error_rad: Array | None = None) -> dict[str, float]:
    """`set_errors` of `model` at the reported joints q against `truth` at q plus the joint
    error (none: at q)."""
    q_true = q if joint_error_rad is None else q + joint_error_rad
    return set_errors(forward_kinematics(model, q), forward_kinematics(truth, q_true))


Row = dict[str, float | str]
EXACT_KEYS = ("tpo_mm", "tor_i", "tor_j", "tor_k", "tor_norm")


def scored(model: SerialModel, truth: SerialModel, q: Array, rng: np.random.Generator,
           prefix: str = "") -> Row:
    """The thesis's figures for `model` against `truth` at q: with the random joint error in the
    evaluation, as the thesis's are (`tpo_mm`, `tor_i`, ...), without it (`..._exact`), the
    floor the joint error alone sets (`floor_...`: the truth against itself), plus ours
    (`norm_mm`, `rot_deg`)."""
    dq = joint_error(truth, q, rng)
    noisy = pose_errors(model, truth, q, dq)
    exact = pose_errors(model, truth, q)
    floor = pose_errors(truth, truth, q, dq)  # the joint error alone: no model removes it
    row: Row = {**noisy, **{f"{k}_exact": exact[k] for k in EXACT_KEYS},
                **{f"floor_{k}": floor[k] for k in EXACT_KEYS}}
    return {prefix + k: v for k, v in row.items()}
