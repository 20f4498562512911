"""Straightness of a measured straight-line path (thesis 2.3.2; ISO 12780-1, least-squares
reference line).

The reference line is the 3-D least-squares line: through the centroid, along the first principal
direction. Each point's deviation from it is a vector normal to the line, given in two signed
components: along the second principal direction (u, the direction in which the path deviates
most) and the third (w). The straightness deviation reported by the thesis (peak + valley of the
signed deviations in a plane) is `peak_to_valley_mm` = max(u) - min(u), in the plane of the line
and u; the 3-D figure `cylinder_diameter_mm` = 2 max sqrt(u^2 + w^2) is the diameter of the
least-squares-axis cylinder that holds every point.

Worked example (a zig-zag in the xy-plane)::

    >>> import numpy as np
    >>> pts = np.array([[0, 0, 0], [1, 0.1, 0], [2, -0.1, 0], [3, 0.1, 0], [4, 0, 0]], float)
    >>> s = straightness(pts)
    >>> round(s.peak_to_valley_mm, 4)
    0.2
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import InputError
from screwcal.kinematics.se3 import Array


@dataclass(frozen=True)
class Straightness:
    centroid_mm: Array  # (3,)
    direction: Array  # (3,) unit, along the path from its first point to its last
    normal_u: Array  # (3,) unit, the direction of the signed deviations
    along_mm: Array  # (n,) position of each point's foot along the line
    deviation_u_mm: Array  # (n,) signed deviation along normal_u
    deviation_w_mm: Array  # (n,) signed deviation along direction x normal_u
    peak_mm: float  # max(u) >= 0
    valley_mm: float  # -min(u) >= 0
    peak_to_valley_mm: float  # peak + valley
    cylinder_diameter_mm: float

    def to_dict(self) -> dict:
        return {
            "centroid_mm": self.centroid_mm.tolist(), "direction": self.direction.tolist(),
            "normal_u": self.normal_u.tolist(), "along_mm": self.along_mm.tolist(),
            "deviation_u_mm": self.deviation_u_mm.tolist(),
            "deviation_w_mm": self.deviation_w_mm.tolist(), "peak_mm": self.peak_mm,
            "valley_mm": self.valley_mm, "peak_to_valley_mm": self.peak_to_valley_mm,
            "cylinder_diameter_mm": self.cylinder_diameter_mm,
        }


def straightness(points_mm: ArrayLike) -> Straightness:
    """Least-squares straightness of measured points (n >= 3, (n, 3)) along a straight path."""
    p = np.asarray(points_mm, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"straightness needs points of shape (n, 3); got {p.shape}")
    if len(p) < 3:
        raise InputError(f"straightness needs at least 3 points; got {len(p)}")
    if not np.all(np.isfinite(p)):
        raise InputError("straightness: every coordinate must be a finite number")
    c = p.mean(axis=0)
    _, s, Vt = np.linalg.svd(p - c, full_matrices=False)
    if s[0] <= 1e-9 * max(1.0, np.abs(p).max()):
        raise InputError("straightness: the points coincide; there is no line to fit")
    d, u = Vt[0], Vt[1]
    if np.dot(p[-1] - p[0], d) < 0:
        d = -d
    w = np.cross(d, u)
    rel = p - c
    dev_u, dev_w = rel @ u, rel @ w
    if dev_u.max() < -dev_u.min():  # orient u towards the larger excursion for readability
        u, w, dev_u, dev_w = -u, -w, -dev_u, -dev_w
    peak, valley = float(max(dev_u.max(), 0.0)), float(max(-dev_u.min(), 0.0))
    return Straightness(centroid_mm=c, direction=d, normal_u=u, along_mm=rel @ d,
                        deviation_u_mm=dev_u, deviation_w_mm=dev_w, peak_mm=peak,
                        valley_mm=valley, peak_to_valley_mm=peak + valley,
                        cylinder_diameter_mm=float(2 * np.sqrt(dev_u**2 + dev_w**2).max()))
