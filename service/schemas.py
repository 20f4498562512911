"""The REST API's models (pydantic): what comes in (`...Create`) and what goes out."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from protocol.arm_url import HOSTNAME, ArmUrlError, check_arm_url
from screwcal.calibration.flange import DEFAULT_HOLES_IN_FLANGE_MM, FlangeError, MeasuringFlange
from screwcal.calibration.point_export import covariance_of_u95
from service.document import (
    SQLITE_MAX_ID,
    Id,
    JobOptions,
    JobRecord,
    PhaseRecord,
    ResultDocument,
)
from service.instruments import Conditions, Measurement
from service.job_state import JobState
from service.robot_record import ArmSetup, InstrumentSetup, RobotRecord, TrackerSetup

__all__ = ["SQLITE_MAX_ID", "GoAhead", "Id", "JobCreate", "JobOptions", "JobPublic", "JobResult",
           "MeasurementPost", "MeasurementPublic", "RobotCreate", "RobotPublic"]



class RobotCreate(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: str = Field(min_length=1, max_length=80)
    controller_host: str = Field("127.0.0.1", min_length=1, max_length=253,
                                 description="host name or IP address of the controller")
    controller_port: int = Field(4012, ge=1, le=65535)
    instrument: InstrumentSetup | None = Field(
        None, description="what measures the robot: the arm (kind 'arm', its url), a laser "
        "tracker over emScon (kind 'tracker', host, port, SMRs) or another instrument posting "
        "its measurements (kind 'external')")
    arm_url: str | None = Field(None, min_length=1, max_length=200,
                                description="the older form of an arm instrument: a serial "
                                "device (/dev/ttyUSB0, COM3), socket://HOST:PORT, "
                                "rfc2217://HOST:PORT or loop://")
    model: str | dict[str, Any] = Field(
        "irb1600", description="a built-in robot name or a model document (never a server path)")
    holes_mm: list[list[float]] = Field(
        default_factory=lambda: [list(h) for h in DEFAULT_HOLES_IN_FLANGE_MM],
        description="the measuring flange's holes P1, P2, P3 in the tool0 frame, mm")
    serial: str = Field("", max_length=80, description="the robot's serial number")
    controller_software: str = Field("", max_length=80, description="e.g. RobotWare 6.15")
    tool: str = Field("", max_length=80, description="the tool mounted")
    payload_kg: float | None = Field(None, ge=0, le=2000, description="the payload carried")
    emulation: list[Annotated[str, Field(max_length=300)]] = Field(
        default_factory=list, max_length=20, description="an emulated robot: what it carries "
        "beyond its geometry (its realism: compliance, backlash, lag, drift, ...), one line per "
        "effect, as the report states it; empty for a real robot")

    @field_validator("holes_mm")
    @classmethod
    def _three_points(cls, v: list[list[float]]) -> list[list[float]]:
        if len(v) != 3 or any(len(p) != 3 for p in v):
            raise ValueError("holes_mm must be three points of three coordinates")
        try:  # the flange code's own checks: finite, apart, not in a line
            MeasuringFlange.from_holes_in_flange(v)
        except FlangeError as err:
            raise ValueError(f"holes_mm cannot define the flange frame: {err}") from None
        return v

    @field_validator("controller_host")
    @classmethod
    def _host(cls, v: str) -> str:
        if not HOSTNAME.match(v):
            raise ValueError("a host name or an IP address (letters, digits, '.', '-', ':')")
        return v

    @model_validator(mode="after")
    def _one_instrument(self) -> RobotCreate:
        """`instrument`, or `arm_url` (the older form of an arm), checked."""
        if self.instrument is None:
            if self.arm_url is None:
                raise ValueError("name the robot's instrument: instrument {kind: arm, url} | "
                                 "{kind: tracker, host, port} | {kind: external}, or arm_url")
            self.instrument = ArmSetup(url=self.arm_url)
        elif self.arm_url is not None and self.instrument != ArmSetup(url=self.arm_url):
            raise ValueError("arm_url and instrument name two instruments: send one of them")
        ins = self.instrument
        try:  # no scheme or path a cell does not use (spy:// writes files, paths open files)
            if isinstance(ins, ArmSetup):
                check_arm_url(ins.url)
        except ArmUrlError as err:
            raise ValueError(f"the arm's url: {err}") from None
        if isinstance(ins, TrackerSetup) and not HOSTNAME.match(ins.host):
            raise ValueError("the tracker's host: a host name or an IP address (letters, "
                             "digits, '.', '-', ':')")
        targets = getattr(ins, "smrs_mm", None) or getattr(ins, "targets_mm", None)
        if targets is not None and len(targets) not in (1, 3):
            raise ValueError(f"the instrument's targets: one point (positions) or three (the "
                             f"pose), not {len(targets)}")
        if targets is not None and len(targets) == 3:
            try:
                MeasuringFlange.from_holes_in_flange(targets)
            except FlangeError as err:
                raise ValueError(f"the instrument's three targets cannot define the flange "
                                 f"frame: {err}") from None
        return self

    @property
    def setup(self) -> InstrumentSetup:
        assert self.instrument is not None  # set by the validator
        return self.instrument


RobotPublic = RobotRecord


class RobotIdentity(BaseModel):
    """A change of a robot's identity (a new controller software, tool or payload): the
    fields sent are changed, the others kept."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    serial: str | None = Field(None, max_length=80)
    controller_software: str | None = Field(None, max_length=80)
    tool: str | None = Field(None, max_length=80)
    payload_kg: float | None = Field(None, ge=0, le=2000)


class JobCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    robot_id: Id
    kind: Literal["performance", "calibration", "procedure", "verify"]
    mode: Literal["AUTO", "STEP"] = "AUTO"
    options: JobOptions = Field(default_factory=JobOptions)


