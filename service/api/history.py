"""/robots/{id}/history and /robots/{id}/identity: a robot's jobs with their provenance, its
model versions, its accuracy trend and drift alarm (service/history.py); its identity as it
changes (controller software, tool, payload)."""

from __future__ import annotations

from fastapi import APIRouter, Request

from service.api.deps import Auth, Read, RobotId, StoreDep
from service.history import RobotHistory, robot_history
from service.robot_record import RobotRecord
from service.schemas import RobotIdentity, RobotPublic

router = APIRouter(prefix="/robots", tags=["robots"])


@router.get("/{robot_id}/history", response_model=RobotHistory)
def history(robot_id: RobotId, _: Read, request: Request, store: StoreDep) -> RobotHistory:
    return robot_history(store, robot_id, request.app.state.settings.drift_alarm_mm)


@router.put("/{robot_id}/identity", response_model=RobotPublic)
def set_identity(robot_id: RobotId, body: RobotIdentity, _: Auth, store: StoreDep
                 ) -> RobotRecord:
    return store.set_identity(robot_id, body.model_dump(exclude_none=True))
