"""The job service (FastAPI): robots, jobs, progress as server-sent events, the operator's
go-ahead, abort, measurements, results and a report page.

`create_app(settings)` builds the app; nothing is created at import. Requests that can move a
robot or change data need `Authorization: Bearer <token>` (401 without, 403 with a wrong one,
and 403 always when no token is configured).
"""

from __future__ import annotations

import asyncio
import json
import secrets
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Annotated, Any

from fastapi import APIRouter, Depends, FastAPI, Header, HTTPException, Path, Query, Request, status
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, JSONResponse, StreamingResponse
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from fastapi.staticfiles import StaticFiles
from swagger_ui_bundle import swagger_ui_path

from screwcal.calibration.blas_threads import hold_one_blas_thread
from screwcal.errors import ScrewcalError
from screwcal.kinematics.modelfile import model_document, parse_model
from screwcal.kinematics.robots import BUILTIN_MODELS, builtin_model
from service.document import JobRecord
from service.errors import ConflictError, NotFoundError, SafetyError, StoreError, StoreLostError
from service.manager import JobManager
from service.plans import LISTS_OF_KIND, plan_for
from service.report import report_html
from service.schemas import (
    SQLITE_MAX_ID,
    GoAhead,
    JobCreate,
    JobPublic,
    JobResult,
    MeasurementPublic,
    RobotCreate,
    RobotPublic,
)
from service.settings import ServiceSettings
from service.store import Store, open_store

TERMINAL = ("done", "failed", "aborted")


BEARER = HTTPBearer(auto_error=False, description="the service's token (--token or "
                    "SCREWCAL_TOKEN)")


def _check_token(request: Request, credentials: HTTPAuthorizationCredentials | None,
                 accepted: tuple[str, ...]) -> None:
    if credentials is None or credentials.scheme.lower() != "bearer":
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, "bearer token required",
                            headers={"WWW-Authenticate": "Bearer"})
    given = credentials.credentials.encode()
    if not any(t and secrets.compare_digest(given, t.encode()) for t in accepted):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "token refused")


def authorised(request: Request,
               credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(BEARER)]
               ) -> None:
    """Requests that move a robot or change data carry the settings' bearer token (declared in
    the OpenAPI, so that /docs' "Authorize" works)."""
    _check_token(request, credentials, (request.app.state.settings.token,))


def may_read(request: Request,
             credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(BEARER)]
             ) -> None:
    """Reads (hosts, arm URLs, every measurement) need a token too: the service's, or the
    read-only one."""
    settings = request.app.state.settings
    _check_token(request, credentials, (settings.token, settings.read_token))


def store_of(request: Request) -> Store:
    return request.app.state.store


def manager_of(request: Request) -> JobManager:
    return request.app.state.manager


Auth = Annotated[None, Depends(authorised)]
Read = Annotated[None, Depends(may_read)]
# Ids in paths are SQLite integers: a larger number names nothing, and gets a 422, not a 500.
JobId = Annotated[int, Path(ge=1, le=SQLITE_MAX_ID, description="a job's id")]
RobotId = Annotated[int, Path(ge=1, le=SQLITE_MAX_ID, description="a robot's id")]
StoreDep = Annotated[Store, Depends(store_of)]
ManagerDep = Annotated[JobManager, Depends(manager_of)]


