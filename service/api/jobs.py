"""/jobs: start a job, follow it, let it move, abort it, read its measurements, result,
calibrated model and report page."""

from __future__ import annotations

import asyncio
import hashlib
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.responses import HTMLResponse

from screwcal.errors import InputError, ScrewcalError
from screwcal.kinematics.modelfile import parse_model
from service.api.auth import require
from service.api.deps import Auth, JobId, ManagerDep, Read, StoreDep, public
from service.audit import Event
from service.errors import ConflictError, NotFoundError, ServiceError
from service.manager import JobManager
from service.phases import STEP_OF, Action
from service.plans import LISTS_OF_KIND, plan_for
from service.report import report_html
from service.robot_record import RobotRecord
from service.roles import OPERATOR_JOB_KINDS, Grant
from service.schemas import (
    GoAhead,
    JobCreate,
    JobPublic,
    JobResult,
    MeasurementPost,
    MeasurementPublic,
)
from service.store import Store
from service.verify import verify_options

router = APIRouter(prefix="/jobs", tags=["jobs"])


@router.post("", status_code=202, response_model=JobPublic)
async def create_job(body: JobCreate, who: Auth, request: Request, store: StoreDep,
                     manager: ManagerDep) -> JobPublic:
    """One unfinished job per robot: refused at once when the robot has one or another
    request is planning one for it; the database's unique index decides in the end (a
    second service on a server database included). An operator may start performance and
    verify jobs; the other kinds calibrate the robot and need an engineer."""
    if body.kind not in OPERATOR_JOB_KINDS:
        require(who, Grant.CALIBRATE)
    robot, body = await asyncio.to_thread(_admit, store, body)
    planning: set[int] = request.app.state.planning
    if body.robot_id in planning:
        raise ConflictError(f"robot {body.robot_id} is busy: another request is starting a "
                            "job on it")
    planning.add(body.robot_id)
    try:
        return await _plan_and_add(body, robot, store, manager, request.app.state.plans)
    finally:
        planning.discard(body.robot_id)


def _admit(store: Store, body: JobCreate) -> tuple[RobotRecord, JobCreate]:
    """The store's checks of a new job (in a worker thread): its robot exists and is not busy,
    a verify job's options from the robot's newest model, a frame's source job has one."""
    robot = store.robot(body.robot_id)
    busy = store.unfinished_job(body.robot_id)
    if busy is not None:
        raise ConflictError(f"robot {body.robot_id} is busy with job {busy}: wait for it to "
                            f"end or abort it (screwcal job abort {busy})")
    if body.kind == "verify":  # the robot's newest model: its frame, its targets
        body = body.model_copy(update={"options": verify_options(store, body.robot_id,
                                                                 body.options)})
    source = body.options.frame_from_job
    if source is not None and not store.job(source).result.base:
        raise HTTPException(422, f"job {source} has no identified robot base frame to "
                            "measure in: choose a calibration or procedure job that ran "
                            "its estimation")
    return robot, body


async def _plan_and_add(body: JobCreate, robot: RobotRecord, store: Store, manager: JobManager,
                        plans: asyncio.Semaphore) -> JobPublic:
    try:  # a job that cannot run is refused now, with the reason, not at run time
        model = parse_model(robot.model, f"robot {body.robot_id}")
        async with plans:  # a bounded number of plans at once: each takes a worker thread
            built = {kind: await asyncio.to_thread(plan_for, model, kind, body.options,
                                                   robot.instrument)
                     for kind in LISTS_OF_KIND[body.kind]}
    except ScrewcalError as err:
        raise HTTPException(422, f"this job cannot run on robot {body.robot_id}: "
                            f"{err}") from None
    job = await asyncio.to_thread(store.add_job, body.robot_id, body.kind, body.mode,
                                  body.options.model_dump())
    await manager.start(job.id, built)  # the runner's plans: built once, here, off the loop
    return public(job, manager)

@router.get("", response_model=list[JobPublic])
def list_jobs(_: Read, store: StoreDep, manager: ManagerDep) -> list[JobPublic]:
    return [public(j, manager) for j in store.jobs()]

@router.get("/{job_id}", response_model=JobPublic)
def get_job(job_id: JobId, _: Read, store: StoreDep, manager: ManagerDep) -> JobPublic:
    return public(store.job(job_id), manager)

