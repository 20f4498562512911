"""Importer for the IRB 120 laser-tracker data set (`irb120-laser-tracker/`).

The data set is not shipped with the package: it is real data of a real robot, public in the
repository icelinker/Robot-Calibration-LaserTracker (commit 188abd2, folder
`4-DataProcess/Input/`, plus `commanded_joints.txt` from `3-Full Measurement/Input/
generated_joints.txt`). `locate_dataset` finds it from an explicit folder or the
`SCREWCAL_DATA_DIR` environment variable, and says where to get it when it is missing.

Files of 1000 whitespace-separated rows: `measured_joints.txt` (6 joint angles, deg, read back
right after each move returned) and `commanded_joints.txt` (the targets sent), three tool
reflectors `measured_SMR_{1,2,3}.txt` and three base reflectors `measured_base_{1,2,3}.txt`
(mm, tracker frame). Row i of every file is pose i.

Checks, each reported with the rows it rejects:
- base drift: every base reflector must stay within `drift_tol_mm` of its median position (the
  tracker or the robot base moved, or the reading failed: a few rows of this data set are metres
  off);
- tool rigidity: the three tool reflectors' mutual distances must stay within `rigidity_tol_mm`
  of their medians (a mislabelled or failed tool reading);
- finite numbers and equal row counts.
Rejected rows are left out of the measurements, never used silently.

The base reflectors also follow the tracker's small drift over the acquisition (tenths of the
tolerance above: about 0.04 mm here): `measurements` brings every row's tool reflectors back by
the rigid motion that returns that row's base reflectors to their median places
(`drift="correct"`, the default; `"none"` leaves them), as laser-tracker practice does.

The tool reflectors give full poses: the frame of SMR 1, 2, 3 by the flange's Gram-Schmidt
(`flange.frame_from_holes`), whose origin is SMR 1; its transform from the flange is unknown
and identified with the tracker frame.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from screwcal.calibration.flange import frame_from_holes, hole_distances
from screwcal.calibration.initial_frames import rigid_motion
from screwcal.calibration.measurements import MeasurementSet, previous_rows
from screwcal.errors import DataFileError, DatasetMissingError
from screwcal.kinematics.se3 import Array

DATASET_NAME = "irb120-laser-tracker"
DATA_DIR_ENV = "SCREWCAL_DATA_DIR"
WHERE_TO_GET = (f"the {DATASET_NAME} data set is public in the repository "
                "icelinker/Robot-Calibration-LaserTracker (commit 188abd2, folder "
                f"4-DataProcess/Input/); put its files in a folder named {DATASET_NAME} and pass "
                f"--data DIR or set {DATA_DIR_ENV}=DIR (DIR: that folder or the one holding it)")
DRIFT_TOL_MM = 0.25  # the good rows stay within 0.07 mm
RIGIDITY_TOL_MM = 0.1  # the reflector triangle's sides vary by 0.02 mm in good rows


def add_data_argument(parser: argparse.ArgumentParser) -> None:
    """The studies' `--data DIR` option: the data set's folder (default: SCREWCAL_DATA_DIR)."""
    parser.add_argument("--data", default=None, metavar="DIR",
                        help=f"the {DATASET_NAME} folder (default: ${DATA_DIR_ENV})")


def locate_dataset(data_dir: str | Path | None = None) -> Path:
    """The data set's folder: `data_dir` (the folder itself or the one holding it), else
    $SCREWCAL_DATA_DIR; DatasetMissingError naming where it looked and where to get it."""
    given = data_dir if data_dir is not None else os.environ.get(DATA_DIR_ENV)
    if not given:
        raise DatasetMissingError(f"${DATA_DIR_ENV}", f"not set and no --data given: "
                                  f"{WHERE_TO_GET}")
    for folder in (Path(given), Path(given) / DATASET_NAME):
        if (folder / "measured_joints.txt").is_file():
            return folder
    raise DatasetMissingError(str(given), f"no {DATASET_NAME} data set here: {WHERE_TO_GET}")


@dataclass(frozen=True)
class TrackerData:
    q_deg: Array  # (N, 6)
    smr_mm: Array  # (N, 3, 3): pose, reflector, xyz
    base_mm: Array  # (N, 3, 3)
    rejected: dict[int, str] = field(default_factory=dict)  # 0-based row -> reason

    @property
    def good_rows(self) -> Array:
        return np.array([k for k in range(len(self.q_deg)) if k not in self.rejected])

    def measurements(self, full_pose: bool = True,
                     drift: Literal["correct", "none"] = "correct") -> MeasurementSet:
        """The accepted rows as measurements of SMR 1 (position) or of the SMR frame (pose),
        corrected for the tracker's drift by the base reflectors (`drift`); ids are the 1-based
        row numbers of the files."""
        rows = self.good_rows
        smr = self.smr_mm[rows] if drift == "none" else self.drift_corrected()[rows]
        rotations = frame_from_holes(smr)[:, :3, :3] if full_pose else None
        q = np.radians(self.q_deg)  # every row: the arm moved from the previous one anyway
        return MeasurementSet(q[rows], smr[:, 0].copy(), rotations,
                              tuple(str(k + 1) for k in rows), q_previous=previous_rows(q)[rows])

    def drift_corrected(self) -> Array:
        """(N, 3, 3) the tool reflectors moved, row by row, by the rigid motion that returns
        that row's base reflectors to their median places (rejected rows: unchanged)."""
        out = self.smr_mm.copy()
        reference = np.median(self.base_mm[self.good_rows], axis=0)
        for k in self.good_rows:
            R, t = rigid_motion(self.base_mm[k], reference)
            out[k] = self.smr_mm[k] @ R.T + t
        return out

    def base_drift_mm(self) -> float:
        """The largest distance of a base reflector from its median place (accepted rows)."""
        base = self.base_mm[self.good_rows]
        return float(np.linalg.norm(base - np.median(base, axis=0), axis=2).max())

    def report(self) -> str:
        drift = (f"; base reflectors drift up to {self.base_drift_mm():.3f} mm (corrected)")
        if not self.rejected:
            return f"{len(self.q_deg)} rows, all accepted{drift}"
        lines = [f"{len(self.q_deg)} rows, {len(self.rejected)} rejected{drift}:"]
        lines += [f"  row {k + 1}: {why}" for k, why in sorted(self.rejected.items())]
        return "\n".join(lines)


