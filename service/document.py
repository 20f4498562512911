"""A job, its phases and its result document as typed objects (pydantic): what the runner writes,
the store keeps as JSON, the REST API serves, and the CLI and the report page read.

The result document grows as the job's phases complete: a section (or a field of one) that was
never set is absent from the JSON, never a null (`Section.document()`: the fields that were set,
by the runner or in the JSON read back). Every section keeps keys it does not declare (a document
stored by another version of the service loses nothing).

    ResultDocument
    ├── estimation, estimation_2    EstimationSummary   the robot's identified parameters
    ├── calibration, calibration_2  dict                the calibration result document
    │                                                   (format screwcal-calibration)
    ├── correction, correction_2    CorrectionPlan      what the route did or will do
    ├── base                        4x4                 arm frame <- robot base
    ├── frame_note                  str                 which base frame the accuracy is in
    ├── performance                 {phase: PerformanceSection}   ISO 9283, straightness
    ├── home_check                  HomeCheck           thesis Table 14
    ├── test_conditions             {label: value}      as ISO 9283 asks a report to state
    ├── arm_readings_discarded      DiscardedReadings
    ├── poses_skipped               {phase: [index]}    a tracker's beam stayed broken there
    ├── backlash                    dict                lost motion per joint (calibration list
    │                                                   with two-direction pairs)
    ├── drift                       DriftSection        reference poses re-measured over the job
    └── warnings                    [str]
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from screwcal.calibration.error_parameters import ModelKind
from screwcal.performance.iso9283 import PoseMetrics
from service.job_state import JobState
from service.phases import Round

SQLITE_MAX_ID = 2**63 - 1  # SQLite's INTEGER: a larger id can name nothing (and must not 500)
Id = Annotated[int, Field(ge=1, le=SQLITE_MAX_ID)]


class Section(BaseModel):
    """A part of a stored document: extra keys are kept, unset fields are left out."""

    model_config = ConfigDict(extra="allow")

    def document(self) -> dict[str, Any]:
        """As stored and served: the fields that were set (None included when set so)."""
        return self.model_dump(exclude_unset=True)


# -- a job, its options and its phases ------------------------------------------------------------
class JobOptions(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    model: ModelKind = Field(
        "full", description="error model identified: full (every identifiable parameter, "
        "frames identified), thesis (the thesis's virtual joints), joints (the joint offsets) "
        "or frames (the nominal robot, only the frames fitted)")
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
    compliance: Literal["auto", "none", "j23", "j23-free", "wrist"] = Field(
        "auto", description="joint compliance under gravity identified with the geometry: auto "
        "(joints 2-3 when the data support them), none (geometric only), j23, j23-free (a "
        "coefficient per arm mass), wrist (joints 2-6)")
    lag: Literal["auto", "none"] = Field(
        "auto", description="joint readings that trail the motion: auto (estimated and "
        "corrected when the diagnostics flag them) or none")
    take_up_lost_motion: bool = Field(
        False, description="compensated lists: each joint also commanded half the lost motion "
        "(backlash) the calibration found beyond its target, on the side it comes from in the "
        "list (calibration.lag.commands_for_lost_motion); nothing when none was found")
    payload_kg: float = Field(0.0, ge=0.0, le=2000.0, description="mass on the flange during "
                              "the performance lists (and the calibration list unless "
                              "calibration_payload_kg is given), kg")
    payload_cog_mm: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="its centre of gravity in the flange (tool0) frame, mm")
    calibration_payload_kg: float | None = Field(
        None, ge=0.0, le=2000.0, description="mass on the flange during the calibration list, "
        "kg (default: payload_kg)")
    calibration_payload_cog_mm: tuple[float, float, float] | None = Field(
        None, description="its centre of gravity in the flange frame, mm (default: "
        "payload_cog_mm)")
    warmup_cycles: int = Field(0, ge=0, le=60, description="ISO 9283 warm-up: cycles of the "
                               "test cycle (P1, P5, P4, P3, P2) run unmeasured before the first "
                               "performance list")
    backlash_poses: int = Field(
        0, ge=0, le=20, description="calibration: this many calibration poses measured twice "
        "more, approached from 1 deg below and from 1 deg above on every joint, to identify "
        "each joint's lost motion (backlash, deg); 0: none")
    drift_poses: int = Field(
        0, ge=0, le=5, description="ISO 9283 drift: this many reference poses (the test "
        "cube's P1, P2, P4, P3, P5 in that order, each approached from 1 deg below on every "
        "joint) re-measured periodically during the job; 0: none")
    drift_period_poses: int = Field(
        40, ge=5, le=1000, description="drift: re-measure the reference poses every this many "
        "measured poses (count)")
    drift_period_s: float | None = Field(
        None, gt=0, le=86400, description="drift: re-measure the reference poses every this "
        "many seconds of the job instead (s; checked between poses)")
    frame_from_job: Id | None = Field(
        None, description="performance: measure accuracy in the robot base frame that this "
        "earlier job's calibration identified (default: a frame fitted to the job's own data, "
        "which hides what such a frame absorbs)")

    @model_validator(mode="after")
    def _something_to_zero(self) -> JobOptions:
        """The frames model identifies no joint offset: a ZERO route would send nothing."""
        if self.model == "frames" and self.correction.startswith("zero"):
            raise ValueError("the frames model identifies no joint offset, so a ZERO would "
                             "change nothing: use correction compensate, or another model")
        return self


class PhaseRecord(Section):
    """A step of a job: claimed (`started`), then `done` with the seconds it took."""

    started: bool = False
    done: bool = False
    seconds: float = 0.0


# -- the estimation ------------------------------------------------------------------------------
class EstimatedParameter(Section):
    name: str
    unit: str
    value: float
    std_error: float


class MeasuringFrame(Section):
    """The robot base in the measuring system's frame, mm and degrees."""

    x: float
    y: float
    z: float
    rx: float
    ry: float
    rz: float
    meaning: str


