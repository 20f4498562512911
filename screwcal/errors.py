"""The exception tree of the core.

    ScrewcalError
    ├── ModelError            a serial model or model file is invalid
    ├── DataFileError         an input file is refused (names file, line and column)
    ├── UnreachableError      an IK target cannot be reached by any branch
    └── JointLimitError       a joint value lies outside the model's limits
"""


class ScrewcalError(Exception):
    """Base of every error the core raises on purpose."""


class ModelError(ScrewcalError):
    """A serial model, or the file it came from, is invalid."""


class DataFileError(ScrewcalError):
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


class UnreachableError(ScrewcalError):
    """An inverse-kinematics target has no solution; `index` is the first such target."""

    def __init__(self, message: str, index: int | None = None):
        super().__init__(message)
        self.index = index


class JointLimitError(ScrewcalError):
    """Joint values outside the model's joint limits; `index` is the first such configuration."""

    def __init__(self, message: str, index: int | None = None):
        super().__init__(message)
        self.index = index
