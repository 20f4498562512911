"""The running jobs: one runner task per job, resumed after a restart.

A service runs the jobs it holds the lease of (service/store.py): those it created, and those it
adopts, at start and then every third of a lease: unfinished jobs nobody holds, or whose
holder's lease expired (a service on the same PostgreSQL database that died). While it lives it
renews its leases at the same pace; a job found held by another service (this one froze past its
lease) has its runner cancelled at once, before it moves the robot again."""

from __future__ import annotations

import asyncio
import contextlib
import sys
from collections.abc import Callable

from screwcal.errors import ScrewcalError
from service.errors import ConflictError, ServiceError, StoreError, StoreLostError
from service.events import EventBus
from service.runner import JobRunner
from service.settings import ServiceSettings
from service.store import UNFINISHED, Store


class JobManager:
    def __init__(self, store: Store, settings: ServiceSettings,
                 on_fatal: Callable[[str], None] | None = None):
        self.store, self.settings = store, settings
        self.events = EventBus()
        self.runners: dict[int, JobRunner] = {}
        self.tasks: dict[int, asyncio.Task[None]] = {}
        self._on_fatal = on_fatal
        self.fatal_reason: str | None = None
        self._keeper: asyncio.Task[None] | None = None

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
        """After a restart (or a crash): every unfinished job nobody else holds goes on where
        its store says; start-up never dies on one bad record. Then the leases are kept."""
        resumed = self.adopt()
        if self._keeper is None:
            self._keeper = asyncio.create_task(self._keep(), name="leases")
        return resumed

    def running(self, job_id: int) -> bool:
        task = self.tasks.get(job_id)
        return task is not None and not task.done()

    def adopt(self) -> list[int]:
        """Take and run the unfinished jobs nobody holds; their ids."""
        return [j for j in self.store.adoptable()
                if not self.running(j) and self.store.take(j) and self.start(j)]

    def keep_leases(self) -> None:
        """Renew this service's leases, stop the runners of jobs another service holds now,
        adopt the jobs whose holder died."""
        held = self.store.renew()
        for job_id, task in self.tasks.items():
            if not task.done() and job_id not in held and \
                    self.store.job(job_id).state in UNFINISHED:
                task.cancel()  # held by another service now: this runner must not move on
        self.adopt()

    async def _keep(self) -> None:
        while True:
            await asyncio.sleep(self.store.lease_s / 3)
            try:
                self.keep_leases()
            except StoreLostError as err:
                self.fatal(str(err))
                return
            except StoreError as err:  # a full disk: the jobs pause by themselves; try again
                print(f"screwcal service: cannot renew leases: {err}", file=sys.stderr)

    def busy_with(self, robot_id: int) -> int | None:
        """The unfinished job of this robot, if any."""
        return self.store.unfinished_job(robot_id)

    def runner(self, job_id: int) -> JobRunner:
        runner = self.runners.get(job_id)
        if runner is None or self.tasks[job_id].done():
            holder, left_s = self.store.lease_of(job_id)
            if holder is not None and holder != self.store.holder and left_s > 0:
                raise ConflictError(f"job {job_id} runs on another service ({holder}): ask "
                                    "that one (its go-aheads and abort are there)")
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
        """Cancel the runners, then let go of the leases: another service on the database
        takes the jobs over at once rather than after a lease."""
        if self._keeper is not None:
            self._keeper.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._keeper
        for task in self.tasks.values():
            task.cancel()
        for task in self.tasks.values():
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        if self.fatal_reason is None:
            with contextlib.suppress(StoreError):
                self.store.release()
