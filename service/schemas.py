"""The REST API's models (pydantic): what comes in (`...Create`) and what goes out."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from protocol.arm_url import HOSTNAME, ArmUrlError, check_arm_url
from screwcal.calibration.flange import DEFAULT_HOLES_IN_FLANGE_MM, FlangeError, MeasuringFlange

SQLITE_MAX_ID = 2**63 - 1  # SQLite's INTEGER: a larger id can name nothing (and must not 500)
Id = Annotated[int, Field(ge=1, le=SQLITE_MAX_ID)]


class RobotCreate(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    name: str = Field(min_length=1, max_length=80)
    controller_host: str = Field("127.0.0.1", min_length=1, max_length=253,
                                 description="host name or IP address of the controller")
    controller_port: int = Field(4012, ge=1, le=65535)
    arm_url: str = Field(min_length=1, max_length=200,
                         description="the measuring arm: a serial device (/dev/ttyUSB0, COM3), "
                         "socket://HOST:PORT, rfc2217://HOST:PORT or loop://")
    model: str | dict[str, Any] = Field(
        "irb1600", description="a built-in robot name or a model document (never a server path)")
    holes_mm: list[list[float]] = Field(
        default_factory=lambda: [list(h) for h in DEFAULT_HOLES_IN_FLANGE_MM],
        description="the measuring flange's holes P1, P2, P3 in the tool0 frame, mm")

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

    @field_validator("arm_url")
    @classmethod
    def _url(cls, v: str) -> str:
        try:  # no scheme or path a cell does not use (spy:// writes files, paths open files)
            return check_arm_url(v)
        except ArmUrlError as err:
            raise ValueError(str(err)) from None


class RobotPublic(BaseModel):
    id: int
    name: str
    controller_host: str
    controller_port: int
    arm_url: str
    model: dict[str, Any]
    holes_mm: list[list[float]]


class JobOptions(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    model: Literal["thesis", "full", "joints"] = Field(
        "full", description="error model identified: full (every identifiable parameter, "
        "frames identified) or the thesis's virtual joints")
    correction: Literal["compensate", "zero", "zero+compensate"] = Field(
        "compensate", description="procedure: compensate the later lists' joint targets "
        "(nothing changes in the controller), ZERO the joint offsets (thesis 4.5), or both")
    rounds: int = Field(1, ge=1, le=2, description="procedure: 2 adds the thesis's second "
                                                  "calibration round (4.7)")
    calibration_poses: int = Field(40, ge=10, le=400)
    cycles: int = Field(30, ge=2, le=60, description="ISO 9283 cycles (30 by the standard)")
    cube_edge_mm: float = Field(300.0, gt=0, le=2000)
    arm_position_mm: tuple[float, float, float] | None = Field(
        None, description="where the arm stands in the robot frame, to keep the cube in reach")
    frame_from_job: Id | None = Field(
        None, description="performance: measure accuracy in the robot base frame that this "
        "earlier job's calibration identified (default: a frame fitted to the job's own data, "
        "which hides what such a frame absorbs)")


class JobCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    robot_id: Id
    kind: Literal["performance", "calibration", "procedure"]
    mode: Literal["AUTO", "STEP"] = "AUTO"
    options: JobOptions = Field(default_factory=JobOptions)


class JobPublic(BaseModel):
    id: int
    robot_id: int
    kind: str
    mode: str
    state: str
    reason: str
    options: dict[str, Any]
    phases: dict[str, Any]
    waiting_for: dict[str, Any] | None = None


class GoAhead(BaseModel):
    model_config = ConfigDict(extra="forbid")
    index: int = Field(ge=0, le=100_000, description="the pose the operator lets the robot "
                       "move to")


class MeasurementPublic(BaseModel):
    """One measured pose, as committed."""

    id: int
    job_id: int
    phase: str = Field(description="perf_before, cal, perf_after, cal_2, perf_after_2")
    idx: int = Field(description="the pose's index in its list")
    joints_deg: list[float] = Field(description="what the encoders read (j packet)")
    tool0: list[float] = Field(description="nominal tool0 x, y, z mm, rx, ry, rz deg (p packet)")
    holes_mm: list[list[float]] = Field(description="P1, P2, P3 as the arm measured them")
    flange_pose: list[float] = Field(description="measured tool0 (Eq. 4.6) in the arm's frame")
    created: float


class JobResult(BaseModel):
    """What a job found. Sections appear as its phases complete."""

    model_config = ConfigDict(extra="allow")
    id: int
    state: str
    reason: str
    phases: dict[str, Any] = Field(description="seconds per phase (set-up, measuring, ...)")
    estimation: dict[str, Any] | None = Field(
        None, description="identified parameters with unit, value, std error; removed ones")
    correction: dict[str, Any] | None = Field(
        None, description="joint offsets, the ZERO targets sent (deg), or why refused")
    performance: dict[str, Any] | None = Field(
        None, description="ISO 9283 per point and overall, straightness, per phase")
    base: list[list[float]] | None = Field(None, description="arm frame <- robot base (4x4)")
