"""The model file: JSON, validated by pydantic, in the interface units (mm, degrees).

One schema, three representations of the same serial model (chosen with `representation`):

- "screws": per joint a unit direction and a point on the axis at home, plus the home flange pose;
- "dh" / "mdh": a standard or modified Denavit-Hartenberg table, with `dh_base` (robot base <-
  DH frame 0) and `dh_flange` (DH frame n <- flange).

Every representation also carries per-joint `zero_deg` and `limits_deg`, and the `base` (world
<- robot base) and `tool` (flange <- measured point) poses; a model with joint compliance carries
`gravity`: per-joint compliance in deg per kN m, the lumped masses that load the joints (joint
numbers from 1, kg, centre at home in mm) and the payload (kg, centre of gravity in the flange
frame, mm). Poses are {x, y, z} in mm and
{rx, ry, rz} in degrees with R = Rz(rz) Ry(ry) Rx(rx). For prismatic joints, `zero_deg`,
`limits_deg` and `theta_deg`/`d_mm` values along the joint are in mm.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, field_validator

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import LumpedMass, Payload
from screwcal.kinematics.dh import DHRow, DHTable, dh_from_model, model_from_dh
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose

FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]
FORMAT = "screwcal-model"


class PoseIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    x: FiniteFloat = 0.0
    y: FiniteFloat = 0.0
    z: FiniteFloat = 0.0
    rx: FiniteFloat = 0.0
    ry: FiniteFloat = 0.0
    rz: FiniteFloat = 0.0

    def transform(self) -> np.ndarray:
        return transform_from_pose([self.x, self.y, self.z, self.rx, self.ry, self.rz])

    @classmethod
    def of(cls, T: np.ndarray) -> PoseIn:
        x, y, z, rx, ry, rz = (float(v) for v in pose_from_transform(T))
        return cls(x=x, y=y, z=z, rx=rx, ry=ry, rz=rz)


class JointCommon(BaseModel):
    model_config = ConfigDict(extra="forbid")
    type: Literal["R", "P"] = "R"
    zero_deg: FiniteFloat = 0.0
    limits_deg: tuple[FiniteFloat, FiniteFloat]

    @field_validator("limits_deg")
    @classmethod
    def _ordered(cls, v: tuple[float, float]) -> tuple[float, float]:
        if not v[0] < v[1]:
            raise ValueError(f"limits must be [min, max] with min < max, got {list(v)}")
        return v


class ScrewJoint(JointCommon):
    direction: Vec3
    point_mm: Vec3 = (0.0, 0.0, 0.0)

    @field_validator("direction")
    @classmethod
    def _unit(cls, v: Vec3) -> Vec3:
        norm = math.sqrt(sum(c * c for c in v))
        if abs(norm - 1.0) > 1e-6:
            raise ValueError(f"direction must be a unit vector, its norm is {norm:.9g}")
        return v


class DHJoint(JointCommon):
    a_mm: FiniteFloat
    alpha_deg: FiniteFloat
    d_mm: FiniteFloat
    theta_deg: FiniteFloat


class MassIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    joint: int = Field(ge=1)  # the mass moves with this joint (1-based)
    kg: FiniteFloat = Field(gt=0)
    home_mm: Vec3


class PayloadIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    kg: FiniteFloat = Field(default=0.0, ge=0)
    cog_mm: Vec3 = (0.0, 0.0, 0.0)


class GravityIn(BaseModel):
    """Joint compliance under gravity (`screwcal.kinematics.compliance`)."""

    model_config = ConfigDict(extra="forbid")
    compliance_deg_per_knm: list[Annotated[float, Field(ge=0, allow_inf_nan=False)]]
    # per joint and arm mass (rows: joints, columns: `masses`), replacing the per-joint values
    compliance_by_mass_deg_per_knm: list[list[FiniteFloat]] | None = None
    masses: list[MassIn] = []
    payload: PayloadIn = PayloadIn()

    def fields(self, n: int) -> dict:
        if len(self.compliance_deg_per_knm) != n:
            raise ModelError(f"gravity.compliance_deg_per_knm has "
                             f"{len(self.compliance_deg_per_knm)} values for {n} joints")
        for m in self.masses:
            if m.joint > n:
                raise ModelError(f"gravity.masses: joint {m.joint} of a {n}-joint model")
        by_mass = self.compliance_by_mass_deg_per_knm
        if by_mass is not None and np.shape(by_mass) != (n, len(self.masses)):
            raise ModelError(f"gravity.compliance_by_mass_deg_per_knm must be {n} rows of "
                             f"{len(self.masses)} (one per mass), got {np.shape(by_mass)}")
        return dict(compliance=np.radians(self.compliance_deg_per_knm) / 1000.0,
                    compliance_by_mass=None if by_mass is None else
                    np.radians(np.array(by_mass, float)) / 1000.0,
                    masses=tuple(LumpedMass(m.joint - 1, m.kg, m.home_mm) for m in self.masses),
                    payload=Payload(self.payload.kg, self.payload.cog_mm))

    @classmethod
    def of(cls, model: SerialModel) -> GravityIn | None:
        if not model.has_compliance and model.payload.kg == 0.0:
            return None
        by_mass = model.compliance_by_mass
        return cls(compliance_deg_per_knm=[float(v) for v in np.degrees(model.compliance)
                                           * 1000.0],
                   compliance_by_mass_deg_per_knm=None if by_mass is None else
                   (np.degrees(by_mass) * 1000.0).tolist(),
                   masses=[MassIn(joint=m.link + 1, kg=m.kg, home_mm=m.home_mm)
                           for m in model.masses],
                   payload=PayloadIn(kg=model.payload.kg, cog_mm=model.payload.cog_mm))


class _FileCommon(BaseModel):
    model_config = ConfigDict(extra="forbid")
    format: Literal["screwcal-model"] = FORMAT
    version: Literal[1] = 1
    name: str = Field(min_length=1)
    base: PoseIn = PoseIn()
    tool: PoseIn = PoseIn()
    gravity: GravityIn | None = None

    def _with_gravity(self, model: SerialModel) -> SerialModel:
        if self.gravity is None:
            return model
        return replace(model, **self.gravity.fields(model.n_joints))

    def _numeric(self, joints: list[ScrewJoint] | list[DHJoint]) -> tuple[np.ndarray, np.ndarray]:
        """Limits (n, 2) and zeros (n,) in numeric units (rad for R, mm for P)."""
        rev = np.array([j.type == "R" for j in joints])
        limits = np.array([list(j.limits_deg) for j in joints], dtype=float)
        zero = np.array([j.zero_deg for j in joints], dtype=float)
        return (np.where(rev[:, None], np.radians(limits), limits),
                np.where(rev, np.radians(zero), zero))


class ScrewsFile(_FileCommon):
    """representation "screws": joint screws at home and the home flange pose."""

    representation: Literal["screws"]
    joints: list[ScrewJoint] = Field(min_length=1)
    home_flange: PoseIn

    def to_model(self) -> SerialModel:
        limits, zero = self._numeric(self.joints)
        return self._with_gravity(SerialModel(
            name=self.name, joint_types=tuple(j.type for j in self.joints),
            axis_dirs=[j.direction for j in self.joints],
            axis_points_mm=[j.point_mm for j in self.joints],
            home_flange=self.home_flange.transform(), limits=limits, joint_zero=zero,
            base=self.base.transform(), tool=self.tool.transform()))


class DHFile(_FileCommon):
    """representation "dh" / "mdh": a DH table with the frames that close it."""

    representation: Literal["dh", "mdh"]
    joints: list[DHJoint] = Field(min_length=1)
    dh_base: PoseIn
    dh_flange: PoseIn

    def to_model(self) -> SerialModel:
        limits, zero = self._numeric(self.joints)
        rows = tuple(DHRow(a_mm=j.a_mm, alpha=math.radians(j.alpha_deg), d_mm=j.d_mm,
                           theta=math.radians(j.theta_deg), joint_type=j.type)
                     for j in self.joints)
        table = DHTable(convention=self.representation, rows=rows,
                        dh_base=self.dh_base.transform(), dh_flange=self.dh_flange.transform())
        return self._with_gravity(model_from_dh(table, self.name, limits, zero,
                                                self.base.transform(), self.tool.transform()))


ModelFile = Annotated[ScrewsFile | DHFile, Field(discriminator="representation")]
_ADAPTER: TypeAdapter[ScrewsFile | DHFile] = TypeAdapter(ModelFile)


def model_file_from_model(model: SerialModel,
                          representation: Literal["screws", "dh", "mdh"] = "screws"
                          ) -> ScrewsFile | DHFile:
    """The file document of a model, in the chosen representation."""
    limits = model.limits_deg
    zero = model.joints_to_deg(model.joint_zero)
    common = [dict(type=t, zero_deg=float(zero[i]), limits_deg=(float(limits[i, 0]),
                                                                 float(limits[i, 1])))
              for i, t in enumerate(model.joint_types)]
    frames = dict(base=PoseIn.of(model.base), tool=PoseIn.of(model.tool),
                  gravity=GravityIn.of(model))
    if representation == "screws":
        joints = [ScrewJoint(direction=tuple(float(c) for c in model.axis_dirs[i]),
                             point_mm=tuple(float(c) for c in model.axis_points_mm[i]), **c)
                  for i, c in enumerate(common)]
        return ScrewsFile(name=model.name, representation="screws", joints=joints,
                         home_flange=PoseIn.of(model.home_flange), **frames)
    table = dh_from_model(model, representation)
    dh_joints = [DHJoint(a_mm=r.a_mm, alpha_deg=math.degrees(r.alpha), d_mm=r.d_mm,
                         theta_deg=math.degrees(r.theta), **c)
                 for r, c in zip(table.rows, common, strict=True)]
    return DHFile(name=model.name, representation=representation, joints=dh_joints,
                     dh_base=PoseIn.of(table.dh_base), dh_flange=PoseIn.of(table.dh_flange),
                     **frames)


def _describe(err: ValidationError) -> str:
    parts = []
    for e in err.errors():
        loc = e["loc"][1:] if e["loc"] and e["loc"][0] in ("screws", "dh", "mdh") else e["loc"]
        where = ".".join(str(x) for x in loc) or "document"
        parts.append(f"{where}: {e['msg']}")
    return "; ".join(parts)


def parse_model(data: dict, source: str = "model") -> SerialModel:
    """A serial model from a decoded JSON object. A calibration result (with a `model` member)
    is accepted as well."""
    if isinstance(data, dict) and "model" in data and "representation" not in data:
        data = data["model"]
    try:
        return _ADAPTER.validate_python(data).to_model()
    except ValidationError as err:
        raise ModelError(f"{source}: invalid model file: {_describe(err)}") from None


def load_model(path: str | Path) -> SerialModel:
    """Read a model file (any representation)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ModelError(f"{path}: model file not found") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ModelError(f"{path}: not a JSON model file ({err})") from None
    return parse_model(data, str(path))


def save_model(model: SerialModel, path: str | Path,
               representation: Literal["screws", "dh", "mdh"] = "screws") -> None:
    """Write a model file in the chosen representation."""
    doc = model_file_from_model(model, representation)
    Path(path).write_text(doc.model_dump_json(indent=2) + "\n", encoding="utf-8")


def resolve_model(name_or_path: str) -> SerialModel:
    """A built-in model name (`irb1600`, `irb120`) or the path of a model / result file."""
    from screwcal.kinematics.robots import BUILTIN_MODELS, builtin_model

    if name_or_path in BUILTIN_MODELS:
        return builtin_model(name_or_path)
    if not Path(name_or_path).exists():
        raise ModelError(f"'{name_or_path}' is neither a built-in robot "
                         f"({', '.join(sorted(BUILTIN_MODELS))}) nor an existing model file")
    return load_model(name_or_path)
