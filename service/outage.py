"""A job's calls of the store that wait out the store's outages (service/errors.py:
StoreUnavailableError: a full disk, an I/O error such as a file-size limit, a read-only file, a
lost PostgreSQL connection) instead of ending the job.

The call that failed is made again every `retry_s` until it succeeds (the database reconnects by
itself, service/database.py); meanwhile the job is paused with the cause (stored when the store
takes that much, else said by the API from here, and in the job's events), and the robot waits
where it is: a pose's commit that failed is the very call retried, so nothing is measured twice
and nothing moves before its pose is committed. Every call made through here runs in a worker
thread: the event loop never waits on the store.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Any, TypeVar

from service.errors import StoreUnavailableError
from service.events import JobEvents
from service.job_state import JobState, JobStateError
from service.store import Store

T = TypeVar("T")


class StoreOutage:
    """One job's store calls; `reason` is why the job waits for its store now (None: it
    does not)."""

    def __init__(self, store: Store, events: JobEvents, job_id: int, retry_s: float):
        self.store, self.events, self.job_id, self.retry_s = store, events, job_id, retry_s
        self.reason: str | None = None

    async def call(self, fn: Callable[..., T], /, *args: Any) -> T:
        """`fn(*args)` in a worker thread, made again until the store takes it."""
        while True:
            try:
                result = await asyncio.to_thread(fn, *args)
            except StoreUnavailableError as err:
                await self.pause(err)
                await asyncio.sleep(self.retry_s)
                continue
            if self.reason is not None:
                with contextlib.suppress(StoreUnavailableError):  # done: the next call says
                    await self._resumed()
            return result

    async def wait(self, err: StoreUnavailableError) -> None:
        """A step failed on the store (`err`): pause, and return once the store takes a write
        again (the job's state back to running)."""
        await self.pause(err)
        while self.reason is not None:
            await asyncio.sleep(self.retry_s)
            with contextlib.suppress(StoreUnavailableError):
                await self._resumed()

    async def pause(self, err: StoreUnavailableError) -> None:
        if self.reason == str(err):
            return
        self.reason = str(err)
        with contextlib.suppress(StoreUnavailableError):  # said from memory when not stored
            await asyncio.to_thread(self.store.set_state, self.job_id, JobState.PAUSED,
                                    self.reason)
        await self.events.publish(JobState.PAUSED, reason=self.reason)

    async def _resumed(self) -> None:
        """The store is back: the job runs again (a job the retried call ended stays ended)."""
        with contextlib.suppress(JobStateError):
            await asyncio.to_thread(self.store.set_state, self.job_id, JobState.RUNNING, "")
        self.reason = None
        await self.events.publish("resumed", cause="the database is back")
