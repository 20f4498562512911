"""The thesis's base alignment of the measuring system (4.6, Fig. 40), for users who align by
hand, and as a starting guess for the solver.

A point on the robot is probed while joint 1 alone turns, then while joint 2 alone turns (with
joint 1 at `q1_during_j2_deg`). A circle fitted to each sweep gives the joint's axis (its normal,
oriented by the sense of the turn, and its centre). The common normal of the two axes meets axis
1 at a point; moving along axis 1 by the model's nominal distance from the base origin to that
point gives the origin. z is axis 1; x is the common normal's direction (from axis 1 to axis 2)
turned back by the joint-1 angle of the second sweep; the model's nominal geometry fixes what
these are in the robot base frame. The thesis notes that the link and joint offsets then enter
the alignment: the solver refines it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from screwcal.errors import AlignmentError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array, invert_transform


@dataclass(frozen=True)
class Circle:
    centre_mm: Array
    normal: Array  # unit, oriented by the sense of travel (right-hand rule)
    radius_mm: float
    rms_mm: float  # RMS distance of the points from the fitted circle


def fit_circle(points_mm: ArrayLike) -> Circle:
    """Least-squares circle in 3-D of points listed in the order they were probed (n >= 4):
    plane by SVD, algebraic (Kasa) circle in the plane, then a geometric refinement."""
    p = np.asarray(points_mm, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 4:
        raise AlignmentError(f"a circle fit needs at least 4 points (n, 3); got {p.shape}")
    c0 = p.mean(axis=0)
    _, s, Vt = np.linalg.svd(p - c0)
    if s[1] < 1e-6 * max(s[0], 1e-12):
        raise AlignmentError("the sweep points are collinear: turn the joint further")
    u, v, n = Vt
    xy = np.column_stack([(p - c0) @ u, (p - c0) @ v])
    A = np.column_stack([2 * xy, np.ones(len(p))])
    (a, b, k), *_ = np.linalg.lstsq(A, np.sum(xy**2, axis=1), rcond=None)
    r0 = np.sqrt(k + a * a + b * b)

    def residual(x: Array) -> Array:
        centre, normal, radius = x[:3], x[3:6] / np.linalg.norm(x[3:6]), x[6]
        d = p - centre
        along = d @ normal
        radial = np.linalg.norm(d - np.outer(along, normal), axis=1)
        return np.concatenate([radial - radius, along])

    x0 = np.concatenate([c0 + a * u + b * v, n, [r0]])
    sol = least_squares(residual, x0, method="lm", xtol=1e-14, ftol=1e-14)
    centre, normal, radius = sol.x[:3], sol.x[3:6] / np.linalg.norm(sol.x[3:6]), float(sol.x[6])
    travel = np.sum(np.cross(p[:-1] - centre, p[1:] - centre), axis=0)
    if np.dot(travel, normal) < 0:
        normal = -normal
    return Circle(centre, normal, abs(radius), float(np.sqrt(np.mean(sol.fun**2))))


def _feet(p1: Array, d1: Array, p2: Array, d2: Array) -> tuple[Array, Array]:
    c = np.cross(d1, d2)
    if np.linalg.norm(c) < 1e-6:
        raise AlignmentError("the joint 1 and joint 2 axes came out parallel")
    s, t, _ = np.linalg.solve(np.column_stack([d1, -d2, c]), p2 - p1)
    return p1 + s * d1, p2 + t * d2


def base_from_sweeps(model: SerialModel, j1_points_mm: ArrayLike, j2_points_mm: ArrayLike,
                     q1_during_j2_deg: float = 0.0) -> Array:
    """The measuring system's frame to robot base transform (4, 4), `model.base` convention
    (world <- robot base), from the two sweeps."""
    c1, c2 = fit_circle(j1_points_mm), fit_circle(j2_points_mm)
    foot1, foot2 = _feet(c1.centre_mm, c1.normal, c2.centre_mm, c2.normal)
    # The same construction on the nominal model, in the robot base frame.
    w1, w2 = model.axis_dirs[0], model.axis_dirs[1]
    n1, n2 = _feet(model.axis_points_mm[0], w1, model.axis_points_mm[1], w2)
    x_nom = n2 - n1
    if np.linalg.norm(x_nom) < 1e-9:  # intersecting axes: use their cross product
        x_nom = np.cross(w1, w2)
    x_nom /= np.linalg.norm(x_nom)
    x_meas = foot2 - foot1 if np.linalg.norm(foot2 - foot1) > 1e-6 else np.cross(c1.normal,
                                                                                  c2.normal)
    x_meas /= np.linalg.norm(x_meas)
    # Undo the joint-1 angle of the second sweep: rotate about axis 1 by -q1.
    a = -np.radians(q1_during_j2_deg)
    z = c1.normal
    x_meas = x_meas * np.cos(a) + np.cross(z, x_meas) * np.sin(a) + z * np.dot(z, x_meas) * (
        1 - np.cos(a))
    meas = np.eye(4)  # the construction's frame in the measuring system
    meas[:3, 0], meas[:3, 2] = x_meas, z
    meas[:3, 1] = np.cross(z, x_meas)
    meas[:3, 3] = foot1
    nom = np.eye(4)  # the same frame in the robot base frame
    nom[:3, 0], nom[:3, 2] = x_nom, w1
    nom[:3, 1] = np.cross(w1, x_nom)
    nom[:3, 3] = n1  # the base height along axis 1 is carried here
    return meas @ invert_transform(nom)


SWEEP_COLUMNS = ("joint", "q1", "x", "y", "z")


def read_sweeps_csv(path: str) -> tuple[Array, Array, float]:
    """A sweep file: columns joint (1 or 2), q1 (deg, joint 1's reading), x, y, z (mm), in the
    order probed. Returns the joint-1 points, the joint-2 points and q1 during the J2 sweep."""
    from screwcal.errors import DataFileError
    from screwcal.tables import read_numeric_csv

    table = read_numeric_csv(path, list(SWEEP_COLUMNS), min_rows=8)
    joint = table.column("joint")
    bad = np.flatnonzero(~np.isin(joint, (1, 2)))
    if bad.size:
        raise DataFileError(table.path, "joint must be 1 or 2", line=table.lines[bad[0]],
                            column="joint")
    xyz = table.take(["x", "y", "z"])
    j2 = joint == 2
    for k in (1, 2):
        if np.sum(joint == k) < 4:
            raise DataFileError(table.path, f"the joint-{k} sweep needs at least 4 points")
    q1 = table.column("q1")[j2]
    if np.ptp(q1) > 1e-6:
        raise DataFileError(table.path, "joint 1 must stay still during the joint-2 sweep",
                            column="q1")
    return xyz[joint == 1], xyz[j2], float(q1[0])
