"""Acquisition: the links to the controller and the instrument, the operator's gate, and the
measured poses committed one by one.

Every list runs in STEP mode on the wire: the go-ahead for a pose is sent only once the previous
pose is committed to the store, so no measurement is ever lost to a crash; an AUTO job gives the
go-ahead itself, a STEP job waits for the operator's. At each pose reached the instrument the
robot's record names (service/instruments.py: the arm, a laser tracker, or an external one whose
measurement is posted) is asked for the pose's measurement. A lost link raises one of the
protocol's `LinkError`s (a tracker's broken beam, lost initialisation included); the runner
pauses the job and calls `reconnect`. Three points measured give the flange's pose (the arm's
holes, three SMRs); one point gives its position only.
"""

from __future__ import annotations

import asyncio
import time
from collections import Counter
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from protocol.client import ControllerClient, Timeouts
from protocol.codec import MAX_LIST, Lists
from protocol.errors import BeamBrokenError, LinkError, ProtocolError
from screwcal.calibration.flange import MeasuringFlange
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
from service.document import DiscardedReadings
from service.drift import DRIFT_PHASE, DriftSchedule, DriftState
from service.errors import SafetyError
from service.events import JobEvents
from service.instruments import (
    ArmInstrument,
    JobAborted,
    PoseAt,
    Seen,
    open_instrument,
)
from service.outage import StoreOutage
from service.phases import ListKind, list_kind
from service.plans import PlannedPose
from service.readings import EarlierReadings, PoseReading
from service.robot_record import RobotRecord
from service.settings import ServiceSettings
from service.store import Store

# the controller's list (the RAPID server module's) that runs a job's planned list
CONTROLLER_LIST: dict[ListKind, Lists] = {"cal": "CAL", "perf": "PERF"}
LINK_ERRORS = (LinkError,)  # protocol/errors.py: lost, timed out, busy, the arm's line or port
ZERO_NOTE = ("ZERO: the robot stands at the correction; enter the offsets on the FlexPendant "
             "(calibration data), then give the go-ahead")

__all__ = ["CONTROLLER_LIST", "LINK_ERRORS", "Acquisition", "JobAborted", "OperatorGate"]


class OperatorGate:
    """The operator's go-ahead before a move: in a STEP job before every pose, in every mode
    before a step that needs a person at the controller (a `note`)."""

    def __init__(self, step_mode: bool):
        self.step_mode = step_mode
        self.aborted = asyncio.Event()
        self.go_ahead: asyncio.Queue[int] = asyncio.Queue()
        self.waiting_for: tuple[str, int] | None = None

    def check_aborted(self) -> None:
        if self.aborted.is_set():
            raise JobAborted()

    def take(self, index: int) -> bool:
        """The operator lets the robot move to pose `index`: False when the job waits for no
        such pose (consumed at once: a second go-ahead for the same pose is refused)."""
        if self.waiting_for is None or self.waiting_for[1] != index:
            return False
        self.waiting_for = None
        self.go_ahead.put_nowait(index)
        return True

    async def wait(self, phase: str, planned: PlannedPose, events: JobEvents,
                   note: str = "") -> None:
        """Wait for the go-ahead for `planned` (at once in AUTO without a note)."""
        if not self.step_mode and not note:
            return
        self.waiting_for = (phase, planned.idx)
        extra = {"note": note} if note else {}
        await events.publish("waiting", phase=phase, index=planned.idx,
                             joints_deg=list(planned.joints_deg), **extra)
        try:
            while True:
                getter = asyncio.create_task(self.go_ahead.get())
                stopper = asyncio.create_task(self.aborted.wait())
                finished, _ = await asyncio.wait({getter, stopper},
                                                 return_when=asyncio.FIRST_COMPLETED)
                getter.cancel()
                stopper.cancel()
                self.check_aborted()
                if getter in finished and getter.result() == planned.idx:
                    return
        finally:
            self.waiting_for = None


