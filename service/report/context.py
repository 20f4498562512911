"""What a section of the report reads."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from service.document import JobRecord, ResultDocument


@dataclass(frozen=True)
class ReportContext:
    """The job (its options, phases and result document) and the robot record. A section shows
    figures of the result document only: it never computes a figure the document does not
    hold (a chart draws the very numbers of the table beside it)."""

    job: JobRecord
    robot: dict[str, Any]

    @property
    def result(self) -> ResultDocument:
        return self.job.result


# A section: the HTML of one part of the report (`markup.section(...)`), or None when the job
# has nothing for it.
Section = Callable[[ReportContext], str | None]
