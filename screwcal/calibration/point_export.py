"""Measurements from any instrument's software: a point export (X, Y, Z and optionally U95 per
point, as SpatialAnalyzer, PolyWorks or a tracker SDK script writes them) with a joints file.

The point export: a header row, then one point per row; columns found by name, case and spaces
ignored: X, Y, Z (required), U95 (optional: the point's expanded uncertainty at 95 %, k = 2, per
coordinate), and a name column (one of name, point, point name, target, label, id). Commas,
semicolons or tabs separate the fields; with semicolons or tabs a decimal comma is read too.
Other columns (collection, group, time, ...) are ignored.

The joints file is the measurement CSV's joint part (docs/formats.md): q1..qn (deg) and an
optional id. With an id column, each joint row takes the point of the same name (points without a
joint row, such as base nests, are left out and counted); without one, row k takes point k and the
counts must agree. Rows are in acquisition order (the previous readings of the read-back lag).

With U95 the points weigh by their own uncertainty: covariance (U95 / 2)^2 I per point.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from screwcal.calibration.measurements import (
    LENGTH_UNITS_MM,
    MeasurementSet,
    check_units,
    previous_rows,
)
from screwcal.errors import DataFileError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.readings import JointConvention, serial_from_readings
from screwcal.kinematics.se3 import Array
from screwcal.tables import joint_columns, read_numeric_csv

NAME_COLUMNS = ("name", "point", "pointname", "target", "label", "id")


@dataclass(frozen=True)
class PointExport:
    names: tuple[str, ...]
    points_mm: Array  # (N, 3)
    u95_mm: Array | None  # (N,)
    lines: tuple[int, ...]


def _key(cell: str) -> str:
    return "".join(cell.split()).lower()


def _rows(path: Path) -> tuple[list[list[str]], bool]:
    """The file's rows and whether a decimal comma may be used (a separator other than ',')."""
    label = str(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise DataFileError(label, "file not found") from None
    except (IsADirectoryError, UnicodeDecodeError) as err:
        raise DataFileError(label, f"not a readable UTF-8 text file ({err})") from None
    first = next((line for line in text.splitlines() if line.strip()), "")
    delimiter = max((";", "\t", ","), key=first.count) if first else ","
    rows = list(csv.reader(text.splitlines(), delimiter=delimiter))
    return rows, delimiter != ","


def read_point_export(path: str | Path, length_unit: str = "mm") -> PointExport:
    path = Path(path)
    label = str(path)
    rows, decimal_comma = _rows(path)
    start = next((k for k, row in enumerate(rows) if any(c.strip() for c in row)), None)
    if start is None:
        raise DataFileError(label, "the file is empty: expected a header row with X, Y, Z",
                            line=1)
    header = [_key(c) for c in rows[start]]
    missing = [c for c in ("x", "y", "z") if c not in header]
    if missing:
        raise DataFileError(label, f"missing column(s) {', '.join(c.upper() for c in missing)}"
                            f"; the header has {', '.join(rows[start])}", line=start + 1)
    cols = [header.index(c) for c in ("x", "y", "z")]
    u95 = header.index("u95") if "u95" in header else None
    name = next((header.index(c) for c in NAME_COLUMNS if c in header), None)
    names: list[str] = []
    points: list[list[float]] = []
    u: list[float] = []
    lines: list[int] = []
    for lineno, row in enumerate(rows[start + 1:], start=start + 2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) < len(header):
            raise DataFileError(label, f"{len(row)} fields where the header has {len(header)}",
                                line=lineno)
        values = [_number(label, row[k], lineno, rows[start][k], decimal_comma)
                  for k in [*cols, *([] if u95 is None else [u95])]]
        points.append(values[:3])
        if u95 is not None:
            if values[3] <= 0.0:
                raise DataFileError(label, f"U95 {values[3]:g} is not positive", line=lineno,
                                    column=rows[start][u95])
            u.append(values[3])
        names.append(row[name].strip() if name is not None else str(len(names) + 1))
        lines.append(lineno)
    if not points:
        raise DataFileError(label, "no point rows under the header")
    scale = LENGTH_UNITS_MM[length_unit]
    return PointExport(tuple(names), np.array(points) * scale,
                       None if u95 is None else np.array(u) * scale, tuple(lines))


def _number(label: str, cell: str, line: int, column: str, decimal_comma: bool) -> float:
    text = cell.strip()
    try:
        value = float(text.replace(",", ".") if decimal_comma else text)
    except ValueError:
        what = "is empty" if not text else f"'{text}' is not a number"
        raise DataFileError(label, what, line=line, column=column) from None
    if not math.isfinite(value):
        raise DataFileError(label, f"'{text}' is not a finite number", line=line, column=column)
    return value


def read_points_and_joints(points_path: str | Path, joints_path: str | Path,
                           model: SerialModel, *, joint_unit: str = "deg",
                           length_unit: str = "mm",
                           joint_convention: JointConvention = "serial") -> MeasurementSet:
    """A point export and its joints file (see the module) as measurements of positions."""
    export = read_point_export(points_path, length_unit)
    table = read_numeric_csv(joints_path, joint_columns(model.n_joints))
    with_ids = _has_id_column(Path(joints_path))
    if with_ids:
        where = {n: k for k, n in enumerate(export.names)}
        absent = [i for i in table.ids if i not in where]
        if absent:
            raise DataFileError(str(joints_path), f"{len(absent)} joint row(s) have no point of "
                                f"that name in {points_path} (first: {absent[0]!r})")
        rows = [where[i] for i in table.ids]
    else:
        if len(table.ids) != len(export.names):
            raise DataFileError(str(joints_path), f"{len(table.ids)} joint rows for "
                                f"{len(export.names)} points in {points_path}: give both an id "
                                "column (the point names) or the same count in the same order")
        rows = list(range(len(export.names)))
    q_deg = table.take(joint_columns(model.n_joints))
    if joint_unit == "rad":
        q_deg = np.where(model.is_revolute, np.degrees(q_deg), q_deg)
    positions = export.points_mm[rows]
    check_units(str(points_path), model, q_deg, positions, joint_unit, length_unit)
    q = model.joints_from_deg(serial_from_readings(q_deg, joint_convention))
    outside = np.flatnonzero(np.logical_not(model.within_limits(q)))
    if outside.size:
        raise DataFileError(str(joints_path), f"joint values outside the limits of model "
                            f"'{model.name}'", line=table.lines[int(outside[0])])
    cov = None if export.u95_mm is None else covariance_of_u95(export.u95_mm[rows])
    return MeasurementSet(q, positions, None, tuple(export.names[k] for k in rows),
                          tuple(export.lines[k] for k in rows), previous_rows(q),
                          position_cov_mm2=cov)


def covariance_of_u95(u95_mm: Array) -> Array:
    """The covariances (N, 3, 3) mm^2 of points stated by their expanded uncertainty U95 (N,)
    mm (k = 2, every direction alike): (U95 / 2)^2 I."""
    sigma = np.asarray(u95_mm, dtype=float) / 2.0
    return (sigma**2)[:, None, None] * np.eye(3)


def _has_id_column(path: Path) -> bool:
    with path.open(newline="", encoding="utf-8-sig") as handle:
        header = next(csv.reader(handle), [])
    return "id" in [h.strip() for h in header]
