"""The measuring flange (thesis 4.2): a frame from three probed holes, and the flange pose.

Gram-Schmidt on the holes P1, P2, P3 (Eqs. 4.1-4.4): x = (P3 - P1) / |P3 - P1|,
z = x x (P2 - P1) normalised, y = z x x, origin P1. That frame is the measuring flange's (tcp);
the robot's own flange (ef, tool0) follows by Eq. 4.6: T_ef^b = T_tcp^b (T_tcp^ef)^-1, where
T_tcp^ef comes from bench measurements of the measuring flange mounted on a dummy robot flange
(Fig. 33): the holes and three points that fix the ef frame (its origin, a point on its z axis
and a point along its x axis), all in the bench's frame.

Holes that are duplicated, collinear, or whose spacing does not match the flange's (labels
swapped, a wrong feature probed) are refused with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from itertools import permutations

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import FlangeError
from screwcal.kinematics.se3 import Array, invert_transform

# A measuring flange's three holes in the robot flange (tool0) frame, mm: the default layout of
# the emulator and of a robot registered without its own bench data.
DEFAULT_HOLES_IN_FLANGE_MM = ((0.0, -30.0, 20.0), (40.0, 0.0, 20.0), (0.0, 30.0, 20.0))
MIN_SEPARATION_MM = 1.0
MIN_ANGLE_DEG = 5.0  # smallest angle at P1 between P1->P2 and P1->P3 for a usable frame
_PAIRS = ((0, 1), (0, 2), (1, 2))


def _as_points(points: ArrayLike) -> Array:
    p = np.asarray(points, dtype=float)
    if p.ndim == 2:
        p = p[None]
    if p.ndim != 3 or p.shape[1:] != (3, 3):
        raise FlangeError(f"holes must be given as (N, 3, 3) [pose, hole P1..P3, xyz]; got "
                          f"{np.shape(points)}")
    if not np.all(np.isfinite(p)):
        raise FlangeError("hole coordinates must be finite numbers")
    return p


def hole_distances(points: ArrayLike) -> Array:
    """|P1P2|, |P1P3|, |P2P3| per pose, (N, 3)."""
    p = _as_points(points)
    return np.stack([np.linalg.norm(p[:, a] - p[:, b], axis=1) for a, b in _PAIRS], axis=1)


def check_holes(points: ArrayLike, nominal_distances_mm: ArrayLike | None = None,
                tol_mm: float = 0.5) -> None:
    """Refuse duplicated or collinear holes, and holes whose spacing is not the flange's."""
    p = _as_points(points)
    d = hole_distances(p)
    for k in range(len(p)):
        for (a, b), dist in zip(_PAIRS, d[k], strict=True):
            if dist < MIN_SEPARATION_MM:
                raise FlangeError(f"pose {k}: P{a + 1} and P{b + 1} are {dist:.3f} mm apart: "
                                  "the same hole was probed twice")
        u, v = p[k, 1] - p[k, 0], p[k, 2] - p[k, 0]
        sin = float(np.linalg.norm(np.cross(u, v)) / (np.linalg.norm(u) * np.linalg.norm(v)))
        if sin < np.sin(np.radians(MIN_ANGLE_DEG)):
            raise FlangeError(f"pose {k}: the holes are collinear (angle at P1 "
                              f"{np.degrees(np.arcsin(min(sin, 1.0))):.2f} deg): no frame")
    if nominal_distances_mm is None:
        return
    nominal = np.asarray(nominal_distances_mm, dtype=float)
    for k in range(len(p)):
        err = np.abs(d[k] - nominal).max()
        if err <= tol_mm:
            continue
        for perm in permutations(range(3)):
            if perm == (0, 1, 2):
                continue
            if np.abs(hole_distances(p[k][list(perm)])[0] - nominal).max() <= tol_mm:
                labels = ", ".join(f"P{i + 1} looks like P{perm.index(i) + 1}" for i in range(3)
                                   if perm[i] != i)
                raise FlangeError(f"pose {k}: hole labels look swapped ({labels})")
        raise FlangeError(f"pose {k}: hole spacing {np.round(d[k], 3).tolist()} mm does not "
                          f"match the flange's {nominal.tolist()} mm (off by {err:.3f} mm)")


def frame_from_holes(points: ArrayLike) -> Array:
    """Frames (N, 4, 4) from holes (N, 3, 3) by Gram-Schmidt, Eqs. 4.1-4.4 (no checks)."""
    p = _as_points(points)
    x = p[:, 2] - p[:, 0]  # Eq. 4.1
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = np.cross(x, p[:, 1] - p[:, 0])  # Eq. 4.2
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    y = np.cross(z, x)  # Eq. 4.3
    T = np.zeros((len(p), 4, 4))
    T[:, :3, 0], T[:, :3, 1], T[:, :3, 2], T[:, :3, 3] = x, y, z, p[:, 0]  # Eq. 4.4
    T[:, 3, 3] = 1.0
    return T


@dataclass(frozen=True)
class MeasuringFlange:
    """The measuring flange: its holes' spacing and T_tcp^ef, from bench measurements."""

    tcp_in_ef: Array  # (4, 4) T_tcp^ef
    hole_distances_mm: Array  # (3,) |P1P2|, |P1P3|, |P2P3|

    @classmethod
    def from_bench(cls, holes_mm: ArrayLike, ef_origin_mm: ArrayLike, ef_z_point_mm: ArrayLike,
                   ef_x_point_mm: ArrayLike) -> MeasuringFlange:
        """Fig. 33: the holes and three points of the ef frame, all in the bench frame."""
        holes = _as_points(holes_mm)
        check_holes(holes)
        o, zp, xp = (np.asarray(v, dtype=float) for v in (ef_origin_mm, ef_z_point_mm,
                                                          ef_x_point_mm))
        z = zp - o
        if np.linalg.norm(z) < MIN_SEPARATION_MM:
            raise FlangeError("the ef z-axis point coincides with the ef origin")
        z /= np.linalg.norm(z)
        x = (xp - o) - np.dot(xp - o, z) * z
        if np.linalg.norm(x) < MIN_SEPARATION_MM:
            raise FlangeError("the ef x-axis point lies on the ef z axis")
        x /= np.linalg.norm(x)
        ef = np.eye(4)
        ef[:3, 0], ef[:3, 1], ef[:3, 2], ef[:3, 3] = x, np.cross(z, x), z, o
        tcp = frame_from_holes(holes)[0]
        return cls(invert_transform(ef) @ tcp, hole_distances(holes)[0])

    @classmethod
    def from_holes_in_flange(cls, holes_mm: ArrayLike) -> MeasuringFlange:
        """When the holes' positions in the robot flange (tool0) frame are known (a drawing, or
        a bench measurement already expressed in that frame)."""
        holes = _as_points(holes_mm)
        check_holes(holes)
        return cls(frame_from_holes(holes)[0], hole_distances(holes)[0])

    @cached_property
    def ef_in_tcp(self) -> Array:
        """(T_tcp^ef)^-1, once per flange: the service applies it to every probed pose."""
        return invert_transform(self.tcp_in_ef)

    def flange_poses(self, holes_mm: ArrayLike, tol_mm: float = 0.5) -> Array:
        """T_ef^b (N, 4, 4) from probed holes (N, 3, 3) in the measuring frame, Eq. 4.6."""
        holes = _as_points(holes_mm)
        check_holes(holes, self.hole_distances_mm, tol_mm)
        poses: Array = frame_from_holes(holes) @ self.ef_in_tcp
        return poses
