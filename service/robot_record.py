"""A robot cell as the service stores it: its controller, its model, and the instrument that
measures it, one of three (a discriminated union on `kind`):

- `arm`: the measuring arm over its serial line (`url`: a serial device, socket://, rfc2217://,
  loop://); it probes the flange's three holes (the record's `holes_mm`);
- `tracker`: a laser tracker over Leica emScon TPI (`host`, `port` 700 by default), measuring
  one SMR (positions) or three (the flange's pose) at `smrs_mm` in tool0, standing roughly at
  `stand_mm` in the robot's base frame (turned `yaw_deg` about the vertical) so that the job's
  poses are planned for its beam to see;
- `external`: any other instrument (SpatialAnalyzer, PolyWorks, a FARO or API SDK script): the
  job waits at each pose until the measurement is posted (POST /jobs/ID/measurement); its
  targets in tool0 are `targets_mm` (one point: positions; three: the pose), by default the
  record's holes.

A record of an older release names no instrument: its `arm_url` is read as an `arm`. What a
stored record holds is read as it was stored (an address checked since it was written is
checked again when the job opens it); what a new record may hold is checked by
`service/schemas.py`'s `RobotCreate`.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, computed_field, model_validator

from protocol.emscon import DEFAULT_PORT as EMSCON_PORT
from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM
from screwcal.instrument import TRACKER_STAND_MM

Point = Annotated[list[float], Field(min_length=3, max_length=3)]


class ArmSetup(BaseModel):
    """The measuring arm on its serial line."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    kind: Literal["arm"] = "arm"
    url: str = Field(min_length=1, max_length=200, description="a serial device "
                     "(/dev/ttyUSB0, COM3), socket://HOST:PORT, rfc2217://HOST:PORT or loop://")


class TrackerSetup(BaseModel):
    """A laser tracker over emScon TPI and its reflectors on the flange."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    kind: Literal["tracker"] = "tracker"
    host: str = Field(min_length=1, max_length=253, description="the tracker's controller")
    port: int = Field(EMSCON_PORT, ge=1, le=65535, description="its TPI port (700)")
    smrs_mm: list[Point] = Field(
        default_factory=lambda: [list(DEFAULT_SMR_MM)], min_length=1, max_length=3,
        description="the SMRs' centres in tool0, mm: one (positions) or three (the pose)")
    stand_mm: Point = Field(default_factory=lambda: list(TRACKER_STAND_MM),
                            description="where the tracker stands, roughly, mm in the robot's "
                            "base frame: the job's poses are planned for its beam")
    yaw_deg: float = Field(0.0, ge=-360.0, le=360.0, description="its frame turned about the "
                           "vertical from the robot's, roughly (points the beam at SMRs 2, 3)")
    initialise: bool = Field(True, description="initialise the tracker when the job connects")

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"emscon://{host}:{self.port}"


class ExternalSetup(BaseModel):
    """Another instrument, whose software posts each pose's measurement to the job."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    kind: Literal["external"] = "external"
    targets_mm: list[Point] | None = Field(
        None, min_length=1, max_length=3, description="what it measures, in tool0 (mm): one "
        "point (positions) or three (the pose); none: the record's holes")
    name: str = Field("", max_length=80, description="what it is (e.g. 'AT960 via "
                      "SpatialAnalyzer'), for the report")


InstrumentSetup = Annotated[ArmSetup | TrackerSetup | ExternalSetup,
                            Field(discriminator="kind")]
INSTRUMENT_KINDS = ("arm", "tracker", "external")


class RobotRecord(BaseModel):
    """One stored robot cell (GET /robots/ID)."""

    id: int
    name: str
    controller_host: str
    controller_port: int
    instrument: InstrumentSetup
    model: dict[str, Any]
    holes_mm: list[list[float]]
    serial: str = ""
    controller_software: str = ""
    tool: str = ""
    payload_kg: float | None = None
    emulation: list[str] = Field(default_factory=list)

    @model_validator(mode="before")
    @classmethod
    def _older_record(cls, data: Any) -> Any:
        """A record of an older release: no instrument, its arm's address in `arm_url`."""
        if isinstance(data, dict) and data.get("instrument") is None:
            return {**data, "instrument": {"kind": "arm", "url": data.get("arm_url") or ""}}
        return data

    @computed_field  # type: ignore[prop-decorator]  # pydantic: a property under it, as documented
    @property
    def arm_url(self) -> str:
        """The measuring arm's address ('' for another instrument): what older clients read."""
        return self.instrument.url if isinstance(self.instrument, ArmSetup) else ""

    def targets_mm(self) -> list[list[float]]:
        """What the instrument measures at each pose, mm in tool0: the arm's holes, the
        tracker's SMRs, the external instrument's targets."""
        if isinstance(self.instrument, TrackerSetup):
            return self.instrument.smrs_mm
        if isinstance(self.instrument, ExternalSetup) and self.instrument.targets_mm:
            return self.instrument.targets_mm
        return self.holes_mm

    def instrument_text(self) -> str:
        """The instrument in a line (the report's and the ISO conditions')."""
        ins = self.instrument
        if isinstance(ins, ArmSetup):
            return ins.url
        if isinstance(ins, TrackerSetup):
            return (f"laser tracker {ins.url} (emScon TPI), {len(ins.smrs_mm)} SMR"
                    f"{'s' if len(ins.smrs_mm) > 1 else ''}")
        return f"external instrument{f' ({ins.name})' if ins.name else ''}, measurements posted"
