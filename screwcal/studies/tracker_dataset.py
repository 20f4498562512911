"""Importer for the laser-tracker data set format of ../shared/datasets/irb120-laser-tracker/.

Files of 1000 whitespace-separated rows: `measured_joints.txt` (6 joint angles, deg), three tool
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

The tool reflectors give full poses: the frame of SMR 1, 2, 3 by the flange's Gram-Schmidt
(`flange.frame_from_holes`), whose origin is SMR 1; its transform from the flange is unknown
and identified with the tracker frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from screwcal.errors import DataFileError
from screwcal.flange import frame_from_holes, hole_distances
from screwcal.measurements import MeasurementSet
from screwcal.se3 import Array

DRIFT_TOL_MM = 0.25  # the good rows stay within 0.07 mm
RIGIDITY_TOL_MM = 0.1  # the reflector triangle's sides vary by 0.02 mm in good rows


@dataclass(frozen=True)
class TrackerData:
    q_deg: Array  # (N, 6)
    smr_mm: Array  # (N, 3, 3): pose, reflector, xyz
    base_mm: Array  # (N, 3, 3)
    rejected: dict[int, str] = field(default_factory=dict)  # 0-based row -> reason

    @property
    def good_rows(self) -> Array:
        return np.array([k for k in range(len(self.q_deg)) if k not in self.rejected])

    def measurements(self, full_pose: bool = True) -> MeasurementSet:
        """The accepted rows as measurements of SMR 1 (position) or of the SMR frame (pose);
        ids are the 1-based row numbers of the files."""
        rows = self.good_rows
        smr = self.smr_mm[rows]
        rotations = frame_from_holes(smr)[:, :3, :3] if full_pose else None
        return MeasurementSet(np.radians(self.q_deg[rows]), smr[:, 0].copy(), rotations,
                              tuple(str(k + 1) for k in rows))

    def report(self) -> str:
        if not self.rejected:
            return f"{len(self.q_deg)} rows, all accepted"
        lines = [f"{len(self.q_deg)} rows, {len(self.rejected)} rejected:"]
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


def read_tracker_dataset(folder: str | Path, drift_tol_mm: float = DRIFT_TOL_MM,
                         rigidity_tol_mm: float = RIGIDITY_TOL_MM) -> TrackerData:
    folder = Path(folder)
    q = _load(folder / "measured_joints.txt", 6)
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
