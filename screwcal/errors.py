"""The exception tree of the core: every error screwcal raises on purpose, defined here.

    ScrewcalError                 the root: `screwcal` commands print it and exit 2
    ├── InputError                what the user gave cannot be used: fix the input
    │   ├── ModelError            a serial model or model file is invalid
    │   │   └── DegenerateTableError   a DH table would need offsets far beyond the robot
    │   ├── DataFileError         an input file is refused (names file, line and column)
    │   │   └── DatasetMissingError    the real data set is not where it was looked for
    │   ├── FlangeError           probed holes that cannot define the flange frame
    │   ├── AlignmentError        sweep points that cannot give an axis
    │   └── IdentificationError   the data cannot identify what was asked
    ├── ExtraMissingError         an optional part is not installed: names the extra to install
    └── TargetRefusedError        a target the robot is not sent to: nothing moves
        ├── UnreachableError      an IK target cannot be reached by any branch
        ├── JointLimitError       a joint value lies outside the model's limits
        ├── CorrectionRefusedError  a correction beyond plausible bounds
        └── InfeasibleCubeError   no ISO 9283 test cube fits the workspace

Callers catch a family when they treat its members alike (`compensate_each` lists every
`TargetRefusedError` as a refused target); the protocol (`ProtocolError`) and the service
(`ServiceError`) keep their own roots, since the core imports neither.
"""

from __future__ import annotations


class ScrewcalError(Exception):
    """Base of every error the core raises on purpose."""


class InputError(ScrewcalError):
    """The user's input (a model, a file, measurements) cannot be used as given."""


class ExtraMissingError(ScrewcalError):
    """An optional part of screwcal (a Dask cluster, a PostgreSQL store) was asked for and its
    library is not installed; the message names the extra that installs it."""


class TargetRefusedError(ScrewcalError):
    """A target the robot is not sent to; `index` is the first such target, when known."""

    def __init__(self, message: str, index: int | None = None):
        super().__init__(message)
        self.index = index


class ModelError(InputError):
    """A serial model, or the file it came from, is invalid."""


class DegenerateTableError(ModelError):
    """A standard DH table would need offsets far beyond the robot (near-parallel axes)."""


class DataFileError(InputError):
    """An input data file is refused; the message names the file, the line and the column."""

    def __init__(self, path: str, message: str, line: int | None = None, column: str | None = None):
        where = str(path)
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column '{column}'"
        super().__init__(f"{where}: {message}")
        self.path = str(path)
        self.line = line
        self.column = column


class DatasetMissingError(DataFileError):
    """The real data set is not where it was looked for; the message says where to get it."""


class FlangeError(InputError):
    """Probed holes that cannot define the flange frame."""


class AlignmentError(InputError):
    """Sweep points that cannot give an axis."""


class IdentificationError(InputError):
    """The identification cannot run on these data (too few poses, nothing identifiable)."""


class UnreachableError(TargetRefusedError):
    """An inverse-kinematics target has no solution; `index` is the first such target."""


class JointLimitError(TargetRefusedError):
    """Joint values outside the model's joint limits; `index` is the first such configuration."""


class CorrectionRefusedError(TargetRefusedError):
    """A correction outside plausible bounds: nothing is sent. `index`: the target refused."""


class InfeasibleCubeError(TargetRefusedError):
    """No cube of the requested size fits the robot's workspace (and the arm's sphere)."""
