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

from screwcal.errors import DataFileError, InputError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import euler_zyx_deg_from_rotation, rotation_from_euler_zyx_deg
from screwcal.kinematics.readings import JointConvention, serial_from_readings
from screwcal.kinematics.se3 import Array, transform_points
from screwcal.tables import (
    LENGTH_UNITS_MM,
    RADIAN_LOOKING_DEG,
    direction_columns,
    fixed_texts,
    joint_columns,
    read_numeric_csv,
    write_csv_atomic,
)


def check_covariances(cov: Array, n: int) -> None:
    """Refuses what cannot be a point's covariance: not (n, 3, 3), not finite, not symmetric,
    not positive definite (InputError naming the first such point)."""
    if cov.shape != (n, 3, 3):
        raise InputError(f"position covariances must be ({n}, 3, 3); got {cov.shape}")
    bad = ~np.isfinite(cov).all(axis=(1, 2)) | \
        ~np.isclose(cov, np.swapaxes(cov, 1, 2), rtol=1e-6, atol=1e-12).all(axis=(1, 2))
    if not bad.any():
        bad = np.linalg.eigvalsh(cov)[:, 0] <= 0.0
    if bad.any():
        k = int(np.argmax(bad))
        raise InputError(f"the covariance of point {k + 1} is not a covariance (finite, "
                         f"symmetric, positive definite): {cov[k].tolist()}")


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
    # (N, n) the sign of each joint's last move before the pose (+1 from below, -1 from above,
    # 0 unknown), the file's optional dir1..dirn (`backlash.direction_pairs`); None: not given
    directions: Array | None = None
    # (N, 3, 3) each measured position's covariance (mm^2), as an instrument reports it (a
    # laser tracker's: tight along the beam, wide across it, growing with the range); the
    # statistical weighting then whitens each point by its own (`residual_problem`), the
    # measuring noise level scaling them all. None: every point alike, isotropic
    position_cov_mm2: Array | None = None

    def __post_init__(self) -> None:
        N = len(self.q)
        if self.positions_mm.shape != (N, 3):
            raise InputError(f"positions must be ({N}, 3); got {self.positions_mm.shape}")
        if self.rotations is not None and self.rotations.shape != (N, 3, 3):
            raise InputError(f"rotations must be ({N}, 3, 3); got {self.rotations.shape}")
        if self.q_previous is not None and self.q_previous.shape != self.q.shape:
            raise InputError(f"previous readings must be {self.q.shape}; got "
                                f"{self.q_previous.shape}")
        if self.directions is not None and self.directions.shape != self.q.shape:
            raise InputError(f"approach directions must be {self.q.shape}; got "
                             f"{self.directions.shape}")
        if self.position_cov_mm2 is not None:
            check_covariances(self.position_cov_mm2, N)
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
                              None if self.q_previous is None else self.q_previous[idx],
                              None if self.directions is None else self.directions[idx],
                              None if self.position_cov_mm2 is None
                              else self.position_cov_mm2[idx])

    def transformed(self, T: Array) -> MeasurementSet:
        """The same measurements seen from another frame: T (4, 4) maps this frame into it."""
        R = T[:3, :3]
        return replace(self, positions_mm=transform_points(T, self.positions_mm),
                       rotations=None if self.rotations is None else R @ self.rotations,
                       position_cov_mm2=None if self.position_cov_mm2 is None
                       else R @ self.position_cov_mm2 @ R.T)

    def with_q(self, q: Array) -> MeasurementSet:
        """The same measurements with other joint readings (e.g. corrected for lag)."""
        return replace(self, q=q)


def previous_rows(q: Array) -> Array:
    """(N, n) each row's predecessor in acquisition order (NaN for the first)."""
    out = np.full_like(q, np.nan)
    out[1:] = q[:-1]
    return out


JOINT_UNITS = ("deg", "rad")
# The measured points' spread over the model's: outside these bounds the lengths are not mm
SPREAD_RATIO = (0.3, 3.0)


def read_measurements_csv(path: str | Path, model: SerialModel, *, joint_unit: str = "deg",
                          length_unit: str = "mm",
                          joint_convention: JointConvention = "serial") -> MeasurementSet:
    """The measurement file (docs/formats.md): q1..qn (deg), x, y, z (mm),
    optionally rx, ry, rz (deg) on every row, optionally the approach directions dir1..dirn
    on every row, optional id. `joint_unit` ("rad") and
    `length_unit` ("m", "in") read files written in other units; numbers that look like
    another unit than the one given are refused with the fix (`check_units`). The readings
    count joint 3 as `joint_convention` says (`fanuc`: to the horizontal); the set holds the
    model's serial angles."""
    if joint_unit not in JOINT_UNITS or length_unit not in LENGTH_UNITS_MM:
        raise InputError(f"joint unit is one of {JOINT_UNITS}, length unit one of "
                            f"{tuple(LENGTH_UNITS_MM)}; not {joint_unit!r}, {length_unit!r}")
    directions = direction_columns(model.n_joints)
    table = read_numeric_csv(path, [*joint_columns(model.n_joints), "x", "y", "z"],
                             optional_groups=[["rx", "ry", "rz"], directions])
    q_given = table.take(joint_columns(model.n_joints))
    # revolute joints in degrees; prismatic ones are lengths
    q_deg = np.where(model.is_revolute, np.degrees(q_given) if joint_unit == "rad" else q_given,
                     q_given * LENGTH_UNITS_MM[length_unit])
    positions = table.take(["x", "y", "z"]) * LENGTH_UNITS_MM[length_unit]
    check_units(table.path, model, q_deg, positions, joint_unit, length_unit)
    q = model.joints_from_deg(serial_from_readings(q_deg, joint_convention))
    outside = np.logical_not(model.within_limits(q))
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise DataFileError(table.path, f"joint values outside the limits of model "
                            f"'{model.name}'", line=table.lines[k])
    rotations = None
    if "rx" in table.columns:
        rotations = rotation_from_euler_zyx_deg(table.take(["rx", "ry", "rz"]))
    return MeasurementSet(q, positions, rotations, table.ids, table.lines,
                          previous_rows(q),  # the file's rows are in acquisition order
                          table.take(directions) if directions[0] in table.columns else None)


