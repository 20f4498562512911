"""/robots: the cells the service knows (a robot's controller, measuring arm, model, flange)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException

from screwcal.errors import ScrewcalError
from screwcal.kinematics.modelfile import model_document, parse_model
from screwcal.kinematics.robots import BUILTIN_MODELS, builtin_model
from service.api.deps import Auth, Read, RobotId, StoreDep
from service.robot_record import RobotRecord
from service.schemas import RobotCreate, RobotPublic
from service.store import IDENTITY

router = APIRouter(prefix="/robots", tags=["robots"])


@router.post("", status_code=201, response_model=RobotPublic)
def create_robot(body: RobotCreate, _: Auth, store: StoreDep) -> RobotRecord:
    if isinstance(body.model, str) and body.model not in BUILTIN_MODELS:
        # never a path on the server: not opened, and one message whatever the path
        raise HTTPException(422, f"model: {body.model[:80]!r} is not a built-in robot "
                            f"({', '.join(sorted(BUILTIN_MODELS))}); send the model "
                            "itself as a JSON document (`screwcal job robot-add --robot "
                            "FILE` reads FILE on your side and sends it)")
    try:
        model = builtin_model(body.model) if isinstance(body.model, str) else \
            parse_model(body.model, "model")
    except ScrewcalError as err:
        raise HTTPException(422, f"model: {err}") from None
    doc = model_document(model)
    return store.add_robot(body.name, body.controller_host, body.controller_port,
                           body.setup, doc, body.holes_mm,
                           body.model_dump(include=set(IDENTITY)), body.emulation)

@router.get("", response_model=list[RobotPublic])
def list_robots(_: Read, store: StoreDep) -> list[RobotRecord]:
    return store.robots()

@router.get("/{robot_id}", response_model=RobotPublic)
def get_robot(robot_id: RobotId, _: Read, store: StoreDep) -> RobotRecord:
    return store.robot(robot_id)
