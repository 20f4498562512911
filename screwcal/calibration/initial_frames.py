"""Initial guesses of the unknown frames: the measuring system's frame (base) and the measured
point's offset from the flange (tool), from nominal kinematics and measured positions.

Alternates a Kabsch fit of the base (the rotation nearest the points' cross-covariance) with the
linear least-squares tool offset, which converges in a few rounds when the robot's own errors are
small next to the frames' (as they are: millimetres against metres).
"""

from __future__ import annotations

import numpy as np

from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, transform_from_rotation_translation


def _nearest_rotation(M: Array) -> Array:
    """The rotation nearest a 3x3 matrix (Frobenius): the chordal mean of rotations when M is
    their average."""
    U, _, Vt = np.linalg.svd(M)
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt


def _kabsch(a: Array, b: Array) -> Array:
    """The rotation R minimising sum |a_i - R b_i|^2 for centred point sets (N, 3) (Kabsch)."""
    return _nearest_rotation(a.T @ b)


def rigid_motion(src: Array, dst: Array) -> tuple[Array, Array]:
    """(R, t) of the rigid motion that best lays the points src (N, 3) on dst (N, 3):
    minimises sum |dst_i - (R src_i + t)|^2 (Kabsch)."""
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    R = _kabsch(dst - cd, src - cs)
    return R, cd - R @ cs


def align_frames(model: SerialModel, q: Array, positions_mm: Array, rotations: Array | None = None,
                 *, fit_tool: bool = True, rounds: int = 20, base: Array | None = None
                 ) -> tuple[Array, Array]:
    """(base (4, 4), tool (4, 4)) so that base . flange(q) . tool best matches the measured
    points; with rotations (full pose) the tool's rotation is fitted too. A given `base` (from
    the thesis's alignment, `base_alignment`) is kept and only the tool is fitted."""
    F = flange_kinematics(model, q)
    R_f, p_f = F[:, :3, :3], F[:, :3, 3]
    t_tool = np.zeros(3) if fit_tool else model.tool[:3, 3].copy()
    R_b, t_b = np.eye(3), np.zeros(3)
    if base is not None:
        R_b, t_b = base[:3, :3], base[:3, 3]
    tool_solver = np.linalg.pinv(R_f.reshape(-1, 3))  # the same system every round
    for _ in range(rounds):
        if base is None:
            R_b, t_b = rigid_motion(p_f + R_f @ t_tool, positions_mm)
        if not fit_tool:
            break
        # measured = R_b (p_f + R_f t) + t_b  ->  R_f t = R_b^T (measured - t_b) - p_f
        rhs = (positions_mm - t_b) @ R_b - p_f
        new = tool_solver @ rhs.reshape(-1)
        if np.linalg.norm(new - t_tool) < 1e-4:  # mm: a starting guess, the solver refines
            t_tool = new
            break
        t_tool = new
    if not fit_tool:
        return transform_from_rotation_translation(R_b, t_b), model.tool
    R_tool = np.eye(3)
    if rotations is not None:
        # R_meas = R_b R_f R_tool: average R_tool over poses.
        R_tool = _nearest_rotation((np.swapaxes(R_f, 1, 2) @ R_b.T @ rotations).mean(axis=0))
    return (transform_from_rotation_translation(R_b, t_b),
            transform_from_rotation_translation(R_tool, t_tool))
