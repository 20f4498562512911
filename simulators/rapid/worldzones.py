"""World Zones (RobotWare option): a program's zone definitions and supervision are accepted and
do nothing here (the emulated controller supervises no zone); the event log says so once per
task, when the first one runs.

Instructions: WZBoxDef, WZCylDef, WZSphDef, WZHomeJointDef, WZLimJointDef (define a shape),
WZLimSup, WZDOSet (activate supervision), WZEnable, WZDisable, WZFree (a temporary zone);
data: wzstationary, wztemporary, shapedata (`values.WORLD_ZONE_TYPES`).
"""

from __future__ import annotations

from typing import Any

from simulators.rapid.builtins import builtin

INSTRUCTIONS = ("WZBoxDef", "WZCylDef", "WZSphDef", "WZHomeJointDef", "WZLimJointDef",
                "WZLimSup", "WZDOSet", "WZEnable", "WZDisable", "WZFree")
NOTE = ("World Zones", "zones are accepted and not supervised by this emulated controller")


def note_once(task: Any) -> None:
    """The event log's one entry about World Zones for this task."""
    noted: set[str] = task.services.setdefault("noted", set())
    if "worldzones" not in noted:
        noted.add("worldzones")
        task.log.write("info", *NOTE)


def _accepted(task: Any, pos: list, opt: dict) -> None:
    note_once(task)


for _name in INSTRUCTIONS:
    builtin(_name, "proc", opts=None)(_accepted)
