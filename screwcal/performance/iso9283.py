"""ISO 9283 pose accuracy and repeatability (thesis 2.3.1, Eqs. 2.5-2.10).

For one commanded pose measured n times (n cycles):

- position accuracy      AP_P = |mean(p_j) - p_c|                               (Eq. 2.5)
  with components        AP_x = mean(x_j) - x_c, ...
- position repeatability RP_l = mean(l) + 3 S_l, l_j = |p_j - mean(p)|,
                         S_l = sqrt(sum (l_j - mean(l))^2 / (n - 1))            (ISO 9283 7.2.2)
- the thesis's variant   RP (Eq. 2.8) = S_l alone, with d_i = l_i (Eqs. 2.6-2.7): labelled
                         `rp_thesis_eq2_8_mm`, it is not the ISO figure.
- orientation accuracy   AP_a = mean(a_j) - a_c, AP_b, AP_c about x, y, z         (Eq. 2.9)
- orientation repeat.    RP_a = +-3 S_a, S_a = sqrt(sum (a_j - mean(a))^2 / (n-1)) (Eq. 2.10)

Angles are (rx, ry, rz) in degrees as elsewhere. Every attained orientation is first written on
the ZYX triple nearest the commanded one (flange-down is both (180, 0, 180) and (0, 180, 0)), each
angle within 180 deg of it, so neither the representation nor the +-180 cut distorts the means.

Worked example (position only; 3 cycles, commanded at the origin)::

    >>> import numpy as np
    >>> m = pose_metrics(np.zeros(3), np.array([[1.0, 0, 0], [1.0, 2, 0], [1.0, -2, 0]]))
    >>> round(m.ap_mm, 6), [round(v, 6) for v in m.ap_xyz_mm]
    (1.0, [1.0, 0.0, 0.0])
    >>> round(m.rp_mm, 4)  # l = (0, 2, 2): mean 4/3, S_l = 1.1547; RP = 4/3 + 3 * 1.1547
    4.7974
    >>> round(m.rp_thesis_eq2_8_mm, 4)
    1.1547
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import InputError
from screwcal.kinematics.pose import euler_zyx_deg_near, rotation_from_euler_zyx_deg
from screwcal.kinematics.se3 import Array


@dataclass(frozen=True)
class PoseMetrics:
    """ISO 9283 figures for one commanded pose (mm, degrees). Orientation fields are None for
    position-only measurements."""

    n_cycles: int
    ap_mm: float
    ap_xyz_mm: tuple[float, float, float]
    rp_mm: float
    rp_thesis_eq2_8_mm: float
    mean_distance_mm: float  # mean(l_j)
    std_distance_mm: float  # S_l
    ap_abc_deg: tuple[float, float, float] | None = None
    rp_abc_deg: tuple[float, float, float] | None = None  # +-3 S_a, S_b, S_c (value of 3 S)

    @property
    def ap_abc_max_abs_deg(self) -> float | None:
        """The orientation accuracy as one figure: max(|AP_a|, |AP_b|, |AP_c|) (the summary's
        and the report's; None for position-only measurements)."""
        return None if self.ap_abc_deg is None else max(abs(v) for v in self.ap_abc_deg)

    def to_dict(self) -> dict:
        return asdict(self)


def wrap_deg(angle_deg: ArrayLike) -> Array:
    """Angles wrapped to (-180, 180]."""
    a = np.asarray(angle_deg, dtype=float)
    return 180.0 - np.mod(180.0 - a, 360.0)


def _triple(v: Array) -> tuple[float, float, float]:
    """A (3,) array as three floats."""
    a, b, c = (float(x) for x in v)
    return a, b, c


def pose_metrics(p_cmd_mm: ArrayLike, p_mm: ArrayLike, r_cmd_deg: ArrayLike | None = None,
                 r_deg: ArrayLike | None = None) -> PoseMetrics:
    """ISO 9283 metrics of n >= 2 attained poses p_mm (n, 3) [and r_deg (n, 3)] of one
    commanded pose p_cmd_mm (3,) [r_cmd_deg (3,)]."""
    p_cmd = np.asarray(p_cmd_mm, dtype=float)
    p = np.asarray(p_mm, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p_cmd.shape != (3,):
        raise InputError(f"pose metrics need attained positions (n, 3) and a commanded (3,); "
                            f"got {p.shape} and {p_cmd.shape}")
    n = len(p)
    if n < 2:
        raise InputError(f"repeatability needs at least 2 cycles of a pose; got {n}")
    mean = p.mean(axis=0)
    ap_xyz = mean - p_cmd  # Eq. 2.5 components
    dist = np.linalg.norm(p - mean, axis=1)  # l_j, Eq. 2.6
    l_mean = float(dist.mean())  # Eq. 2.7
    s_l = float(np.std(dist, ddof=1))  # Eq. 2.8
    ap_abc: tuple[float, float, float] | None = None
    rp_abc: tuple[float, float, float] | None = None
    if (r_cmd_deg is None) != (r_deg is None):
        raise InputError("give both commanded and attained orientations, or neither")
    if r_deg is not None:
        r = np.asarray(r_deg, dtype=float)
        r_cmd = np.asarray(r_cmd_deg, dtype=float)
        if r.shape != p.shape or r_cmd.shape != (3,):
            raise InputError(f"orientations must be (n, 3) and (3,); got {r.shape}, "
                                f"{r_cmd.shape}")
        r = euler_zyx_deg_near(rotation_from_euler_zyx_deg(r), r_cmd)
        dev = wrap_deg(r - r_cmd)  # attained - commanded, near 0
        ap_abc = _triple(dev.mean(axis=0))  # Eq. 2.9
        rp_abc = _triple(3.0 * np.std(dev, axis=0, ddof=1))  # Eq. 2.10
    return PoseMetrics(n_cycles=n, ap_mm=float(np.linalg.norm(ap_xyz)),
                       ap_xyz_mm=_triple(ap_xyz),
                       rp_mm=l_mean + 3.0 * s_l, rp_thesis_eq2_8_mm=s_l,
                       mean_distance_mm=l_mean, std_distance_mm=s_l,
                       ap_abc_deg=ap_abc, rp_abc_deg=rp_abc)
