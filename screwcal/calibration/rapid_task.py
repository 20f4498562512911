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
from screwcal.rapid import RapidEncryptedError, RapidSyntaxError, parse_module
from screwcal.rapid import ast as rapid


def read_rapid_task(sources: Sequence[tuple[str, str]]) -> list[RapidModule]:
    """The modules of one task, (path, text) each: RECORD types of any module known to all,
    and motions through the task's routines resolved. An encrypted module is kept with why it
    cannot be read (`unreadable`): the filter leaves it as it is and says so."""
    parsed: list[rapid.Module | str] = []
    for path, text in sources:
        try:
            parsed.append(parse_module(text, path))
        except RapidEncryptedError as err:
            parsed.append(err.reason)
        except RapidSyntaxError:
            parsed.append(parse_rapid(path, text))  # raises DataFileError with its line
    readable = [p for p in parsed if not isinstance(p, str)]
    records = target_records(readable)
    modules = [RapidModule(path, text, unreadable=p) if isinstance(p, str) else
               module_of(p, path, text, records)
               for p, (path, text) in zip(parsed, sources, strict=True)]
    resolve_routine_motions(modules)
    return modules