class Acquisition:
    """One job's links and measurements. `robot` is the robot's stored record."""

    def __init__(self, store: Store, settings: ServiceSettings, events: JobEvents, job_id: int,
                 robot: RobotRecord, model: SerialModel, gate: OperatorGate,
                 outage: StoreOutage | None = None):
        """`outage`: the job's store calls (the runner's), waiting out the store's outages."""
        self.store, self.settings, self.events, self.job_id = store, settings, events, job_id
        self.robot, self.model, self.gate = robot, model, gate
        self.outage = outage or StoreOutage(store, events, job_id, settings.reconnect_interval_s)
        targets = robot.targets_mm()
        # three points measured: the flange's pose from them; one: its position only
        self.flange = MeasuringFlange.from_holes_in_flange(targets) if len(targets) == 3 \
            else None
        self.drift: DriftSchedule | None = None  # the job's drift checks (the runner's)
        self.client: ControllerClient | None = None
        self.instrument = open_instrument(robot, settings, events, model, gate.aborted,
                                          self._reading_of)
        self._open = False
        self._beam_broken: Counter[tuple[str, int]] = Counter()  # by pose, this runner's

    @property
    def discarded(self) -> Counter[str]:
        """Arm readings refused, by kind (none for another instrument)."""
        return self.instrument.discarded if isinstance(self.instrument, ArmInstrument) \
            else Counter()

    # -- links ---------------------------------------------------------------------------------
    async def connect(self) -> None:
        if self.client is None or self.client.lost is not None:
            self.client = ControllerClient(self.robot.controller_host,
                                           self.robot.controller_port,
                                           Timeouts(pose_s=self.settings.pose_timeout_s))
            # a few quick tries: the controller may not yet have seen the last client leave
            await self.client.reconnect(attempts=3, first_delay_s=0.05)
        if not self._open:
            await self.instrument.open()
            self._open = True

    async def disconnect(self) -> None:
        if self.client is not None:
            await self.client.close()
            self.client = None
        self._open = False
        await self.instrument.close()

    async def reconnect(self) -> None:
        while True:
            self.gate.check_aborted()
            await self.disconnect()
            try:
                await self.connect()
                return
            except LINK_ERRORS:
                await asyncio.sleep(self.settings.reconnect_interval_s)

    async def abort(self) -> None:
        self.gate.aborted.set()
        if self.client is not None and self.client.lost is None:
            try:
                await self.client.abort()
            except ProtocolError:
                pass

    # -- measuring -----------------------------------------------------------------------------
    async def measure(self, phase: str, plan: list[PlannedPose]) -> None:
        """Every pose of `plan` not yet committed for `phase`, in lists of at most MAX_LIST;
        the drift checks (`service/drift.py`) that fall due before, during and after it."""
        assert self.client is not None and self._open
        self._check_limits(phase, plan)
        if self.drift is not None:
            self._check_limits(DRIFT_PHASE, self.drift.references)
        list_name = CONTROLLER_LIST[list_kind(phase)]
        seen = await self.outage.call(self._seen)
        while True:  # the store read once per chunk
            measured = await self.outage.call(self.store.measured_indices, self.job_id, phase)
            measured |= await self.outage.call(self._skipped, phase)
            todo = [p for p in plan if p.idx not in measured]
            room = MAX_LIST
            if self.drift is not None:
                state = DriftState(*await self.outage.call(self.store.phase_progress,
                                                           self.job_id, DRIFT_PHASE))
                check = self.drift.due(state, time.time(), end_of_list=not todo)
                if check is not None:
                    done = await self.outage.call(self.store.measured_indices, self.job_id,
                                                  DRIFT_PHASE)
                    poses = [p for p in self.drift.check(check) if p.idx not in done]
                    await self._run_list(DRIFT_PHASE, list_name, poses, seen,
                                         self.drift.per_check, self.drift.per_check - len(poses))
                    continue
                room = min(room, self.drift.room(state))
            if not todo:
                return
            chunk = todo[:room]
            if chunk[-1].role == "approach" and len(todo) > len(chunk):  # never leave a
                chunk = todo[:room + 1]  # return point without its target: a check between
            await self._run_list(phase, list_name, chunk, seen, len(plan), len(measured))

    def _check_limits(self, phase: str, plan: Sequence[PlannedPose]) -> None:
        for p in plan:  # the service refuses targets outside the limits before sending
            if not self.model.within_limits(np.radians(p.joints_deg)):
                raise SafetyError(f"{phase} pose {p.idx} is outside the joint limits")

    def _seen(self) -> Seen:
        """The job's committed readings, which the next arm reading is checked against (none
        for another instrument: its measurement is asked for, or posted for, the pose)."""
        if not isinstance(self.instrument, ArmInstrument) or self.flange is None:
            return Seen(None, EarlierReadings.empty())
        last = self.store.last_measurement(self.job_id)
        previous = None if last is None else self._reading(
            last["holes_mm"], last["flange_pose"], last["joints_deg"])
        rows = self.store.measurements(self.job_id)
        earlier = EarlierReadings.empty() if not rows else EarlierReadings(
            np.array([r["holes_mm"] for r in rows], dtype=float),
            flange_kinematics(self.model, np.radians([r["joints_deg"] for r in rows]))[:, :3, 3],
            tuple(f"{r['phase']}/{r['idx']}" for r in rows))
        return Seen(previous, earlier)

    async def _run_list(self, phase: str, list_name: Literal["CAL", "PERF"],
                        chunk: list[PlannedPose], seen: Seen, total: int, done: int) -> None:
        """One LOAD and RUN of `chunk` (at most MAX_LIST poses), each pose committed before the
        robot moves on."""
        assert self.client is not None
        await self.client.load(list_name, [p.joints_deg for p in chunk])

        async def gate(k: int) -> None:
            await self._before_move(phase, chunk[k])

        async for got in self.client.run(list_name, "STEP", on_wait=gate, count=len(chunk)):
            planned = chunk[got.idx]
            got_at = PoseAt(phase, planned.idx, got.joints_deg)
            try:
                measurement = await self.instrument.measure(got_at, seen)
            except BeamBrokenError as err:
                self._beam_broken[(phase, planned.idx)] += 1
                if self._beam_broken[(phase, planned.idx)] < self.settings.beam_attempts:
                    raise  # the job pauses, reconnects and tries the pose again
                await self.outage.call(self._skip, phase, planned.idx)
                await self.events.publish("skipped", phase=phase, index=planned.idx,
                                          reason=str(err))
                continue
            points, covariance, conditions, at = measurement.row()
            flange_pose: list[float] = []
            if self.flange is not None:
                reading = self._reading_of(np.array(points), got.joints_deg)
                flange_pose = pose_from_transform(reading.flange).tolist()
                seen.previous = reading
                seen.earlier = seen.earlier.plus(reading, f"{phase}/{planned.idx}")
            await self._commit(phase, planned.idx, list(got.joints_deg), list(got.tool0),
                               points, flange_pose, covariance, conditions, at)
            done += 1
            await self.events.publish("measured", phase=phase, index=planned.idx,
                                      done=done, total=total)
        await self.outage.call(self._count_discarded)

    async def _commit(self, phase: str, idx: int, *pose: Any) -> None:
        """Commit one pose before the robot moves on; through an outage of the store the robot
        waits at the pose and the commit is retried (a commit whose answer a lost connection
        took may have been made: then it is there, once)."""
        try:
            await self.outage.call(self.store.add_measurement, self.job_id, phase, idx, *pose)
        except self.store.db.integrity_errors:
            if idx not in await self.outage.call(self.store.measured_indices, self.job_id,
                                                 phase):
                raise

    async def move_through(self, phase: str, plan: list[PlannedPose]) -> None:
        """Run the robot through `plan` without measuring (a warm-up), in lists of at most
        MAX_LIST; the operator's gate before each move, as for a measured list."""
        assert self.client is not None
        self._check_limits(phase, plan)
        for start in range(0, len(plan), MAX_LIST):
            chunk = plan[start:start + MAX_LIST]
            await self.client.load("PERF", [p.joints_deg for p in chunk])

            async def gate(k: int, chunk: list[PlannedPose] = chunk) -> None:
                await self._before_move(phase, chunk[k])

            async for got in self.client.run("PERF", "STEP", on_wait=gate, count=len(chunk)):
                await self.events.publish("moved", phase=phase, index=chunk[got.idx].idx,
                                          done=start + got.idx + 1, total=len(plan))

    async def zero(self, phase: str, zero_deg: Sequence[float]) -> None:
        """ZERO to `zero_deg`; its WAIT (a person enters the offsets) needs the operator's
        go-ahead in every mode, AUTO included."""
        assert self.client is not None

        async def gate(idx: int) -> None:
            await self._before_move(phase, PlannedPose(idx, tuple(zero_deg), "zero"),
                                    note=ZERO_NOTE)

        await self.client.zero(list(zero_deg), on_wait=gate)

    def _reading(self, holes_mm: Any, flange_pose: Any, joints_deg: Any) -> PoseReading:
        nominal = flange_kinematics(self.model, np.radians([joints_deg]))[0]
        flange = transform_from_pose(np.asarray(flange_pose, dtype=float))
        return PoseReading(np.asarray(holes_mm, dtype=float), flange, nominal)

    def _reading_of(self, points_mm: np.ndarray, joints_deg: Any) -> PoseReading:
        """Three measured points as a reading: the flange's pose from them, and the nominal
        flange at the joints the controller read."""
        assert self.flange is not None
        flange = self.flange.flange_poses(np.asarray(points_mm, dtype=float))[0]
        nominal = flange_kinematics(self.model, np.radians([joints_deg]))[0]
        return PoseReading(np.asarray(points_mm, dtype=float), flange, nominal)

    def _skipped(self, phase: str) -> set[int]:
        return set((self.store.job(self.job_id).result.poses_skipped or {}).get(phase, []))

    def _skip(self, phase: str, idx: int) -> None:
        """A pose whose beam stayed broken: kept in the result as skipped, never measured (the
        robot moves on; a resumed job does not come back to it)."""
        result = self.store.job(self.job_id).result
        skipped = dict(result.poses_skipped or {})
        skipped[phase] = sorted({*skipped.get(phase, []), idx})
        result.poses_skipped = skipped  # the estimation's and evaluation's warnings say so
        self.store.set_result(self.job_id, result)

    def _count_discarded(self) -> None:
        """The result says how many arm readings were refused and why (and the arm's lines
        that were not readings at all)."""
        if not isinstance(self.instrument, ArmInstrument) or self.instrument.arm is None:
            return
        arm = self.instrument.arm
        if not self.discarded and not arm.problems:
            return
        result = self.store.job(self.job_id).result
        result.arm_readings_discarded = DiscardedReadings(
            duplicate=self.discarded["duplicate"], stale=self.discarded["stale"],
            motion=self.discarded["motion"], bad_lines=len(arm.problems),
            meaning="arm triples not used as a pose's reading: repeats of the previous "
                    "pose's, re-probes of a pose the robot had left (stale), readings whose "
                    "measured motion disagreed with the commanded one (early, foreign), and "
                    "lines that broke a triple")
        self.store.set_result(self.job_id, result)

    async def _before_move(self, phase: str, planned: PlannedPose, note: str = "") -> None:
        """Before the robot moves to `planned`: the previous pose is committed; the instrument
        told (the arm drops its stale lines); then the operator's gate."""
        self.gate.check_aborted()
        await self.instrument.before_move()
        await self.gate.wait(phase, planned, self.events, note)
