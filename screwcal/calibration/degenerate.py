"""Degenerate data, named before the fit: what in the poses leaves parameters free or poorly
determined, which, and what data would do.

- The measured point on (or near) the last joint's axis with position-only data: the last
  joint's zero and the tilts of its axis move no measured point; the model then predicts
  positions, not the orientation.
- The measured points in one plane.
- A joint whose readings span too narrow a range for its axis to be located.
- Too few poses for the parameters (refused outright below one equation per parameter, by the
  identification itself; warned below THREE equations per parameter).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from screwcal.calibration.measurements import MeasurementSet
from screwcal.kinematics.forward import forward_kinematics, spatial_jacobian
from screwcal.kinematics.model import SerialModel

# The measured point this close to the last axis is on it: positions then see neither the
# axis' tilt nor its zero (the starting alignment places a point on the axis a few mm off it)
NEAR_AXIS_MM = 10.0
OFF_AXIS_MM = 50.0  # what to ask for instead (the thesis's holes: 25-90 mm)
FLAT_RATIO = 0.05  # the points' thinnest spread under this share of their widest: one plane
MIN_JOINT_RANGE_DEG = 30.0  # a joint's readings spanning less leave its axis poorly placed
GOOD_JOINT_RANGE_DEG = 90.0  # what to ask for instead
EQUATIONS_PER_PARAMETER = 3.0


def point_axis_distance_mm(model: SerialModel) -> float:
    """Distance (mm) of the measured point (the model's tool origin) from the last joint's
    axis, at the zero configuration (it does not depend on the joints)."""
    n = model.n_joints
    if model.joint_types[n - 1] != "R":
        return float("inf")
    q = np.zeros((1, n))
    J = spatial_jacobian(model, q)[0]
    w, v = J[:3, n - 1], J[3:, n - 1]
    on_axis = np.cross(w, v) / (w @ w)
    point = forward_kinematics(model, q)[0, :3, 3]
    return float(np.linalg.norm(np.cross(point - on_axis, w)) / np.linalg.norm(w))


def data_warnings(start: SerialModel, data: MeasurementSet, residual: str, n_rows: int,
                  n_parameters: int, removed: Sequence[str]) -> list[str]:
    """What in these data leaves parameters free or poorly determined (a sentence each, with
    what would do); `start` is the model with the starting frames, `removed` the parameters
    the rank analysis could not identify."""
    out = []
    n = start.n_joints
    if residual != "pose":
        d = point_axis_distance_mm(start)
        if d < NEAR_AXIS_MM:
            free = [r for r in removed if r.startswith(f"J{n}") and not r[len(f"J{n}"):][:1]
                    .isdigit()] or [f"J{n}"]
            out.append(
                f"degenerate data: the measured point is {d:.1f} mm from joint {n}'s axis (as "
                "the starting alignment places it) and "
                f"the data are positions only: {', '.join(free)} cannot be told from them "
                "(held at nominal), so the model predicts positions, not the orientation; "
                f"measure a point at least {OFF_AXIS_MM:g} mm off the axis, or full poses")
    p = data.positions_mm - data.positions_mm.mean(axis=0)
    s = np.linalg.svd(p, compute_uv=False) if len(p) >= 3 else np.zeros(3)
    if len(p) >= 3 and s[0] > 0 and s[-1] < FLAT_RATIO * s[0]:
        scale = np.sqrt(len(p))
        out.append(f"degenerate data: the measured points lie nearly in one plane "
                   f"({s[-1] / scale:.1f} mm RMS off it, {s[0] / scale:.0f} mm across it): "
                   "parameters that move "
                   "the point across it are poorly determined; spread the poses out of that "
                   "plane")
    q_deg = np.degrees(data.q[:, start.is_revolute])
    joints = np.flatnonzero(start.is_revolute)
    span = np.ptp(q_deg, axis=0) if len(q_deg) else np.zeros(len(joints))
    narrow = [f"J{j + 1} {r:.1f} deg" for j, r in zip(joints, span, strict=True)
              if r < MIN_JOINT_RANGE_DEG and not (residual != "pose" and j == n - 1)]
    if narrow:
        out.append(f"degenerate data: joint readings span too narrow a range to locate those "
                   f"axes ({', '.join(narrow)}): their tilts and shifts are poorly determined; "
                   f"spread each over at least {GOOD_JOINT_RANGE_DEG:g} deg")
    if n_rows < EQUATIONS_PER_PARAMETER * n_parameters:
        per_pose = 6 if residual == "pose" else 3 if residual == "position" else None
        more = (f"; {int(np.ceil(EQUATIONS_PER_PARAMETER * n_parameters / per_pose))} poses "
                "would" if per_pose else "; more poses would")
        out.append(f"few poses for the model: {len(data)} poses give {n_rows} equations for "
                   f"{n_parameters} parameters (less than {EQUATIONS_PER_PARAMETER:g} per "
                   f"parameter){more}")
    return out
