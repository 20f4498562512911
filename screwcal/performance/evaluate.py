"""ISO 9283 pose accuracy and repeatability, and straightness, of a performance test: the
performance file's reader (columns in `screwcal evaluate --help`) and the report it gives."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from screwcal.errors import DataFileError
from screwcal.kinematics.se3 import Array
from screwcal.performance.iso9283 import PoseMetrics, pose_metrics
from screwcal.performance.straightness import Straightness
from screwcal.tables import (
    LENGTH_UNITS_MM,
    RADIAN_LOOKING_DEG,
    NumericTable,
    joint_columns,
    read_numeric_csv,
)

CMD = ["x_cmd", "y_cmd", "z_cmd", "rx_cmd", "ry_cmd", "rz_cmd"]
ATTAINED_POSITION = ["x", "y", "z"]
ATTAINED_ORIENTATION = ["rx", "ry", "rz"]
_CMD_TOL = 1e-3  # mm / deg: one commanded pose per point, as printed to 4 decimals


@dataclass(frozen=True)
class PointData:
    label: str
    cmd: Array  # (6,)
    attained: Array  # (n, 3) or (n, 6)


@dataclass(frozen=True)
class PerformanceData:
    path: str
    points: tuple[PointData, ...]
    full_pose: bool

    @property
    def commanded_mm(self) -> Array:
        return np.vstack([np.tile(p.cmd[:3], (len(p.attained), 1)) for p in self.points])

    @property
    def attained_mm(self) -> Array:
        return np.vstack([p.attained[:, :3] for p in self.points])


# Commanded positions all within this (mm) of the robot's base: no ISO 9283 cube sits there,
# the numbers are in another unit
NEAR_BASE_MM = 5.0


def read_performance_csv(path: str | Path, length_unit: str = "mm") -> PerformanceData:
    """Read and check a performance test file (see the module docstring); positions written
    in `length_unit` (m, in) are read as mm. Numbers that look like another unit (joints in
    radians, positions in metres) are refused with the fix, as the measurement file's are."""
    table = read_numeric_csv(path, ["cycle", *joint_columns(6), *CMD, *ATTAINED_POSITION],
                             optional_groups=[ATTAINED_ORIENTATION], min_rows=2,
                             text_columns=["point"])
    scale = LENGTH_UNITS_MM[length_unit]
    for columns in (CMD[:3], ATTAINED_POSITION):
        table.values[:, [table.columns.index(c) for c in columns]] *= scale
    _check_units(table, length_unit)
    full = all(c in table.columns for c in ATTAINED_ORIENTATION)
    labels = table.text["point"]
    cycles = table.column("cycle")
    points = []
    for label in dict.fromkeys(labels):  # first-seen order
        rows = np.flatnonzero(np.array(labels) == label)
        seen: dict[float, int] = {}
        for r in rows.tolist():
            if cycles[r] in seen:
                raise DataFileError(table.path, f"point {label} has cycle {cycles[r]:g} twice "
                                    f"(also line {table.lines[seen[cycles[r]]]})",
                                    line=table.lines[r], column="cycle")
            seen[cycles[r]] = r
        if len(rows) < 2:
            raise DataFileError(table.path, f"point {label} has {len(rows)} cycle; ISO 9283 "
                                "repeatability needs at least 2", line=table.lines[rows[0]],
                                column="point")
        cmd = table.take(CMD)[rows]
        moved = np.abs(cmd - cmd[0]).max(axis=1) > _CMD_TOL
        if moved.any():
            bad = rows[np.argmax(moved)]
            raise DataFileError(table.path, f"point {label}'s commanded pose differs from its "
                                f"first row (line {table.lines[rows[0]]})", line=table.lines[bad])
        attained_cols = ATTAINED_POSITION + (ATTAINED_ORIENTATION if full else [])
        points.append(PointData(label, cmd[0], table.take(attained_cols)[rows]))
    return PerformanceData(table.path, tuple(points), full)


