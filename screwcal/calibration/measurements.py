"""Measured data for identification, and the measurement CSV of the offline contract.

A `MeasurementSet` holds, per pose, the joint values the controller reported and what the
measuring system saw of the measured point: its position (mm) and, for full-pose data, its
orientation, in the measuring system's frame.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import DataFileError, ScrewcalError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import rotation_from_euler_zyx_deg
from screwcal.kinematics.se3 import Array, transform_points
from screwcal.tables import joint_columns, read_numeric_csv


@dataclass(frozen=True)
class MeasurementSet:
    q: Array  # (N, n) joint readings, numeric units (rad / mm)
    positions_mm: Array  # (N, 3)
    rotations: Array | None = None  # (N, 3, 3) for full-pose data
    ids: tuple[str, ...] = ()
    lines: tuple[int, ...] = ()  # the file line of each pose, when read from a file
    # (N, n) the readings of the pose measured just before each one (NaN: the first, or
    # unknown), for readings that lag the motion (`lag`); None: not known at all
    q_previous: Array | None = None

    def __post_init__(self) -> None:
        N = len(self.q)
        if self.positions_mm.shape != (N, 3):
            raise ScrewcalError(f"positions must be ({N}, 3); got {self.positions_mm.shape}")
        if self.rotations is not None and self.rotations.shape != (N, 3, 3):
            raise ScrewcalError(f"rotations must be ({N}, 3, 3); got {self.rotations.shape}")
        if self.q_previous is not None and self.q_previous.shape != self.q.shape:
            raise ScrewcalError(f"previous readings must be {self.q.shape}; got "
                                f"{self.q_previous.shape}")
        if not self.ids:
            object.__setattr__(self, "ids", tuple(str(k + 1) for k in range(N)))

    @property
    def full_pose(self) -> bool:
        return self.rotations is not None

    def __len__(self) -> int:
        return len(self.q)

    def line_of(self, k: int) -> int | None:
        return self.lines[k] if self.lines else None

    def take(self, index: ArrayLike) -> MeasurementSet:
        idx = np.asarray(index)
        return MeasurementSet(self.q[idx], self.positions_mm[idx],
                              None if self.rotations is None else self.rotations[idx],
                              tuple(np.asarray(self.ids, dtype=object)[idx]),
                              tuple(int(v) for v in np.asarray(self.lines, dtype=int)[idx])
                              if self.lines else (),  # Python ints: they go into JSON
                              None if self.q_previous is None else self.q_previous[idx])

    def transformed(self, T: Array) -> MeasurementSet:
        """The same measurements seen from another frame: T (4, 4) maps this frame into it."""
        return replace(self, positions_mm=transform_points(T, self.positions_mm),
                       rotations=None if self.rotations is None else T[:3, :3] @ self.rotations)

    def with_q(self, q: Array) -> MeasurementSet:
        """The same measurements with other joint readings (e.g. corrected for lag)."""
        return replace(self, q=q)


def previous_rows(q: Array) -> Array:
    """(N, n) each row's predecessor in acquisition order (NaN for the first)."""
    out = np.full_like(q, np.nan)
    out[1:] = q[:-1]
    return out


def read_measurements_csv(path: str | Path, model: SerialModel) -> MeasurementSet:
    """The measurement file (docs/formats.md): q1..qn (deg), x, y, z (mm),
    optionally rx, ry, rz (deg) on every row, optional id."""
    table = read_numeric_csv(path, [*joint_columns(model.n_joints), "x", "y", "z"],
                             optional_groups=[["rx", "ry", "rz"]])
    q = model.joints_from_deg(table.take(joint_columns(model.n_joints)))
    outside = ~model.within_limits(q)
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise DataFileError(table.path, f"joint values outside the limits of model "
                            f"'{model.name}'", line=table.lines[k])
    rotations = None
    if "rx" in table.columns:
        rotations = rotation_from_euler_zyx_deg(table.take(["rx", "ry", "rz"]))
    return MeasurementSet(q, table.take(["x", "y", "z"]), rotations, table.ids, table.lines,
                          previous_rows(q))  # the file's rows are in acquisition order
