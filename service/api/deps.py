"""What a request depends on: the bearer tokens, the store, the job manager, ids in paths."""

from __future__ import annotations

import secrets
from typing import Annotated

from fastapi import Depends, HTTPException, Path, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from service.document import SQLITE_MAX_ID, JobRecord
from service.job_state import JobState
from service.manager import JobManager
from service.schemas import JobPublic
from service.store import Store

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
    store: Store = request.app.state.store
    return store


def manager_of(request: Request) -> JobManager:
    manager: JobManager = request.app.state.manager
    return manager


def public(job: JobRecord, manager: JobManager) -> JobPublic:
    """A stored job as the API shows it, with the pose its runner waits for now; paused, with
    the cause, while its runner waits for a store that could not even store that."""
    runner = manager.runners.get(job.id)
    if runner is None:
        return JobPublic.of(job, None)
    outage = runner.outage.reason
    if outage is not None and not job.state.finished:
        job = job.model_copy(update={"state": JobState.PAUSED, "reason": outage})
    return JobPublic.of(job, runner.gate.waiting_for)


Auth = Annotated[None, Depends(authorised)]
Read = Annotated[None, Depends(may_read)]
# Ids in paths are SQLite integers: a larger number names nothing, and gets a 422, not a 500.
JobId = Annotated[int, Path(ge=1, le=SQLITE_MAX_ID, description="a job's id")]
RobotId = Annotated[int, Path(ge=1, le=SQLITE_MAX_ID, description="a robot's id")]
StoreDep = Annotated[Store, Depends(store_of)]
ManagerDep = Annotated[JobManager, Depends(manager_of)]
