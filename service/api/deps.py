"""What a request depends on: who makes it (`auth`), the store, the job manager, ids in paths."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Path, Request

from service.api.auth import Who
from service.document import SQLITE_MAX_ID, JobRecord
from service.instruments import ExternalInstrument
from service.job_state import JobState
from service.manager import JobManager
from service.schemas import JobPublic
from service.store import Store


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
    instrument = runner.acquisition.instrument
    wanted = instrument.wanted() if isinstance(instrument, ExternalInstrument) else None
    return JobPublic.of(job, runner.gate.waiting_for, wanted)


# Every route's grant is declared once, in service/roles.py: both names check it.
Auth = Who
Read = Who
# Ids in paths are SQLite integers: a larger number names nothing, and gets a 422, not a 500.
JobId = Annotated[int, Path(ge=1, le=SQLITE_MAX_ID, description="a job's id")]
RobotId = Annotated[int, Path(ge=1, le=SQLITE_MAX_ID, description="a robot's id")]
StoreDep = Annotated[Store, Depends(store_of)]
ManagerDep = Annotated[JobManager, Depends(manager_of)]