def _check_units(table: NumericTable, length_unit: str) -> None:
    """Positions that look like metres (commanded or attained: every one within NEAR_BASE_MM
    of the robot's base, the other set not), joints that look like radians."""
    for columns, what in ((CMD[:3], "commanded"), (ATTAINED_POSITION, "attained")):
        if np.abs(table.take(columns)).max() < NEAR_BASE_MM:
            raise DataFileError(table.path, f"every {what} position (columns "
                                f"{', '.join(columns)}) lies within {NEAR_BASE_MM:g} mm of the "
                                f"robot's base as read ({length_unit}): they look like metres; "
                                "give --length-unit m, or convert them to mm")
    q = table.take(joint_columns(6))
    if np.ptp(q, axis=0).max() > 0 and np.abs(q).max() < RADIAN_LOOKING_DEG:
        raise DataFileError(table.path, f"every joint reading (columns "
                            f"{', '.join(joint_columns(6))}) lies within "
                            f"+-{RADIAN_LOOKING_DEG:g} deg: they look like radians; convert "
                            "them to degrees")


def point_metrics(data: PerformanceData) -> dict[str, PoseMetrics]:
    out = {}
    for p in data.points:
        if data.full_pose:
            out[p.label] = pose_metrics(p.cmd[:3], p.attained[:, :3], p.cmd[3:], p.attained[:, 3:])
        else:
            out[p.label] = pose_metrics(p.cmd[:3], p.attained[:, :3])
    return out


def summarise(metrics: dict[str, PoseMetrics]) -> dict:
    """Overall figures: mean and max over the points."""
    ap = np.array([m.ap_mm for m in metrics.values()])
    rp = np.array([m.rp_mm for m in metrics.values()])
    out: dict = {"points": len(metrics), "ap_mm_mean": float(ap.mean()),
                 "ap_mm_max": float(ap.max()), "rp_mm_mean": float(rp.mean()),
                 "rp_mm_max": float(rp.max())}
    if all(m.ap_abc_deg is not None for m in metrics.values()):
        abc = np.abs(np.array([m.ap_abc_deg for m in metrics.values()]))
        rpabc = np.array([m.rp_abc_deg for m in metrics.values()])
        out |= {"ap_abc_deg_max_abs": abc.max(axis=0).tolist(),
                "ap_abc_deg_max": max(float(m.ap_abc_max_abs_deg or 0.0)
                                      for m in metrics.values()),
                "rp_abc_deg_max": rpabc.max(axis=0).tolist()}
    return out


def read_path_csv(path: str | Path) -> Array:
    """(N, 3) the attained positions (mm) of a straight-line path file, at least 3 rows."""
    return read_numeric_csv(path, ATTAINED_POSITION, min_rows=3).take(ATTAINED_POSITION)


def performance_section(data: PerformanceData, line: Straightness | None = None
                        ) -> dict[str, Any]:
    """One performance test's figures: ISO 9283 per point and overall (when a point has
    them), and the straightness of `line`. The evaluate command's report and the job service's
    result hold this section."""
    metrics = point_metrics(data)
    out: dict[str, Any] = {
        "measurement": "full pose" if data.full_pose else "position only",
        "points": {k: m.to_dict() for k, m in metrics.items()}}
    if metrics:
        out["overall"] = summarise(metrics)
    if line is not None:
        out["straightness"] = line.to_dict()
    return out


def _section(data: PerformanceData, line: Straightness | None) -> dict[str, Any]:
    return {"file": data.path, **performance_section(data, line)}


def build_report(after: PerformanceData, before: PerformanceData | None = None,
                 line: Straightness | None = None, line_before: Straightness | None = None
                 ) -> dict:
    """The performance report document: ISO 9283 per point after (and before, when given),
    the straightness of a path, the overall figures."""
    report = {
        "standard": "ISO 9283:1998 pose accuracy (AP) and repeatability (RP); straightness by "
                    "ISO 12780-1 least-squares line",
        "units": {"length": "mm", "angle": "deg"},
        "definitions": {
            "ap_mm": "Eq. 2.5: distance from the commanded position to the mean attained one",
            "rp_mm": "ISO 9283: mean(l) + 3 S_l, l = distance to the barycentre",
            "rp_thesis_eq2_8_mm": "thesis Eq. 2.8: S_l alone (not the ISO figure)",
            "ap_abc_deg": "Eq. 2.9: mean attained minus commanded rx, ry, rz",
            "rp_abc_deg": "Eq. 2.10: 3 S of rx, ry, rz (the ISO figure is +-this)",
            "straightness.peak_to_valley_mm": "peak + valley of signed deviations from the LS line",
        },
        "result": _section(after, line),
    }
    if before is not None:
        report["before"] = _section(before, line_before)
    return report