def create_app(settings: ServiceSettings, store: Store | None = None,
               on_fatal: Callable[[str], None] | None = None) -> FastAPI:
    """The app; `store` an already opened store (the service opens it before it binds, so that
    a database another service holds is refused at once), `on_fatal` what stops the service when
    its database is lost (the server's shutdown; without it, requests then get 503)."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        own = store if store is not None else open_store(settings)
        manager = JobManager(own, settings, on_fatal=on_fatal)
        app.state.store, app.state.manager, app.state.settings = own, manager, settings
        app.state.planning = set()  # robots whose job is being planned by a request now
        app.state.plans = asyncio.Semaphore(settings.max_concurrent_plans)
        manager.resume_unfinished()
        # one BLAS thread for the service's whole life: jobs call BLAS in many worker threads
        # at once, a limit set and restored around each identification left the others the
        # spinning default pools (screwcal/calibration/blas_threads.py)
        with hold_one_blas_thread():
            yield
            await manager.stop()
        own.close()

    app = FastAPI(title="screwcal job service", version="1", lifespan=lifespan,
                  docs_url=None, redoc_url=None,
                  description="Sequences performance and calibration pose lists, persists every "
                              "measurement, runs the estimation per job (mm and degrees).")
    # /docs from the files installed with the package: a cell network has no internet.
    app.mount("/static/swagger", StaticFiles(directory=str(swagger_ui_path)), name="swagger")
    app.openapi_version = "3.0.3"  # what the bundled Swagger UI (4.15) renders

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        return get_swagger_ui_html(openapi_url=str(app.openapi_url), title=f"{app.title} - docs",
                                   swagger_js_url="/static/swagger/swagger-ui-bundle.js",
                                   swagger_css_url="/static/swagger/swagger-ui.css",
                                   swagger_favicon_url="/static/swagger/favicon-32x32.png")

    @app.exception_handler(NotFoundError)
    async def not_found(_: Request, err: NotFoundError) -> JSONResponse:
        return JSONResponse({"detail": str(err)}, status_code=404)

    @app.exception_handler(ConflictError)
    async def conflict(_: Request, err: ConflictError) -> JSONResponse:
        return JSONResponse({"detail": str(err)}, status_code=409)

    @app.exception_handler(RequestValidationError)
    async def invalid(_: Request, err: RequestValidationError) -> JSONResponse:
        """Every refused request gets its reasons, even when its input cannot be echoed back
        (a NaN is not JSON): where and what, never the value."""
        detail = [{"loc": list(e.get("loc", ())), "msg": str(e.get("msg", "")),
                   "type": str(e.get("type", ""))} for e in err.errors()]
        return JSONResponse({"detail": detail}, status_code=422)

    @app.exception_handler(SafetyError)
    async def unsafe(_: Request, err: SafetyError) -> JSONResponse:
        return JSONResponse({"detail": str(err)}, status_code=422)

    @app.exception_handler(StoreError)
    async def store_unusable(request: Request, err: StoreError) -> JSONResponse:
        if isinstance(err, StoreLostError):
            request.app.state.manager.fatal(str(err))
        return JSONResponse({"detail": str(err)}, status_code=503)

    robots = APIRouter(prefix="/robots", tags=["robots"])

    @robots.post("", status_code=201, response_model=RobotPublic)
    def create_robot(body: RobotCreate, _: Auth, store: StoreDep) -> dict:
        if isinstance(body.model, str) and body.model not in BUILTIN_MODELS:
            # never a path on the server: not opened, and one message whatever the path
            raise HTTPException(422, f"model: {body.model[:80]!r} is not a built-in robot "
                                f"({', '.join(sorted(BUILTIN_MODELS))}); send the model "
                                "itself as a JSON document (`screwcal job robot-add --model "
                                "FILE` reads FILE on your side and sends it)")
        try:
            model = builtin_model(body.model) if isinstance(body.model, str) else \
                parse_model(body.model, "model")
        except ScrewcalError as err:
            raise HTTPException(422, f"model: {err}") from None
        doc = model_document(model)
        return store.add_robot(body.name, body.controller_host, body.controller_port,
                               body.arm_url, doc, body.holes_mm)

    @robots.get("", response_model=list[RobotPublic])
    def list_robots(_: Read, store: StoreDep) -> list[dict]:
        return store.robots()

    @robots.get("/{robot_id}", response_model=RobotPublic)
    def get_robot(robot_id: RobotId, _: Read, store: StoreDep) -> dict:
        return store.robot(robot_id)

    jobs = APIRouter(prefix="/jobs", tags=["jobs"])

    def public(job: JobRecord, manager: JobManager) -> JobPublic:
        runner = manager.runners.get(job.id)
        return JobPublic.of(job, runner.gate.waiting_for if runner is not None else None)

    @jobs.post("", status_code=202, response_model=JobPublic)
    async def create_job(body: JobCreate, _: Auth, request: Request, store: StoreDep,
                         manager: ManagerDep) -> JobPublic:
        """One unfinished job per robot: refused at once when the robot has one or another
        request is planning one for it; the database's unique index decides in the end (a
        second service on a server database included)."""
        robot = store.robot(body.robot_id)
        busy = store.unfinished_job(body.robot_id)
        if busy is not None:
            raise ConflictError(f"robot {body.robot_id} is busy with job {busy}: wait for it to "
                                f"end or abort it (screwcal job abort {busy})")
        planning: set[int] = request.app.state.planning
        if body.robot_id in planning:
            raise ConflictError(f"robot {body.robot_id} is busy: another request is starting a "
                                "job on it")
        planning.add(body.robot_id)
        try:
            return await _plan_and_add(body, robot, store, manager, request.app.state.plans)
        finally:
            planning.discard(body.robot_id)

    async def _plan_and_add(body: JobCreate, robot: dict, store: Store, manager: JobManager,
                            plans: asyncio.Semaphore) -> JobPublic:
        source = body.options.frame_from_job
        if source is not None and not store.job(source).result.base:
            raise HTTPException(422, f"job {source} has no identified robot base frame to "
                                "measure in: choose a calibration or procedure job that ran "
                                "its estimation")
        try:  # a job that cannot run is refused now, with the reason, not at run time
            model = parse_model(robot["model"], f"robot {body.robot_id}")
            async with plans:  # a bounded number of plans at once: each takes a worker thread
                for kind in LISTS_OF_KIND[body.kind]:
                    await asyncio.to_thread(plan_for, model, kind, body.options)
        except ScrewcalError as err:
            raise HTTPException(422, f"this job cannot run on robot {body.robot_id}: "
                                f"{err}") from None
        job = store.add_job(body.robot_id, body.kind, body.mode, body.options.model_dump())
        manager.start(job.id)
        return public(job, manager)

    @jobs.get("", response_model=list[JobPublic])
    def list_jobs(_: Read, store: StoreDep, manager: ManagerDep) -> list[JobPublic]:
        return [public(j, manager) for j in store.jobs()]

    @jobs.get("/{job_id}", response_model=JobPublic)
    def get_job(job_id: JobId, _: Read, store: StoreDep, manager: ManagerDep) -> JobPublic:
        return public(store.job(job_id), manager)

    @jobs.post("/{job_id}/go", status_code=204)
    async def go_ahead(job_id: JobId, body: GoAhead, _: Auth, manager: ManagerDep) -> None:
        await manager.go(job_id, body.index)

    @jobs.post("/{job_id}/abort", status_code=204)
    async def abort(job_id: JobId, _: Auth, manager: ManagerDep) -> None:
        await manager.abort(job_id)

    @jobs.get("/{job_id}/measurements", response_model=list[MeasurementPublic])
    def measurements(job_id: JobId, _: Read, store: StoreDep,
                     phase: str | None = None) -> list[dict]:
        store.job(job_id)
        return store.measurements(job_id, phase)

    @jobs.get("/{job_id}/result", response_model=JobResult, response_model_exclude_unset=True)
    def result(job_id: JobId, _: Read, store: StoreDep) -> JobResult:
        return JobResult.of(store.job(job_id))

    @jobs.get("/{job_id}/model", responses={200: {"description": (
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

    @jobs.get("/{job_id}/report", response_class=HTMLResponse)
    async def report(job_id: JobId, _: Read, store: StoreDep) -> str:
        job = store.job(job_id)
        return await asyncio.to_thread(report_html, job, store.robot(job.robot_id))

    @jobs.get("/{job_id}/events", response_class=StreamingResponse, responses={200: {
        "content": {"text/event-stream": {}},
        "description": "server-sent events: first the job's state, then measured, waiting, "
                       "phase, paused, resumed, corrected, warning, done/failed/aborted, then "
                       "end; each event has an id, and Last-Event-ID resumes after it"}})
    async def events(job_id: JobId, _: Read, store: StoreDep, manager: ManagerDep,
                     last_event_id: Annotated[str | None, Header(alias="Last-Event-ID")] = None
                     ) -> StreamingResponse:
        store.job(job_id)
        bus = manager.events.of(job_id)
        boot = manager.events.boot
        start = 0  # Last-Event-ID "BOOT-SEQ" of this run: go on after it; else from the start
        if last_event_id and last_event_id.startswith(f"{boot}-"):
            seq = last_event_id.split("-", 1)[1]
            if not seq.isdigit() or int(seq) >= len(bus.items):
                raise HTTPException(400, f"Last-Event-ID {last_event_id!r} names no event of "
                                    f"this job's stream (ids {boot}-0 to {boot}-"
                                    f"{len(bus.items) - 1}); reconnect without it for the "
                                    "whole stream")
            start = int(seq) + 1

        def frame(event: dict, seq: int | None) -> str:
            head = f"id: {boot}-{seq}\n" if seq is not None else ""
            return f"{head}data: {json.dumps(event)}\n\n"

        async def stream() -> AsyncIterator[str]:
            # First the job as it stands (a client that re-attaches, or comes after a restart,
            # knows where it is and what it waits for), then the events.
            job = public(store.job(job_id), manager).model_dump()
            yield frame({**job, "kind": "state", "job_kind": job["kind"]}, None)
            sent = start
            while True:
                while sent < len(bus.items):
                    yield frame(bus.items[sent], sent)
                    sent += 1
                state = store.job(job_id).state
                if state in TERMINAL and sent >= len(bus.items):
                    yield frame({"kind": "end", "state": state}, None)
                    return
                if not await bus.wait_beyond(sent, 1.0):
                    yield ": keep-alive\n\n"

        return StreamingResponse(stream(), media_type="text/event-stream")

    app.include_router(robots)
    app.include_router(jobs)
    return app