def _load(path: Path, columns: int) -> Array:
    try:
        data = np.loadtxt(path, ndmin=2)
    except FileNotFoundError:
        raise DataFileError(str(path), "file not found") from None
    except ValueError as err:
        raise DataFileError(str(path), f"not a table of numbers ({err})") from None
    if data.shape[1] != columns:
        raise DataFileError(str(path), f"{data.shape[1]} columns where {columns} are expected")
    bad = np.argwhere(~np.isfinite(data))
    if len(bad):
        raise DataFileError(str(path), "not a finite number", line=int(bad[0, 0]) + 1)
    return data


JOINT_FILES = {"measured": "measured_joints.txt", "commanded": "commanded_joints.txt"}


def read_tracker_dataset(folder: str | Path, drift_tol_mm: float = DRIFT_TOL_MM,
                         rigidity_tol_mm: float = RIGIDITY_TOL_MM,
                         joints: str = "measured") -> TrackerData:
    """The data set with the joints read back from the controller (`measured`, read before the
    arm had settled) or the targets sent with MoveAbsJ (`commanded`)."""
    folder = Path(folder)
    if joints not in JOINT_FILES:
        raise DataFileError(str(folder), f"joints are {' or '.join(JOINT_FILES)}, not {joints!r}")
    q = _load(folder / JOINT_FILES[joints], 6)
    smr = np.stack([_load(folder / f"measured_SMR_{k}.txt", 3) for k in (1, 2, 3)], axis=1)
    base = np.stack([_load(folder / f"measured_base_{k}.txt", 3) for k in (1, 2, 3)], axis=1)
    if not len(q) == len(smr) == len(base):
        raise DataFileError(str(folder), f"row counts differ: joints {len(q)}, SMR {len(smr)}, "
                            f"base {len(base)}")
    rejected: dict[int, str] = {}
    drift = np.linalg.norm(base - np.median(base, axis=0), axis=2)  # (N, 3)
    for k, j in np.argwhere(drift > drift_tol_mm):
        rejected.setdefault(int(k), f"base reflector {j + 1} is {drift[k, j]:.3f} mm from its "
                                    f"median position (limit {drift_tol_mm} mm)")
    sides = hole_distances(smr)
    off = np.abs(sides - np.median(sides, axis=0))
    for k in np.flatnonzero(off.max(axis=1) > rigidity_tol_mm):
        rejected.setdefault(int(k), f"tool reflector spacing off by {off[k].max():.3f} mm "
                                    f"(limit {rigidity_tol_mm} mm)")
    return TrackerData(q, smr, base, rejected)
