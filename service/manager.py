"""The running jobs: one runner task per job, resumed after a restart."""

from __future__ import annotations

import asyncio
import contextlib
import sys
from collections.abc import Callable

from screwcal.errors import ScrewcalError
from service.errors import ConflictError, ServiceError
from service.events import EventBus
from service.runner import JobRunner
from service.settings import ServiceSettings
from service.store import Store


class JobManager:
    def __init__(self, store: Store, settings: ServiceSettings,
                 on_fatal: Callable[[str], None] | None = None):
        self.store, self.settings = store, settings
        self.events = EventBus()
        self.runners: dict[int, JobRunner] = {}
        self.tasks: dict[int, asyncio.Task[None]] = {}
        self._on_fatal = on_fatal
        self.fatal_reason: str | None = None

    def fatal(self, reason: str) -> None:
        """The database is gone: say why and stop the service (once)."""
        if self.fatal_reason is not None:
            return
        self.fatal_reason = reason
        print(f"screwcal service stops: {reason}", file=sys.stderr)
        if self._on_fatal is not None:
            self._on_fatal(reason)

    def start(self, job_id: int) -> bool:
        """Run a job; one whose records cannot make a runner (a robot stored before its fields
        were validated, say) fails with the reason instead. True when it runs."""
        try:
            runner = JobRunner(self.store, self.settings, self.events.of(job_id), job_id,
                               on_fatal=self.fatal)
        except (ScrewcalError, ServiceError, ValueError, KeyError, TypeError) as err:
            self.store.fail(job_id, f"cannot run: {err}")
            return False
        self.runners[job_id] = runner
        self.tasks[job_id] = asyncio.create_task(runner.run(), name=f"job {job_id}")
        return True

    def resume_unfinished(self) -> list[int]:
        """After a restart (or a crash): every unfinished job goes on where its store says;
        start-up never dies on one bad record."""
        return [j for j in self.store.unfinished_jobs() if self.start(j)]

    def busy_with(self, robot_id: int) -> int | None:
        """The unfinished job of this robot, if any."""
        return self.store.unfinished_job(robot_id)

    def runner(self, job_id: int) -> JobRunner:
        runner = self.runners.get(job_id)
        if runner is None or self.tasks[job_id].done():
            raise ConflictError(f"job {job_id} is not running")
        return runner

    async def go(self, job_id: int, index: int) -> None:
        gate = self.runner(job_id).gate
        waiting = gate.waiting_for
        if not gate.take(index):  # consumed now: a second go-ahead for this pose is refused
            raise ConflictError(f"job {job_id} is not waiting for pose {index} "
                                f"(waiting for {waiting})")

    async def abort(self, job_id: int) -> None:
        await self.runner(job_id).abort()

    async def wait(self, job_id: int) -> None:
        task = self.tasks.get(job_id)
        if task is not None:
            await task

    async def stop(self) -> None:
        for task in self.tasks.values():
            task.cancel()
        for task in self.tasks.values():
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
