"""What one identification is asked to do: `identify`'s options as one frozen object, and the
noise model it weights the residuals with.

`identify(...)` takes an `IdentifySettings` (or builds one from its keyword options); its plan
of stages is built from it (`identify.plan`), and each fit's state carries its own copy, a field
changed with `dataclasses.replace` (the compliance tried, a learned prior).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from screwcal.calibration.error_parameters import ModelKind
from screwcal.calibration.identifiability import Residual
from screwcal.calibration.plausible import PlausibleRanges
from screwcal.errors import IdentificationError
from screwcal.instrument import JOINT_ERROR_DEG, ORIENTATION_NOISE_DEG, POSITION_NOISE_MM
from screwcal.kinematics.se3 import Array

Frames = Literal["unknown", "known", "base"]  # base: only the measuring frame is unknown
Solver = Literal["lm", "de"]
Outliers = Literal["reject", "keep"]
Lag = Literal["none", "auto"]  # auto: the readings' lag estimated and corrected
PriorScale = Literal["learned", "plausible"]  # the prior's scale on small sets
WEIGHTINGS = ("statistical", "eq2.4")
PRIOR_NOISE = (POSITION_NOISE_MM, ORIENTATION_NOISE_DEG, JOINT_ERROR_DEG)  # screwcal/instrument.py
DEFAULT_RANGES = PlausibleRanges()


@dataclass(frozen=True)
class NoiseModel:
    """Noise levels: measuring system (mm, 1 sigma), flange-derived orientation (deg, 1 sigma),
    random joint error (deg, uniform +-). A level left None is estimated from the data,
    starting from PRIOR_NOISE (the FARO arm's 0.013 mm, holes 50 mm apart, the thesis's
    +-0.05 deg)."""

    position_mm: float | None = None
    orientation_deg: float | None = None
    joint_deg: float | None = None

    @property
    def free(self) -> tuple[bool, bool, bool]:
        return (self.position_mm is None, self.orientation_deg is None, self.joint_deg is None)

    def filled(self) -> tuple[float, float, float]:
        """The levels, the priors where free."""
        p, o, j = (prior if v is None else float(v) for prior, v in zip(
            PRIOR_NOISE, (self.position_mm, self.orientation_deg, self.joint_deg), strict=True))
        return p, o, j


@dataclass(frozen=True, eq=False)
class IdentifySettings:
    """The options of one identification (see `identify.identify` for what each does)."""

    kind: ModelKind = "full"
    residual: Residual | None = None  # None: "pose" for full-pose data, else "position"
    frames: Frames = "unknown"
    solver: Solver = "lm"
    weighting: str = "statistical"  # or "eq2.4"
    weight_mm: float = 1.0  # eq2.4's W (mm per deg)
    noise: NoiseModel = field(default_factory=NoiseModel)
    de_link_bounds_mm: tuple[float, float] = (0.0, 1.0)
    seed: int = 0
    base_guess: Array | None = None  # (4, 4) starting base frame
    link_offsets: Sequence[str] | None = None
    outliers: Outliers = "reject"
    de_polish: bool = True
    compliance: str = "none"  # the compliance fitted; "auto": chosen (model_choice)
    ranges: PlausibleRanges | None = DEFAULT_RANGES  # the prior; None: plain least squares
    prior: PlausibleRanges | None = None  # narrower prior scales (empirical_prior); None: ranges
    lag: Lag = "none"
    prior_scale: PriorScale = "learned"

    @classmethod
    def of(cls, *, noise: NoiseModel | None = None,
           plausible: PlausibleRanges | None = DEFAULT_RANGES, **options: Any) -> IdentifySettings:
        """The settings of `identify`'s keyword options (`noise` None: every level estimated;
        `plausible`: the ranges)."""
        return cls(noise=noise or NoiseModel(), ranges=plausible, **options)

    def __post_init__(self) -> None:
        if self.weighting not in WEIGHTINGS:
            raise IdentificationError(f"weighting is 'statistical' or 'eq2.4', not "
                                      f"'{self.weighting}'")

    @property
    def prior_ranges(self) -> PlausibleRanges | None:
        """The ranges that scale the prior: the learned ones (`empirical_prior`) when set, else
        the plausible ranges (which always bound the warnings)."""
        return self.ranges if self.prior is None or self.ranges is None else self.prior

    @property
    def statistical(self) -> bool:
        return self.weighting == "statistical"

    def stated_position_mm(self) -> float:
        """The measuring noise the user stated, or the instrument's prior."""
        return PRIOR_NOISE[0] if self.noise.position_mm is None else self.noise.position_mm


def resolved_residual(settings: IdentifySettings, full_pose: bool) -> Residual:
    """The residual asked for, or the data's own: pose residuals for full-pose data."""
    residual = settings.residual or ("pose" if full_pose else "position")
    if residual == "pose" and not full_pose:
        raise IdentificationError("pose residuals need orientations: the data are positions "
                                  "only (fit residual 'position' or 'distance')")
    return residual


def variance_from_levels(levels: tuple[float, float, float]) -> Array:
    """Variance components (mm^2, rad^2, rad^2) of the levels (mm, deg, uniform +- deg)."""
    p, o, j = levels
    return np.array([p**2, np.radians(o) ** 2, (np.radians(j) / np.sqrt(3.0)) ** 2])


def levels_from_variance(theta: Array) -> Array:
    """The inverse of variance_from_levels: (mm, deg, uniform +- deg)."""
    p, o, j = np.sqrt(np.maximum(theta, 0.0))
    return np.array([p, np.degrees(o), np.degrees(j) * np.sqrt(3.0)])
