"""/jobs/ID/events: a job's progress as server-sent events, resumable with Last-Event-ID."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Annotated, Any

from fastapi import APIRouter, Header, HTTPException
from fastapi.responses import StreamingResponse

from service.api.deps import JobId, ManagerDep, Read, StoreDep, public
from service.job_state import FINISHED, JobState

router = APIRouter(prefix="/jobs", tags=["jobs"])


@router.get("/{job_id}/events", response_class=StreamingResponse, responses={200: {
    "content": {"text/event-stream": {}},
    "description": "server-sent events: first the job's state, then measured, waiting, "
                   "phase, paused, resumed, corrected, warning, done/failed/aborted, then "
                   "end; each event has an id, and Last-Event-ID resumes after it"}})
async def events(job_id: JobId, _: Read, store: StoreDep, manager: ManagerDep,
                 last_event_id: Annotated[str | None, Header(alias="Last-Event-ID")] = None
                 ) -> StreamingResponse:
    first = await asyncio.to_thread(store.job, job_id)  # 404 for no such job
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

    def frame(event: dict[str, Any], seq: int | None) -> str:
        head = f"id: {boot}-{seq}\n" if seq is not None else ""
        return f"{head}data: {json.dumps(event)}\n\n"

    async def stream() -> AsyncIterator[str]:
        # First the job as it stands (a client that re-attaches, or comes after a restart,
        # knows where it is and what it waits for), then the events. The job's end is told by
        # its events (a stale runner's by the store): an open stream never waits on the store.
        job = public(first, manager).model_dump()
        yield frame({**job, "kind": "state", "job_kind": job["kind"]}, None)
        # the stream ends with the job: its end is the event named for its final state
        state = first.state
        ended = [e["kind"] for e in bus.items[:start] if e["kind"] in FINISHED]
        if ended:  # resumed after the job's end
            state = JobState(ended[-1])
        sent = start
        while True:
            while sent < len(bus.items):
                event = bus.items[sent]
                yield frame(event, sent)
                sent += 1
                if event["kind"] in FINISHED:
                    state = JobState(event["kind"])
                elif event["kind"] == "stale":  # another runner ended the job: as stored
                    state = (await asyncio.to_thread(store.job, job_id)).state
            if state.finished and sent >= len(bus.items):
                yield frame({"kind": "end", "state": state}, None)
                return
            if not await bus.wait_beyond(sent, 1.0):
                yield ": keep-alive\n\n"

    return StreamingResponse(stream(), media_type="text/event-stream")