@router.post("/{job_id}/go", status_code=204)
async def go_ahead(job_id: JobId, body: GoAhead, who: Auth, manager: ManagerDep) -> None:
    """The go-ahead, given by the signed-in user (the name kept in the job's provenance); the
    go-ahead of a ZERO needs the ZERO grant (an engineer)."""
    runner = manager.runners.get(job_id)
    waiting = runner.gate.waiting_for if runner is not None else None
    step = STEP_OF.get(waiting[0]) if waiting is not None else None
    if step is not None and step.action is Action.CORRECT:
        require(who, Grant.ZERO)
    name = body.operator if who.legacy else who.name  # a shared token names nobody
    await manager.go(job_id, body.index, name)

@router.post("/{job_id}/measurement", status_code=202, responses={
    200: {"description": "the same measurement was posted already: nothing changed"},
    409: {"description": "the job waits for no such pose, or the pose was measured otherwise"},
    422: {"description": "not a measurement of the robot's targets"}})
async def post_measurement(job_id: JobId, body: MeasurementPost, who: Auth, request: Request,
                           response: Response, manager: ManagerDep) -> dict[str, Any]:
    """The measurement of the pose a job waits for (its `measurement_for`), from another
    instrument's software (SpatialAnalyzer, PolyWorks, a FARO or API SDK script): taken at
    once (202) and committed before the robot moves on; the same measurement posted again is
    200 and changes nothing; another one for a pose measured is 409. Each post is in the audit
    trail with a digest of what was sent."""
    where = f"job {job_id} {body.phase} pose {body.index}"
    try:
        measurement = body.measurement()
        taken = await manager.measurement(job_id, body.phase, body.index, measurement)
    except (ValueError, InputError) as err:
        await _audit_measurement(request, who.name, where, "422 refused", body, str(err))
        raise HTTPException(422, f"{where}: {err}") from None
    except ServiceError as err:
        await _audit_measurement(request, who.name, where, "refused", body, str(err))
        raise
    outcome = "taken" if taken else "the same measurement again: nothing changed"
    await _audit_measurement(request, who.name, where, outcome, body)
    response.status_code = 202 if taken else 200
    return {"job": job_id, "phase": body.phase, "index": body.index, "outcome": outcome}


async def _audit_measurement(request: Request, actor: str, where: str, outcome: str,
                             body: MeasurementPost, why: str = "") -> None:
    """The post in the audit trail: who, the pose, the outcome, and the SHA-256 of what was
    sent (its canonical JSON), so a measurement can be traced to its post."""
    trail = getattr(request.app.state, "audit", None)
    if trail is None:
        return
    digest = hashlib.sha256(body.model_dump_json().encode()).hexdigest()
    client = request.client
    await asyncio.to_thread(trail.append, Event(
        actor, client.host if client else "unknown", "measurement", where, outcome,
        f"sha256 {digest}; {len(body.points_mm)} points{'; ' + why if why else ''}"))


@router.post("/{job_id}/abort", status_code=204)
async def abort(job_id: JobId, _: Auth, manager: ManagerDep) -> None:
    await manager.abort(job_id)

@router.get("/{job_id}/measurements", response_model=list[MeasurementPublic])
def measurements(job_id: JobId, _: Read, store: StoreDep,
                 phase: str | None = None) -> list[dict]:
    store.job(job_id)
    return store.measurements(job_id, phase)

@router.get("/{job_id}/result", response_model=JobResult, response_model_exclude_unset=True)
def result(job_id: JobId, _: Read, store: StoreDep) -> JobResult:
    return JobResult.of(store.job(job_id))

@router.get("/{job_id}/model", responses={200: {"description": (
    "the calibration result document (format screwcal-calibration) whose `model` is the "
    "robot as its controller reads it after the job's correction; `screwcal predict`, "
    "`compensate` and the RAPID filter read it")}})
def calibrated_model(job_id: JobId, _: Read, store: StoreDep,
                     round: Annotated[int, Query(ge=1, le=2)] = 1) -> dict[str, Any]:
    doc = store.job(job_id).result.calibration_of("_2" if round == 2 else "")
    if doc is None:
        raise NotFoundError(f"job {job_id} has no calibrated model (round {round}): "
                            "a calibration or procedure job has one once its estimation ran")
    return doc

@router.get("/{job_id}/report", response_class=HTMLResponse)
def report(job_id: JobId, _: Read, store: StoreDep) -> str:
    """(A sync route: FastAPI runs it in its thread pool, the store's reads and the page.)"""
    job = store.job(job_id)
    return report_html(job, store.robot(job.robot_id).model_dump())