class RemovedParameter(Section):
    name: str
    reason: str


class EstimationSummary(Section):
    parameters: list[EstimatedParameter]
    measuring_frame: MeasuringFrame | None = None
    removed: list[RemovedParameter] = Field(default_factory=list)
    rank: int
    condition_number: float
    chi2_reduced: float
    converged: bool
    noise: dict[str, Any] | None = None  # the noise levels estimated (NoiseEstimate.to_dict)
    warnings: list[str] = Field(default_factory=list)
    residual_before_mm: float
    residual_after_mm: float
    # the joint compliance identified (resultfile.compliance_summary) and the read-back lag
    compliance: dict[str, Any] | None = None
    reading_lag: dict[str, Any] | None = None
    # the share of the calibration residual's mean square the identified model explains
    explained_share: float | None = None


# -- the correction ------------------------------------------------------------------------------
class LeftInRobot(Section):
    name: str
    value: float
    unit: str


class PredictedError(Section):
    before: float
    after: float
    meaning: str


class CorrectionPlan(Section):
    """What a correction route does: ZERO targets (zero routes), compensated lists (compensate
    routes), what stays in the robot, the accuracy the model predicts."""

    route: str
    note: str | None = None
    not_identified: list[str] = Field(default_factory=list)
    offsets_deg: list[float] | None = None
    zero_command_deg: list[float] | None = None
    identified: list[bool] | None = None
    procedure: str | None = None
    compensated_lists: list[str] | None = None
    max_joint_change_deg: float | None = None
    lost_motion_taken_up_deg: list[float] | None = None  # take_up_lost_motion: per joint
    left_in_robot: list[LeftInRobot] | None = None
    predicted_position_error_mm: PredictedError | None = None
    sent: bool | None = None


# -- performance, home, conditions ---------------------------------------------------------------
class PerformanceSection(Section):
    """One performance list's figures, as the performance package computes them
    (`screwcal.performance.evaluate.performance_section`): ISO 9283 per point and overall, and
    the straightness of the line (`Straightness.to_dict`)."""

    measurement: str | None = None
    points: dict[str, PoseMetrics] = Field(default_factory=dict)
    overall: dict[str, Any] | None = None
    straightness: dict[str, Any] | None = None

    @model_validator(mode="before")
    @classmethod
    def _older_straightness(cls, data: Any) -> Any:
        """Documents stored before the service used the package's straightness named the
        signed deviations `deviation_mm`."""
        line = data.get("straightness") if isinstance(data, dict) else None
        if isinstance(line, dict) and "deviation_mm" in line and "deviation_u_mm" not in line:
            line = {k if k != "deviation_mm" else "deviation_u_mm": v for k, v in line.items()}
            data = {**data, "straightness": line}
        return data


