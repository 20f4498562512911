"""Reading and writing the CSV files of the offline contract (docs/formats.md).

Readers check everything at the edge and raise DataFileError naming the file, the line and the
column; writers write to a temporary file and rename it, so a refused input writes nothing.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from screwcal.errors import DataFileError
from screwcal.kinematics.se3 import Array


@dataclass(frozen=True)
class NumericTable:
    """Numeric columns of a CSV file: values (N, k) in `columns` order, ids, file line numbers."""

    path: str
    columns: tuple[str, ...]
    values: Array
    ids: tuple[str, ...]
    lines: tuple[int, ...]
    text: dict[str, tuple[str, ...]] = field(default_factory=dict)  # required text columns

    def column(self, name: str) -> Array:
        return self.values[:, self.columns.index(name)]

    def take(self, names: Sequence[str]) -> Array:
        return self.values[:, [self.columns.index(c) for c in names]]


def read_numeric_csv(path: str | Path, required: Sequence[str],
                     optional_groups: Sequence[Sequence[str]] = (), min_rows: int = 1,
                     text_columns: Sequence[str] = ()) -> NumericTable:
    """Read a CSV with a header row; columns in any order, extra columns ignored.

    `required` numeric columns must all be present; each group of `optional_groups` is either
    wholly present or wholly absent (and, when present, filled on every row). An `id` column is
    optional; without it ids are the 1-based data row numbers. `text_columns` are required,
    non-empty and kept as text.
    """
    path = Path(path)
    label = str(path)
    try:
        handle = path.open(newline="", encoding="utf-8-sig")
    except FileNotFoundError:
        raise DataFileError(label, "file not found") from None
    except IsADirectoryError:
        raise DataFileError(label, "is a directory, not a CSV file") from None
    with handle:
        try:
            rows = list(csv.reader(handle))
        except (UnicodeDecodeError, csv.Error) as err:
            raise DataFileError(label, f"not a readable UTF-8 CSV file ({err})") from None
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise DataFileError(label, "the file is empty: expected a header row", line=1)
    header = [h.strip() for h in rows[0]]
    dupes = sorted({h for h in header if h and header.count(h) > 1})
    if dupes:
        raise DataFileError(label, f"duplicate column(s) {', '.join(dupes)} in the header", line=1)
    missing = [c for c in (*text_columns, *required) if c not in header]
    if missing:
        raise DataFileError(label, f"missing column(s) {', '.join(missing)}; the header has "
                            f"{', '.join(h for h in header if h) or 'nothing'}", line=1,
                            column=missing[0])
    columns = list(required)
    for group in optional_groups:
        present = [c for c in group if c in header]
        if present and len(present) != len(group):
            absent = [c for c in group if c not in header]
            raise DataFileError(label, f"columns {', '.join(group)} go together; "
                                f"{', '.join(absent)} missing", line=1, column=absent[0])
        columns += present
    index = {c: header.index(c) for c in columns}
    id_index = header.index("id") if "id" in header else None
    values: list[list[float]] = []
    ids: list[str] = []
    lines: list[int] = []
    texts: dict[str, list[str]] = {c: [] for c in text_columns}
    for lineno, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue  # blank line
        if len(row) < len(header):
            raise DataFileError(label, f"{len(row)} fields where the header has {len(header)}",
                                line=lineno)
        rec = []
        for c in columns:
            cell = row[index[c]].strip()
            try:
                v = float(cell)
            except ValueError:
                what = "is empty" if not cell else f"'{cell}' is not a number"
                raise DataFileError(label, what, line=lineno, column=c) from None
            if not math.isfinite(v):
                raise DataFileError(label, f"'{cell}' is not a finite number", line=lineno,
                                    column=c)
            rec.append(v)
        for c in text_columns:
            cell = row[header.index(c)].strip()
            if not cell:
                raise DataFileError(label, "is empty", line=lineno, column=c)
            texts[c].append(cell)
        values.append(rec)
        ids.append(row[id_index].strip() if id_index is not None else str(len(ids) + 1))
        lines.append(lineno)
    if len(values) < min_rows:
        raise DataFileError(label, f"{len(values)} data row(s); at least {min_rows} needed")
    return NumericTable(path=label, columns=tuple(columns), values=np.array(values, float),
                        ids=tuple(ids), lines=tuple(lines),
                        text={c: tuple(v) for c, v in texts.items()})


def write_csv_atomic(path: str | Path, header: Sequence[str], rows: Iterable[Sequence[object]]
                     ) -> None:
    """Write a CSV through a temporary file in the same folder, renamed into place at the end."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    write_text_atomic(path, buffer.getvalue().encode("utf-8"))


def write_text_atomic(path: str | Path, data: bytes) -> None:
    """Write bytes through a temporary file in the same folder, renamed into place at the end:
    a failure leaves the old file (or none), never half a file. The file gets the mode a new
    file gets under the user's umask, as every command's outputs do."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    except OSError as err:
        raise DataFileError(str(path), f"cannot write here ({err.strerror})") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            os.fchmod(handle.fileno(), _mode_from_umask())  # mkstemp's 0600 -> the user's
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _mode_from_umask() -> int:
    """0666 less the process's umask: the mode `open()` would give a new file."""
    mask = os.umask(0o022)  # reading the umask means setting it: put it back at once
    os.umask(mask)
    return 0o666 & ~mask


def write_json_atomic(path: str | Path, document: object) -> None:
    """A JSON document (indented, ending with a newline), written as `write_text_atomic`."""
    write_text_atomic(path, (json.dumps(document, indent=2) + "\n").encode("utf-8"))


# The length units a file may be written in, and mm per unit (--length-unit of the readers)
LENGTH_UNITS_MM = {"mm": 1.0, "m": 1000.0, "in": 25.4}
# Joint readings that all lie within +-this (deg) look like radians: no calibration set or
# performance test keeps every joint within a few degrees of zero
RADIAN_LOOKING_DEG = 3.2


def fixed_texts(values: Iterable[float], places: int) -> list[str]:
    """Numbers as a file writes them, `places` decimals (rounded as round(v, places) would):
    a value that rounds to zero is written "0.0000", never "-0.0000"."""
    return unsigned_zeros([f"{v:.{places}f}" for v in values])


def unsigned_zeros(texts: Iterable[str]) -> list[str]:
    """Formatted numbers with the minus of a zero dropped ("-0.0000" -> "0.0000")."""
    return [t[1:] if t[0] == "-" and not t.strip("-0.") else t for t in texts]


def joint_columns(n: int) -> list[str]:
    return [f"q{i}" for i in range(1, n + 1)]


def direction_columns(n: int) -> list[str]:
    """The measurement file's optional approach directions dir1..dirn (+1, -1 or 0)."""
    return [f"dir{i}" for i in range(1, n + 1)]


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """A count as a person reads it: '1 pose', '0 poses', '3 poses' (never '1 poses');
    `plural` where adding an s is wrong ('1 axis', '2 axes')."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