class JobPublic(BaseModel):
    id: int
    robot_id: int
    kind: str
    mode: str
    state: JobState
    reason: str
    options: dict[str, Any]
    phases: dict[str, Any]
    waiting_for: dict[str, Any] | None = None
    measurement_for: dict[str, Any] | None = Field(
        None, description="the pose whose measurement the job waits for (an external "
        "instrument's: POST /jobs/ID/measurement): phase, index, joints_deg, points")

    @classmethod
    def of(cls, job: JobRecord, waiting_for: tuple[str, int] | None,
           measurement_for: dict[str, Any] | None = None) -> JobPublic:
        """A stored job and the pose its runner waits for now (phase, index), if any: for the
        go-ahead, or for its measurement."""
        return cls(id=job.id, robot_id=job.robot_id, kind=job.kind, mode=job.mode,
                   state=job.state, reason=job.reason, options=job.options.model_dump(),
                   phases={k: v.document() for k, v in job.phases.items()},
                   waiting_for=None if waiting_for is None else
                   {"phase": waiting_for[0], "index": waiting_for[1]},
                   measurement_for=measurement_for)


class GoAhead(BaseModel):
    model_config = ConfigDict(extra="forbid")
    index: int = Field(ge=0, le=100_000, description="the pose the operator lets the robot "
                       "move to")
    operator: str = Field("", max_length=80, description="who gives it: kept in the job's "
                          "provenance (who confirmed a ZERO, and when)")


class MeasurementPost(BaseModel):
    """The measurement of the pose a job waits for, from another instrument's software
    (POST /jobs/ID/measurement): the points, their uncertainty (covariance or U95) and when."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    phase: str = Field(min_length=1, max_length=40, description="the pose's list, as the job's "
                       "`measurement_for` names it (cal, perf_before, ...)")
    index: int = Field(ge=0, le=100_000, description="the pose's index in its list")
    points_mm: list[Annotated[list[float], Field(min_length=3, max_length=3)]] = Field(
        min_length=1, max_length=3, description="X, Y, Z of each target (mm, the "
        "instrument's frame), in the order of the robot record's targets")
    covariance_mm2: list[list[list[float]]] | None = Field(
        None, max_length=3, description="each point's 3x3 covariance (mm^2)")
    u95_mm: list[Annotated[float, Field(gt=0.0, le=100.0)]] | None = Field(
        None, max_length=3, description="or each point's expanded uncertainty at 95 % (k = 2, "
        "mm): covariance (U95 / 2)^2 I, as `screwcal calibrate` reads a point export's U95")
    time_s: float = Field(gt=0.0, description="when the instrument measured (Unix time, s)")
    conditions: Conditions | None = Field(None, description="the air it measured in")

    @model_validator(mode="after")
    def _one_uncertainty(self) -> MeasurementPost:
        if self.covariance_mm2 is not None and self.u95_mm is not None:
            raise ValueError("give covariance_mm2 or u95_mm, not both")
        if self.u95_mm is not None and len(self.u95_mm) != len(self.points_mm):
            raise ValueError(f"{len(self.u95_mm)} U95 values for {len(self.points_mm)} "
                             "points: one per point")
        return self

    def measurement(self) -> Measurement:
        """As the job commits it (ValueError naming what is wrong)."""
        cov: Any = self.covariance_mm2
        if self.u95_mm is not None:
            cov = covariance_of_u95(np.array(self.u95_mm)).tolist()
        return Measurement(points_mm=self.points_mm, covariance_mm2=cov,
                           conditions=self.conditions, time_s=self.time_s)


class MeasurementPublic(BaseModel):
    """One measured pose, as committed."""

    id: int
    job_id: int
    phase: str = Field(description="perf_before, cal, perf_after, cal_2, perf_after_2")
    idx: int = Field(description="the pose's index in its list")
    joints_deg: list[float] = Field(description="what the encoders read (j packet)")
    tool0: list[float] = Field(description="nominal tool0 x, y, z mm, rx, ry, rz deg (p packet)")
    holes_mm: list[list[float]] = Field(description="the points the instrument measured: P1, "
                                        "P2, P3 as the arm measured them, the SMRs, ...")
    flange_pose: list[float] = Field(description="measured tool0 (Eq. 4.6) in the "
                                     "instrument's frame; empty: one point, positions only")
    covariance_mm2: list[list[list[float]]] | None = Field(
        None, description="each point's covariance (3x3 mm^2) as the instrument stated it")
    conditions: dict[str, float] | None = Field(
        None, description="temperature_c, pressure_mbar, humidity_pct the instrument measured in")
    measured_at: float | None = Field(None, description="when the instrument measured (Unix s)")
    created: float


class JobResult(ResultDocument):
    """What a job found (GET /jobs/ID/result): its state, the seconds per phase, and the result
    document's sections as its phases complete; the calibration documents themselves are at
    GET /jobs/ID/model."""

    id: int
    state: JobState
    reason: str
    phases: dict[str, PhaseRecord] = Field(description="seconds per phase (set-up, measuring, "
                                           "...)")
    calibration: dict[str, Any] | None = Field(None, exclude=True)
    calibration_2: dict[str, Any] | None = Field(None, exclude=True)


    @classmethod
    def of(cls, job: JobRecord) -> JobResult:
        """The response for a stored job: the sections it has; estimation, correction,
        performance and base always named (null until the job computed them)."""
        return cls.model_validate({
            "id": job.id, "state": job.state, "reason": job.reason,
            "phases": {k: v.document() for k, v in job.phases.items()},
            "estimation": None, "correction": None, "performance": None, "base": None,
            **job.result.document()})