class HomeMeasurement(Section):
    measured_mm: list[float]
    error_mm: list[float]
    distance_mm: float


class HomeCheck(Section):
    """Thesis Table 14: the flange at home, before and after the correction."""

    before: HomeMeasurement | None = None
    after: HomeMeasurement | None = None
    nominal_mm: list[float]
    note: str


class DiscardedReadings(Section):
    """Arm readings not used as a pose's reading, by reason."""

    duplicate: int
    stale: int
    motion: int
    bad_lines: int
    meaning: str


class DriftSection(Section):
    """ISO 9283 drift (`screwcal.performance.drift`): reference poses re-measured over the job,
    each approached from 1 deg below on every joint. Per check: its time and how many poses of
    the job were measured before it; per reference pose: the norm of the change of its measured
    position since its first measurement under the same payload (mm)."""

    reference: list[str]
    t_s: list[float]
    poses_before: list[int]
    list_of_check: list[str]
    deviation_mm: dict[str, list[float]]
    quantity: str
    meaning: str
    since_calibration: dict[str, Any] | None = None


# -- the result ----------------------------------------------------------------------------------
class ResultDocument(Section):
    """What a job found, section by section (see the module docstring)."""

    estimation: EstimationSummary | None = None
    estimation_2: EstimationSummary | None = None
    calibration: dict[str, Any] | None = None
    calibration_2: dict[str, Any] | None = None
    correction: CorrectionPlan | None = None
    correction_2: CorrectionPlan | None = None
    base: list[list[float]] | None = None
    frame_note: str | None = None
    performance: dict[str, PerformanceSection] | None = None
    home_check: HomeCheck | None = None
    test_conditions: dict[str, str | int | float] | None = None
    arm_readings_discarded: DiscardedReadings | None = None
    poses_skipped: dict[str, list[int]] | None = None  # the beam stayed broken: not measured
    backlash: dict[str, Any] | None = None  # calibration.backlash.BacklashEstimate.to_dict
    drift: DriftSection | None = None
    warnings: list[str] | None = None

    def estimation_of(self, suffix: Round) -> EstimationSummary | None:
        return self.estimation_2 if suffix else self.estimation

    def calibration_of(self, suffix: Round) -> dict[str, Any] | None:
        return self.calibration_2 if suffix else self.calibration

    def correction_of(self, suffix: Round) -> CorrectionPlan | None:
        return self.correction_2 if suffix else self.correction

    def overall(self, phase: str, key: str) -> float | None:
        """Performance list `phase`'s overall figure `key` (the performance package's
        `summarise`: ap_mm_mean, rp_mm_max, ...), None when the list or the figure is absent."""
        section = (self.performance or {}).get(phase)
        value = (section.overall or {}).get(key) if section is not None else None
        return None if value is None else float(value)

    def latest_round(self) -> Round:
        """The newest calibration round this result holds: '_2' once the second round's
        estimation (stored with its calibration) is in, else '' (also when there is none: its
        `estimation_of` is then None)."""
        return "_2" if self.estimation_2 is not None else ""

    def with_round(self, suffix: Round, *, estimation: EstimationSummary | None = None,
                   calibration: dict[str, Any] | None = None,
                   correction: CorrectionPlan | None = None) -> ResultDocument:
        """A copy with the given sections of calibration round `suffix` set."""
        update: dict[str, Any] = {}
        for name, value in (("estimation", estimation), ("calibration", calibration),
                            ("correction", correction)):
            if value is not None:
                update[name + suffix] = value
        return self.model_copy(update=update)


class JobRecord(BaseModel):
    """A job as stored."""

    id: int
    robot_id: int
    kind: Literal["performance", "calibration", "procedure", "verify"]
    mode: Literal["AUTO", "STEP"]
    state: JobState
    reason: str
    options: JobOptions
    phases: dict[str, PhaseRecord]
    result: ResultDocument = Field(default_factory=ResultDocument)
    created: float
    updated: float

    @model_validator(mode="before")
    @classmethod
    def _no_result_yet(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("result") is None:
            data = {k: v for k, v in data.items() if k != "result"}
        return data
