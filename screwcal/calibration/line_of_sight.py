"""Can a laser tracker see a reflector (SMR) on the robot's flange? The beam from the tracker's
head to the SMR must be within the tracker's range, within the SMR's acceptance angle of its axis
(where its opening faces), and clear of the robot's links, each approximated by a capsule around
a segment of the robot's skeleton (`kinematics.forward.joint_positions`).

One check serves the emulated tracker (whether it locks on the true robot's SMR) and the planner
(which poses of the nominal robot a tracker would see, with margins for the robot's errors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from screwcal.calibration.posesets import random_configurations
from screwcal.instrument import SMR_ACCEPTANCE_DEG, TRACKER_RANGE_MM
from screwcal.kinematics.forward import forward_kinematics, joint_positions
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, transform_points

DEFAULT_SMR_MM = (30.0, 20.0, 40.0)  # the SMR's centre in tool0 (off the flange's axis)
DEFAULT_SMR_AXIS = (0.0, 0.0, 1.0)  # where its opening faces, in tool0
# three SMRs in nests over the measuring flange's holes (full pose): P1, P2, P3 of
# flange.DEFAULT_HOLES_IN_FLANGE_MM, each centre 20 mm above its hole, all facing tool0's z
THREE_SMRS_MM = ((0.0, -30.0, 40.0), (40.0, 0.0, 40.0), (0.0, 30.0, 40.0))
LINK_RADIUS_MM = (120.0, 110.0, 90.0, 80.0, 60.0, 40.0)  # the capsules, base to flange
SMR_CLEARANCE_MM = 60.0  # the beam's last part, inside the SMR's own nest, is not checked


@dataclass(frozen=True)
class TrackerView:
    """What the tracker can see of the robot, in the world's frame (mm)."""

    smr_mm: Array  # (3,) the SMR's true centre
    smr_axis: Array  # (3,) unit, where its opening faces
    skeleton_mm: Array  # (n + 1, 3) the true robot's skeleton
    base: Array  # (4, 4) the robot's base frame (world <- base): where the tracker stands


def view_from(tool0: Array, skeleton_mm: Array, base: Array,
              smr_mm: tuple[float, float, float] = DEFAULT_SMR_MM,
              smr_axis: tuple[float, float, float] = DEFAULT_SMR_AXIS) -> TrackerView:
    """The view of an SMR at `smr_mm` of tool0 (4, 4), its opening along `smr_axis`."""
    axis = tool0[:3, :3] @ np.asarray(smr_axis, dtype=float)
    return TrackerView(transform_points(tool0, np.asarray(smr_mm, dtype=float)[None])[0],
                       axis / np.linalg.norm(axis), skeleton_mm, base)


def _segment_distance(p0: Array, p1: Array, q0: Array, q1: Array) -> float:
    """The shortest distance between segments p0-p1 and q0-q1."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, f = float(d1 @ d1), float(d2 @ d2), float(d2 @ r)
    c, b = float(d1 @ r), float(d1 @ d2)
    if a < 1e-12 and e < 1e-12:
        return float(np.linalg.norm(r))
    if a < 1e-12:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        if e < 1e-12:
            s, t = min(max(-c / a, 0.0), 1.0), 0.0
        else:
            denom = a * e - b * b
            s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > 1e-12 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                s, t = min(max(-c / a, 0.0), 1.0), 0.0
            elif t > 1.0:
                s, t = min(max((b - c) / a, 0.0), 1.0), 1.0
    return float(np.linalg.norm(p0 + d1 * s - (q0 + d2 * t)))


def beam_blocked(view: TrackerView, station_mm: Array, *,
                 acceptance_deg: float = SMR_ACCEPTANCE_DEG,
                 range_mm: tuple[float, float] = TRACKER_RANGE_MM,
                 link_radius_mm: tuple[float, ...] = LINK_RADIUS_MM) -> str | None:
    """Why the tracker at `station_mm` cannot lock on the SMR, or None when it can."""
    line = station_mm - view.smr_mm
    distance = float(np.linalg.norm(line))
    if not range_mm[0] <= distance <= range_mm[1]:
        return f"out of range ({distance:.0f} mm, the tracker measures {range_mm[0]:.0f}-" \
               f"{range_mm[1]:.0f} mm)"
    toward = line / distance
    angle = math.degrees(math.acos(min(1.0, max(-1.0, float(toward @ view.smr_axis)))))
    if angle > acceptance_deg:
        return f"the reflector faces away ({angle:.0f} deg off its axis, accepts " \
               f"{acceptance_deg:.0f})"
    beam_end = view.smr_mm + toward * SMR_CLEARANCE_MM
    skeleton = view.skeleton_mm
    for k in range(len(skeleton) - 1):
        radius = link_radius_mm[min(k, len(link_radius_mm) - 1)]
        if _segment_distance(station_mm, beam_end, skeleton[k], skeleton[k + 1]) < radius:
            return f"link {k + 1} of the robot breaks the beam"
    return None


def model_views(model: SerialModel, q: Array,
                smr_mm: tuple[float, float, float] = DEFAULT_SMR_MM,
                smr_axis: tuple[float, float, float] = DEFAULT_SMR_AXIS) -> list[TrackerView]:
    """The views of a model's SMR at configurations q (N, n) rad, in the model's world frame
    (its base applied; its tool ignored: the SMR is placed on tool0)."""
    rigid = model.with_frames(tool=np.eye(4))
    T = forward_kinematics(rigid, q)
    skeletons = joint_positions(rigid, q)
    return [view_from(T[k], skeletons[k], model.base, smr_mm, smr_axis) for k in range(len(q))]


def visible(model: SerialModel, q: Array, station_mm: Array, *, acceptance_margin_deg: float = 5.0,
            link_margin_mm: float = 30.0,
            smr_mm: tuple[float, float, float] = DEFAULT_SMR_MM,
            smr_axis: tuple[float, float, float] = DEFAULT_SMR_AXIS) -> np.ndarray:
    """Which configurations q (N, n) rad a tracker at `station_mm` (the model's world frame)
    sees, with margins for the robot's errors: the acceptance angle narrowed, the capsules
    widened. (N,) bool."""
    radius = tuple(r + link_margin_mm for r in LINK_RADIUS_MM)
    return np.array([beam_blocked(v, station_mm,
                                  acceptance_deg=SMR_ACCEPTANCE_DEG - acceptance_margin_deg,
                                  link_radius_mm=radius) is None
                     for v in model_views(model, q, smr_mm, smr_axis)], dtype=bool)


def visible_configurations(model: SerialModel, n: int, station_mm: Array,
                           rng: np.random.Generator,
                           smrs_mm: tuple[tuple[float, float, float], ...] = (DEFAULT_SMR_MM,)
                           ) -> Array:
    """n configurations (rad) uniform in the working region, inside the limits less 5 deg,
    whose SMRs (every one) a tracker at `station_mm` (the model's world frame) sees
    (`visible`). ValueError when the region has too few."""
    kept: list[Array] = []
    for _ in range(200):
        q = random_configurations(4 * n, rng)
        q = q[model.within_limits(q, margin=np.radians(5.0))]
        seen = np.ones(len(q), dtype=bool)
        for smr in smrs_mm:
            seen &= visible(model, q, station_mm, smr_mm=smr)
        kept += list(q[seen])
        if len(kept) >= n:
            return np.array(kept[:n], dtype=float)
    raise ValueError(f"fewer than {n} poses of the working region face a tracker at "
                     f"{np.round(station_mm, 1).tolist()} mm: stand it elsewhere")
