"""The running jobs: one runner task per job, resumed after a restart.

A service runs the jobs it holds the lease of (service/store.py): those it created, and those it
adopts, at start and then every third of a lease: unfinished jobs nobody holds, or whose
holder's lease expired (a service on the same PostgreSQL database that died). While it lives it
renews its leases at the same pace from a thread of its own (LeaseRenewer), not from the event
loop: a loop busy for seconds (plans, compensation, a loaded host) must not let a live service's
leases lapse and its jobs pass back and forth. A job found held by another service (this one
froze past its lease) has its runner cancelled at once, before it moves the robot again."""

from __future__ import annotations

import asyncio
import contextlib
import sys
import threading
from collections.abc import Callable

from screwcal.errors import InputError, ScrewcalError
from service.errors import ConflictError, ServiceError, StoreError, StoreLostError
from service.events import EventBus
from service.instruments import ExternalInstrument, Measurement, measurement_of_row
from service.plans import PlannedPose
from service.runner import JobRunner
from service.settings import ServiceSettings
from service.store import Store


class LeaseRenewer(threading.Thread):
    """Renews the service's leases every third of a lease while the process lives; `held` the
    jobs it held at the last renewal, `error` the last failure (None once one succeeds)."""

    def __init__(self, store: Store):
        super().__init__(name="lease renewer", daemon=True)
        self.store = store
        self.held: set[int] = set()
        self.error: StoreError | None = None
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(self.store.lease_s / 3):
            try:
                self.held, self.error = self.store.renew(), None
            except StoreError as err:  # said by the keeper on the event loop
                self.error = err
            except Exception as err:  # a thread must not die silently: leases would lapse
                self.error = StoreLostError(f"cannot renew the leases: {err!r}")

    def stop(self) -> None:
        self.stopped.set()
        self.join(timeout=10)


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
        self._renewer: LeaseRenewer | None = None

    def fatal(self, reason: str) -> None:
        """The database is gone: say why and stop the service (once)."""
        if self.fatal_reason is not None:
            return
        self.fatal_reason = reason
        print(f"screwcal service stops: {reason}", file=sys.stderr)
        if self._on_fatal is not None:
            self._on_fatal(reason)

    async def start(self, job_id: int, plans: dict[str, list[PlannedPose]] | None = None
                    ) -> bool:
        """Run a job; one whose records cannot make a runner (a robot stored before its fields
        were validated, say) fails with the reason instead. True when it runs. `plans`: its
        lists as the request that posted it built them (else the runner builds them)."""
        try:
            runner = await JobRunner.open(self.store, self.settings, self.events.of(job_id),
                                          job_id, on_fatal=self.fatal, plans=plans)
        except (ScrewcalError, ServiceError, ValueError, KeyError, TypeError) as err:
            await asyncio.to_thread(self.store.fail, job_id, f"cannot run: {err}")
            return False
        self.runners[job_id] = runner
        self.tasks[job_id] = asyncio.create_task(runner.run(), name=f"job {job_id}")
        return True

    async def resume_unfinished(self) -> list[int]:
        """After a restart (or a crash): every unfinished job nobody else holds goes on where
        its store says; start-up never dies on one bad record. Then the leases are kept."""
        resumed = await self.adopt()
        if self._keeper is None:
            self._renewer = LeaseRenewer(self.store)
            self._renewer.start()
            self._keeper = asyncio.create_task(self._keep(), name="leases")
        return resumed

    def running(self, job_id: int) -> bool:
        task = self.tasks.get(job_id)
        return task is not None and not task.done()

    async def adopt(self) -> list[int]:
        """Take and run the unfinished jobs nobody holds; their ids."""
        adopted = []
        for job_id in await asyncio.to_thread(self.store.adoptable):
            if not self.running(job_id) and await asyncio.to_thread(self.store.take, job_id) \
                    and await self.start(job_id):
                adopted.append(job_id)
        return adopted

    async def keep_leases(self) -> None:
        """Stop the runners of jobs another service holds now (this one froze past their
        leases), adopt the jobs whose holder died. (The renewal is LeaseRenewer's.)"""
        live = [job_id for job_id, task in self.tasks.items() if not task.done()]
        for job_id in await asyncio.to_thread(self.store.held_elsewhere, live):
            self.tasks[job_id].cancel()  # held by another service now: must not move on
        await self.adopt()

    async def _keep(self) -> None:
        while True:
            await asyncio.sleep(self.store.lease_s / 3)
            try:
                if self._renewer is not None and self._renewer.error is not None:
                    raise self._renewer.error
                await self.keep_leases()
            except StoreLostError as err:
                self.fatal(str(err))
                return
            except StoreError as err:  # a full disk: the jobs pause by themselves; try again
                print(f"screwcal service: cannot keep its leases: {err}", file=sys.stderr)

    async def runner(self, job_id: int) -> JobRunner:
        runner = self.runners.get(job_id)
        if runner is None or self.tasks[job_id].done():
            holder, left_s = await asyncio.to_thread(self.store.lease_of, job_id)
            if holder is not None and holder != self.store.holder and left_s > 0:
                raise ConflictError(f"job {job_id} runs on another service ({holder}): ask "
                                    "that one (its go-aheads and abort are there)")
            raise ConflictError(f"job {job_id} is not running")
        return runner

    async def go(self, job_id: int, index: int, operator: str = "") -> None:
        """The operator's go-ahead for pose `index`, kept with who gave it (provenance)."""
        gate = (await self.runner(job_id)).gate
        waiting = gate.waiting_for
        if not gate.take(index):  # consumed now: a second go-ahead for this pose is refused
            raise ConflictError(f"job {job_id} is not waiting for pose {index} "
                                f"(waiting for {waiting})")
        if waiting is not None:
            await asyncio.to_thread(self.store.add_confirmation, job_id, waiting[0], index,
                                    operator or "not named")

    async def measurement(self, job_id: int, phase: str, idx: int,
                          measurement: Measurement) -> bool:
        """Another instrument's measurement of pose (phase, idx) of the job: True when taken
        now (the runner commits it before the robot moves on), False when the same
        measurement was taken already (a repeated post). ConflictError when the pose was
        measured otherwise, or the job waits for no such pose (naming the one it waits for);
        InputError when the measurement does not fit the robot's targets."""
        committed = await asyncio.to_thread(self._committed, job_id, phase, idx)
        runner = self.runners.get(job_id)
        instrument = runner.acquisition.instrument if runner is not None else None
        taken = instrument.accepted.get((phase, idx)) \
            if isinstance(instrument, ExternalInstrument) else None
        before = committed or taken
        if before is not None:
            if before == measurement:
                return False
            raise ConflictError(f"job {job_id}: {phase} pose {idx} was measured already, with "
                                "other values: a pose is measured once (send the same "
                                "measurement again, or nothing)")
        runner = await self.runner(job_id)
        instrument = runner.acquisition.instrument
        if not isinstance(instrument, ExternalInstrument):
            raise ConflictError(f"job {job_id} is measured by its robot's "
                                f"{runner.robot.instrument.kind}, not by posted measurements")
        if len(measurement.points_mm) != instrument.n_points:
            raise InputError(f"{len(measurement.points_mm)} points posted: the robot's "
                             f"instrument measures {instrument.n_points} per pose (its targets)")
        if not instrument.post(phase, idx, measurement):
            wanted = instrument.wanted()
            now = "no pose now" if wanted is None else \
                f"{wanted['phase']} pose {wanted['index']}"
            raise ConflictError(f"job {job_id} waits for the measurement of {now}, not "
                                f"{phase} pose {idx}")
        return True

    def _committed(self, job_id: int, phase: str, idx: int) -> Measurement | None:
        self.store.job(job_id)  # NotFoundError for a job that does not exist
        rows = [r for r in self.store.measurements(job_id, phase) if r["idx"] == idx]
        return measurement_of_row(rows[0]) if rows else None

    async def abort(self, job_id: int) -> None:
        await (await self.runner(job_id)).abort()

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
        if self._renewer is not None:
            self._renewer.stop()
        for task in self.tasks.values():
            task.cancel()
        for task in self.tasks.values():
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        if self.fatal_reason is None:
            with contextlib.suppress(StoreError):
                await asyncio.to_thread(self.store.release)
