"""The instrument layer of a job: whatever measures the robot, asked the same thing by the
acquisition (`service/acquisition.py`) at every pose the robot reached: the measurement of that
pose, a `Measurement` (the points, each with its covariance when the instrument states one, the
conditions it measured in, and when).

- `ArmInstrument`: the measuring arm on its serial line (protocol/arm.py). It streams triples
  whenever it probes, so a triple is taken for a pose only when `service/readings.py` accepts it
  (the checks of the arm's readings, unchanged).
- `TrackerInstrument`: a laser tracker over emScon TPI (protocol/tracker.py): one stationary
  measurement per SMR, the first SMR tracked through the moves, SMRs 2 and 3 found by pointing
  the beam where the nominal robot's orientation puts them from the first (the tracker's frame
  turned by the record's `yaw_deg`). Its refusals are link errors: the job pauses, reconnects
  (initialising the tracker again), and measures the pose again, once.
- `ExternalInstrument`: another instrument's software posts the measurement of the pose the job
  waits for (POST /jobs/ID/measurement: `post`).

A failure an instrument cannot cure by itself is one of the link's errors (protocol/errors.py):
the runner pauses the job and reconnects.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from protocol.arm import ArmReader
from protocol.arm_url import check_arm_url
from protocol.errors import (
    ArmLineError,
    BeamBrokenError,
    LinkTimeoutError,
    ProtocolError,
    TrackerNotInitialisedError,
)
from protocol.tracker import TrackerClient, TrackerPoint
from screwcal.instrument import POSITION_NOISE_MM
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from service.arm_opening import ArmOpening
from service.events import JobEvents
from service.readings import EarlierReadings, MotionTolerance, PoseReading, refusal
from service.robot_record import ArmSetup, ExternalSetup, RobotRecord, TrackerSetup
from service.settings import ServiceSettings

Point = tuple[float, float, float]
MAX_COORDINATE_MM = 1e6  # a measured coordinate beyond a kilometre is not one
MAX_VARIANCE_MM2 = 1e4  # nor a variance beyond (100 mm)^2
RIGIDITY_MM = 1.0  # the SMRs measured at a pose keep the nests' distances within this


class JobAborted(Exception):  # noqa: N818 (control flow, not an error)
    """The operator aborted the job."""


class Conditions(BaseModel):
    """The air an instrument measured in (a tracker's weather station)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    temperature_c: float = Field(ge=-50.0, le=80.0)
    pressure_mbar: float = Field(ge=300.0, le=1200.0)
    humidity_pct: float = Field(ge=0.0, le=100.0)


class Measurement(BaseModel):
    """One pose's measurement: its points (mm, the instrument's frame), each point's covariance
    (mm^2, 3x3; None when the instrument states none), the conditions (None: not measured) and
    when it was measured (Unix time, s)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    points_mm: list[tuple[float, float, float]] = Field(min_length=1, max_length=3)
    covariance_mm2: list[tuple[tuple[float, float, float], tuple[float, float, float],
                               tuple[float, float, float]]] | None = None
    conditions: Conditions | None = None
    time_s: float = Field(gt=0.0)

    @model_validator(mode="after")
    def _consistent(self) -> Measurement:
        if any(abs(v) > MAX_COORDINATE_MM for p in self.points_mm for v in p):
            raise ValueError(f"a coordinate beyond {MAX_COORDINATE_MM:g} mm: not a measurement")
        if self.covariance_mm2 is not None:
            if len(self.covariance_mm2) != len(self.points_mm):
                raise ValueError(f"{len(self.covariance_mm2)} covariances for "
                                 f"{len(self.points_mm)} points: one 3x3 per point")
            for k, c in enumerate(self.covariance_mm2):
                m = np.asarray(c, dtype=float)
                if not np.allclose(m, m.T, atol=1e-12 + 1e-9 * np.abs(m).max()):
                    raise ValueError(f"covariance of point {k + 1} is not symmetric")
                eig = np.linalg.eigvalsh(m)
                if eig.min() < -1e-12 or eig.max() > MAX_VARIANCE_MM2:
                    raise ValueError(f"covariance of point {k + 1} is not a covariance (its "
                                     f"eigenvalues {eig.round(9).tolist()} mm^2 must be >= 0 "
                                     f"and <= {MAX_VARIANCE_MM2:g})")
        return self

    @classmethod
    def of_tracker(cls, points: Sequence[TrackerPoint]) -> Measurement:
        first = points[0]
        return cls(points_mm=[p.xyz_mm for p in points],
                   covariance_mm2=[tuple(map(tuple, p.covariance)) for p in points],
                   conditions=Conditions(temperature_c=first.temperature_c,
                                         pressure_mbar=first.pressure_mbar,
                                         humidity_pct=first.humidity_pct),
                   time_s=first.time_s)

    def row(self) -> tuple[list, list | None, dict | None, float]:
        """What the store keeps: points, covariances, conditions, time."""
        return ([list(p) for p in self.points_mm],
                None if self.covariance_mm2 is None else [[list(r) for r in c]
                                                          for c in self.covariance_mm2],
                None if self.conditions is None else self.conditions.model_dump(),
                self.time_s)


def measurement_of_row(row: dict) -> Measurement:
    """A committed pose's measurement, as the store holds it."""
    return Measurement(points_mm=row["holes_mm"], covariance_mm2=row.get("covariance_mm2"),
                       conditions=row.get("conditions"),
                       time_s=row.get("measured_at") or row["created"])


@dataclass
class PoseAt:
    """The pose the robot reached: its phase and index, and the joints the controller read."""

    phase: str
    idx: int
    joints_deg: Sequence[float]


@dataclass
class Seen:
    """The readings a new arm reading is checked against: the previous pose's, and every
    earlier one."""

    previous: PoseReading | None
    earlier: EarlierReadings


class Instrument(Protocol):
    async def open(self) -> None: ...

    async def close(self) -> None: ...

    async def before_move(self) -> None:
        """The previous pose is committed; the robot is about to move on."""

    async def measure(self, pose: PoseAt, seen: Seen) -> Measurement:
        """The measurement of the pose the robot just reached."""


# -- the measuring arm ----------------------------------------------------------------------------
class ArmInstrument:
    """The arm's port, opened in a thread (`ArmOpening`), and its readings checked."""

    def __init__(self, setup: ArmSetup, settings: ServiceSettings, events: JobEvents,
                 model: SerialModel, reading_of: Callable[[np.ndarray, Sequence[float]],
                                                          PoseReading]):
        self.setup, self.settings, self.events, self.model = setup, settings, events, model
        self.reading_of = reading_of
        self.arm: ArmReader | None = None
        self._opening: ArmOpening | None = None
        self.discarded: Counter[str] = Counter()  # readings refused, by kind

    async def open(self) -> None:
        if self.arm is None:
            url = check_arm_url(self.setup.url)  # a record older than the check too
            # the port opens in a thread that a cancellation cannot stop (`ArmOpening`):
            # `close`, which every runner's end calls, lets go of it
            self._opening = ArmOpening(url)
            self.arm = await self._opening.claim()
            self._opening = None

    async def close(self) -> None:
        if self._opening is not None:  # aborted while the arm's port opened: its thread closes
            opening, self._opening = self._opening, None  # it, and a new one waits for that
            opening.abandon()
            with contextlib.suppress(Exception):  # (its own error, or "let go of")
                await asyncio.shield(opening.future)
        if self.arm is not None:
            # pyserial's socket:// close() sleeps 0.3 s: never on the event loop.
            await asyncio.to_thread(self.arm.close)
            self.arm = None

    async def before_move(self) -> None:
        assert self.arm is not None
        await asyncio.to_thread(self.arm.drain)  # stale lines never read as the next pose's

    async def measure(self, pose: PoseAt, seen: Seen) -> Measurement:
        """The arm reading of the pose the robot reported arriving at (service/readings.py): a
        duplicated, stale or early triple is discarded and logged and the next one read; when
        none is accepted in time, the arm is asked to probe again (`remeasure_attempts`), then
        the job pauses and the pose is measured anew."""
        assert self.arm is not None
        tol = MotionTolerance(self.settings.motion_tolerance_mm,
                              self.settings.motion_tolerance_rel,
                              self.settings.motion_tolerance_deg)
        attempts = 0
        last_refusal = ""
        deadline = time.monotonic() + self.settings.arm_timeout_s
        while True:
            try:
                holes = await asyncio.to_thread(self.arm.read_holes,
                                                max(0.05, deadline - time.monotonic()))
            except LinkTimeoutError:
                if last_refusal and attempts >= self.settings.remeasure_attempts:
                    raise ArmLineError(  # say why, not only "no reading": it may be the check
                        f"{pose.phase} pose {pose.idx}: every reading of this pose was "
                        f"refused, the last one: {last_refusal}. If the robot is this far from "
                        "its nominal model, raise motion_tolerance_deg / motion_tolerance_rel"
                    ) from None
                if attempts >= self.settings.remeasure_attempts or not self.discarded:
                    raise
                attempts += 1
                await asyncio.to_thread(self.arm.request)
                deadline = time.monotonic() + self.settings.arm_timeout_s
                continue
            points = np.array(holes.points_mm)
            refused = refusal(seen.previous, self.reading_of(points, pose.joints_deg), tol,
                              seen.earlier)
            if refused is None:
                var = POSITION_NOISE_MM ** 2  # the arm's stated noise, every coordinate alike
                return Measurement(points_mm=holes.points_mm,
                                   covariance_mm2=[((var, 0, 0), (0, var, 0), (0, 0, var))] * 3,
                                   time_s=time.time())
            kind, why = refused
            last_refusal = why
            self.discarded[kind] += 1
            await self.events.publish("discarded", phase=pose.phase, index=pose.idx,
                                      reason=why, seqs=list(holes.seqs))


# -- the laser tracker ----------------------------------------------------------------------------
class TrackerInstrument:
    """A laser tracker over emScon TPI (blocking driver calls in worker threads)."""

    def __init__(self, setup: TrackerSetup, model: SerialModel):
        self.setup, self.model = setup, model
        self.smrs = np.array(setup.smrs_mm, dtype=float)
        c, s = np.cos(np.radians(setup.yaw_deg)), np.sin(np.radians(setup.yaw_deg))
        self.to_tracker = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # <- robot
        self.tracker: TrackerClient | None = None
        self._anchor: Point | None = None  # the first SMR, as measured at the last pose
        self._lost_initialisation = False  # the tracker said so: initialise it on reconnecting

    async def open(self) -> None:
        if self.tracker is None:
            tracker = await asyncio.to_thread(TrackerClient.open, self.setup.url)
            initialise = self.setup.initialise or self._lost_initialisation
            try:
                await asyncio.to_thread(tracker.setup, initialise=initialise)
            except BaseException:
                tracker.close()
                raise
            self.tracker, self._lost_initialisation = tracker, False

    async def close(self) -> None:
        if self.tracker is not None:
            tracker, self.tracker = self.tracker, None
            await asyncio.to_thread(tracker.close)

    async def before_move(self) -> None:
        return None

    async def measure(self, pose: PoseAt, seen: Seen) -> Measurement:
        """The SMRs of the pose reached; a refusal is raised as the link error it is (the job
        pauses, reconnects and measures the pose again)."""
        assert self.tracker is not None
        try:
            return Measurement.of_tracker(await asyncio.to_thread(
                self._measure_all, self.tracker, pose.joints_deg))
        except TrackerNotInitialisedError:
            self._lost_initialisation = True
            raise

    def _measure_all(self, tracker: TrackerClient, joints_deg: Sequence[float]
                     ) -> list[TrackerPoint]:
        """Every SMR of this pose, the first first (blocking: in a thread)."""
        if self._anchor is not None and len(self.smrs) > 1:  # the beam may be on another SMR
            with contextlib.suppress(ProtocolError):  # (a retry after a failure mid-triangle)
                tracker.go_position(self._anchor)
        first = tracker.measure()
        self._anchor = first.xyz_mm
        R = self.to_tracker @ flange_kinematics(self.model, np.radians([joints_deg]))[0][:3, :3]
        return measure_others(tracker, first, self.smrs, R)


def measure_others(tracker: TrackerClient, first: TrackerPoint, smrs_mm: np.ndarray,
                   rotation: np.ndarray) -> list[TrackerPoint]:
    """The SMRs (k, 3) at tool0 of this pose, the first measured already (the beam locked on
    it): the others found by pointing where `rotation` (the tracker's frame <- tool0, roughly)
    puts them from the first; the beam left on the first (tracked through the next move). A
    triangle whose sides are not the nests' is a wrong reflector locked: BeamBrokenError."""
    points = [first]
    if len(smrs_mm) == 1:
        return points
    try:
        for smr in smrs_mm[1:]:
            tracker.go_position(np.asarray(first.xyz_mm) + rotation @ (smr - smrs_mm[0]))
            points.append(tracker.measure())
    finally:
        with contextlib.suppress(ProtocolError):  # tracked through the next move
            tracker.go_position(first.xyz_mm)
    mismatch = triangle_mismatch_mm(np.array([p.xyz_mm for p in points]), smrs_mm)
    if mismatch > RIGIDITY_MM:
        raise BeamBrokenError(f"the reflectors measured are not the SMRs' triangle (sides off "
                              f"by {mismatch:.2f} mm): a wrong reflector was locked")
    return points


def triangle_mismatch_mm(measured: np.ndarray, nests: np.ndarray) -> float:
    """The largest difference between the measured SMRs' mutual distances and the nests'."""
    k = len(nests)
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    return max((abs(float(np.linalg.norm(measured[i] - measured[j])
                          - np.linalg.norm(nests[i] - nests[j]))) for i, j in pairs),
               default=0.0)


# -- another instrument, posting its measurements -------------------------------------------------
class ExternalInstrument:
    """Waits at each pose for its measurement, posted by another instrument's software."""

    def __init__(self, setup: ExternalSetup, events: JobEvents, aborted: asyncio.Event,
                 n_points: int):
        self.setup, self.events, self.aborted, self.n_points = setup, events, aborted, n_points
        self.waiting_for: PoseAt | None = None
        self._posted: asyncio.Future[Measurement] | None = None
        self.accepted: dict[tuple[str, int], Measurement] = {}  # what was posted, by pose

    def wanted(self) -> dict[str, Any] | None:
        """The pose whose measurement the job waits for now (the API shows it), or None."""
        pose = self.waiting_for
        return None if pose is None else {"phase": pose.phase, "index": pose.idx,
                                          "joints_deg": list(pose.joints_deg),
                                          "points": self.n_points}

    async def open(self) -> None:
        return None

    async def close(self) -> None:
        return None

    async def before_move(self) -> None:
        return None

    def post(self, phase: str, idx: int, measurement: Measurement) -> bool:
        """The measurement of (phase, idx): False when the job waits for no such pose now."""
        pose, posted = self.waiting_for, self._posted
        if pose is None or posted is None or posted.done() or (pose.phase, pose.idx) != (
                phase, idx):
            return False
        self.accepted[(phase, idx)] = measurement
        posted.set_result(measurement)
        return True

    async def measure(self, pose: PoseAt, seen: Seen) -> Measurement:
        posted: asyncio.Future[Measurement] = asyncio.get_running_loop().create_future()
        self._posted, self.waiting_for = posted, pose
        await self.events.publish("measurement wanted", phase=pose.phase, index=pose.idx,
                                  joints_deg=list(pose.joints_deg), points=self.n_points)
        stopper: asyncio.Future[Any] = asyncio.ensure_future(self.aborted.wait())
        try:
            await asyncio.wait([posted, stopper], return_when=asyncio.FIRST_COMPLETED)
            if not posted.done():
                raise JobAborted()
            return posted.result()
        finally:
            stopper.cancel()
            self.waiting_for, self._posted = None, None


def open_instrument(robot: RobotRecord, settings: ServiceSettings, events: JobEvents,
                    model: SerialModel, aborted: asyncio.Event,
                    reading_of: Callable[[np.ndarray, Sequence[float]], PoseReading]
                    ) -> ArmInstrument | TrackerInstrument | ExternalInstrument:
    """The instrument the robot's record names (not yet opened)."""
    setup = robot.instrument
    if isinstance(setup, ArmSetup):
        return ArmInstrument(setup, settings, events, model, reading_of)
    if isinstance(setup, TrackerSetup):
        return TrackerInstrument(setup, model)
    return ExternalInstrument(setup, events, aborted, len(robot.targets_mm()))


__all__ = ["ArmInstrument", "Conditions", "ExternalInstrument", "Instrument",
           "JobAborted", "Measurement", "PoseAt", "Seen", "TrackerInstrument", "measurement_of_row",
           "open_instrument"]
