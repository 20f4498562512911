"""ISO 9283 drift of pose characteristics (ISO 9283 7.5): reference poses re-measured over time.

ISO 9283 measures how the pose accuracy changes while the robot runs (warm-up): the drift of
position accuracy dAP = |AP_(t=1) - AP_(t=T)| between the first and the last measurement of a
pose. Here each reference pose is measured once per check, always approached from the same
side, and its drift is taken in vector form, the change of the attained position itself:

    d_k = p_k - p_0,   |d_k|  (mm)                                               (Eq. D.1)

p_k the reference pose's measured position at check k (any fixed frame: a distance needs no
base frame); |d_T| bounds ISO's |AP_1 - AP_T| and needs no commanded pose in the measuring frame.
With one measurement per check there is no repeatability to drift (ISO's dRP needs several).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import InputError
from screwcal.kinematics.se3 import Array


@dataclass(frozen=True)
class DriftSeries:
    """Reference poses' drift over the checks: t_s (K,), the change of each reference pose's
    position since its first measurement, components (K, R, 3) and norm (K, R), mm."""

    t_s: Array
    deviation_xyz_mm: Array
    deviation_mm: Array

    @property
    def max_mm(self) -> Array:
        """(K,) the largest norm over the reference poses at each check."""
        return self.deviation_mm.max(axis=1)

    @property
    def dap_mm(self) -> Array:
        """(R,) ISO 9283's position-accuracy drift in vector form: |p_T - p_0| (Eq. D.1)."""
        return self.deviation_mm[-1]


def drift_series(t_s: ArrayLike, p_mm: ArrayLike, since: int = 0) -> DriftSeries:
    """Eq. D.1 for checks at times t_s (K,) of R reference poses measured at p_mm (K, R, 3),
    relative to check `since` (its time the series' zero; the checks before it dropped)."""
    t = np.asarray(t_s, dtype=float)
    p = np.asarray(p_mm, dtype=float)
    if p.ndim != 3 or p.shape[2] != 3 or t.shape != (p.shape[0],) or p.shape[0] < 1:
        raise InputError(f"drift: times (K,) and positions (K, R, 3) of K >= 1 checks; got "
                         f"{t.shape} and {p.shape}")
    if not 0 <= since < len(t):
        raise InputError(f"drift: the reference check {since} is not one of the {len(t)}")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(t))):
        raise InputError("drift: times and positions must be finite")
    d = p[since:] - p[since]
    return DriftSeries(t[since:] - t[since], d, np.linalg.norm(d, axis=2))