def write_measurements_csv(path: str | Path, data: MeasurementSet, model: SerialModel) -> None:
    """The measurement file `read_measurements_csv` reads (what `screwcal calibrate --data`
    takes): id, q1..qn (deg; mm for prismatic joints), x, y, z (mm), and rx, ry, rz (deg) for
    full-pose data, one row per pose in the set's order (the order measured)."""
    q_deg = model.joints_to_deg(data.q)
    header = ["id", *joint_columns(model.n_joints), "x", "y", "z"]
    columns = [q_deg, data.positions_mm]
    if data.rotations is not None:
        header += ["rx", "ry", "rz"]
        columns.append(euler_zyx_deg_from_rotation(data.rotations))
    values = np.hstack(columns)
    write_csv_atomic(path, header, ([pose_id, *fixed_texts(row, 6)]
                                    for pose_id, row in zip(data.ids, values, strict=True)))


def check_joint_units(path: str, model: SerialModel, q_deg: Array, joint_unit: str = "deg"
                      ) -> None:
    """Refuse (DataFileError, with the fix) joint readings that look like radians (every
    revolute reading of two rows or more within +-RADIAN_LOOKING_DEG) or, read as radians,
    like degrees (beyond a whole turn): every reader of joint readings checks them so."""
    revolute = model.is_revolute
    columns = ", ".join(c for c, r in zip(joint_columns(model.n_joints), revolute, strict=True)
                        if r)
    if len(q_deg) >= 2 and revolute.any() and \
            np.abs(q_deg[:, revolute]).max() < RADIAN_LOOKING_DEG:
        fix = "they look like radians: give --joint-unit rad, or convert them to degrees" \
            if joint_unit == "deg" else "check the file's joint columns"
        raise DataFileError(path, f"every joint reading in columns {columns} lies within "
                            f"+-{RADIAN_LOOKING_DEG:g} deg as read ({joint_unit}): {fix}")
    if joint_unit == "rad" and revolute.any() and \
            np.abs(q_deg[:, revolute]).max() > 360.0 + RADIAN_LOOKING_DEG:
        raise DataFileError(path, f"joint readings in columns {columns} beyond a whole turn "
                            "when read as radians: they look like degrees; leave out "
                            "--joint-unit rad")


def check_units(path: str, model: SerialModel, q_deg: Array, positions_mm: Array,
                joint_unit: str = "deg", length_unit: str = "mm") -> None:
    """Refuse (DataFileError, with the fix) joint readings that look like radians and
    positions that look like metres or inches: every revolute reading within
    +-RADIAN_LOOKING_DEG, or measured points whose spread differs from the model's flange at
    the same joints by more than SPREAD_RATIO allows and that another unit brings within it
    (the measuring frame changes where the points are, not how far apart)."""
    check_joint_units(path, model, q_deg, joint_unit)
    q = model.joints_from_deg(q_deg)
    if len(q) < 3 or not model.within_limits(q).all():
        return  # the limits' own check names the line
    from screwcal.kinematics.forward import flange_kinematics

    flange = flange_kinematics(model, q)[:, :3, 3]
    model_spread = _spread(flange)
    if model_spread < 10.0:
        return  # the poses hardly move the flange: nothing to compare
    ratio = _spread(positions_mm) / model_spread
    if SPREAD_RATIO[0] <= ratio <= SPREAD_RATIO[1]:
        return

    def misfit(unit: str) -> float:  # how far the spread in `unit` is from the model's
        return abs(float(np.log(ratio * LENGTH_UNITS_MM[unit] / LENGTH_UNITS_MM[length_unit])))

    # the unit the numbers look like: one that brings the spread within SPREAD_RATIO of the
    # model's (a long tool swung by the wrist spreads the point more than the flange: no unit
    # explains that, and it is not refused)
    looks = min(LENGTH_UNITS_MM, key=misfit)
    if looks == length_unit or misfit(looks) > np.log(SPREAD_RATIO[1]):
        return
    raise DataFileError(path, f"the measured points (columns x, y, z) spread over {ratio:.3g} "
                        "times the "
                        f"distance the model's flange does at the same joints, read as "
                        f"{length_unit}: they look like {looks}; give --length-unit {looks}, "
                        "or convert them to mm")


def _spread(points: Array) -> float:
    """RMS distance (mm) of points (N, 3) from their centroid."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))
