"""A RAPID task's modules read together for the program filter: a robtarget declared in one
module may be moved to from another, in a tool and work object a third declares, and a
routine of the task may take the target as a parameter and move to it (`PROC Approach(robtarget
p) MoveL p, v200, z10, tGun \\WObj:=wTable;`): each call of such a routine moves to its
argument in that routine's tool and work object (or those its own arguments name).
"""

from __future__ import annotations

from collections.abc import Sequence

from screwcal.calibration.rapid_source import (
    RapidModule,
    module_of,
    parse_rapid,
    resolve_routine_motions,
    target_records,
)


def read_rapid_task(sources: Sequence[tuple[str, str]]) -> list[RapidModule]:
    """The modules of one task, (path, text) each: RECORD types of any module known to all,
    and motions through the task's routines resolved."""
    parsed = [parse_rapid(path, text) for path, text in sources]
    records = target_records(parsed)
    modules = [module_of(p, path, text, records)
               for p, (path, text) in zip(parsed, sources, strict=True)]
    resolve_routine_motions(modules)
    return modules
