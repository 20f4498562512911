"""The model file's schema (pydantic): what `modelfile.parse_model` accepts, field by field.

Only reading needs it: a document is written as plain JSON by `modelfile.model_document`, and a
test holds the two to the same fields (the schema, dumping what it reads, gives back the very
document written). Importing pydantic and building these classes costs ~90 ms and ~10 MB, which
`screwcal calibrate` (it writes a model, it reads none) no longer pays. The file's format is
described in `modelfile`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    TypeAdapter,
    ValidationError,
    field_validator,
    model_serializer,
)

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import LumpedMass, Payload
from screwcal.kinematics.dh import DHRow, DHTable, model_from_dh
from screwcal.kinematics.model import JointRating, SerialModel
from screwcal.kinematics.pose import transform_from_pose

# every number of a model file: finite and within 1e9 (mm, deg, kg, deg/kNm): beyond, a figure
# is a mistake (1e300 mm passed, and products of such overflowed to inf downstream)
FIGURE_MAX = 1e9
FiniteFloat = Annotated[float, Field(allow_inf_nan=False, ge=-FIGURE_MAX, le=FIGURE_MAX)]
Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]



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


class JointCommon(BaseModel):
    model_config = ConfigDict(extra="forbid")
    type: Literal["R", "P"] = "R"
    zero_deg: FiniteFloat = 0.0
    limits_deg: tuple[FiniteFloat, FiniteFloat]
    # kept from a robot description (URDF) to be written back: the joint's name, its largest
    # effort (N m; N for P) and speed (deg/s; mm/s for P)
    name: str | None = Field(default=None, min_length=1)
    effort_nm: FiniteFloat | None = Field(default=None, ge=0)
    velocity_deg_s: FiniteFloat | None = Field(default=None, ge=0)

    @model_serializer(mode="wrap")
    def _without_unknown_ratings(self, write: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The ratings a file did not give stay out of it (as modelfile writes them)."""
        out: dict[str, Any] = write(self)
        return {k: v for k, v in out.items()
                if v is not None or k not in ("name", "effort_nm", "velocity_deg_s")}

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
    beta_deg: FiniteFloat = 0.0  # Hayati's, "mdh" only (dh.py)


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
    compliance_deg_per_knm: list[Annotated[float, Field(ge=0, le=FIGURE_MAX,
                                                         allow_inf_nan=False)]]
    # per joint and arm mass (rows: joints, columns: `masses`), replacing the per-joint values
    compliance_by_mass_deg_per_knm: list[list[FiniteFloat]] | None = None
    masses: list[MassIn] = []
    payload: PayloadIn = PayloadIn()

    def applied_to(self, model: SerialModel) -> SerialModel:
        """The model with this gravity section's compliance, masses and payload."""
        n = model.n_joints
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
        return replace(model, compliance=np.radians(self.compliance_deg_per_knm) / 1000.0,
                       compliance_by_mass=None if by_mass is None else
                       np.radians(np.array(by_mass, float)) / 1000.0,
                       masses=tuple(LumpedMass(m.joint - 1, m.kg, m.home_mm)
                                    for m in self.masses),
                       payload=Payload(self.payload.kg, self.payload.cog_mm))


class _FileCommon(BaseModel):
    model_config = ConfigDict(extra="forbid")
    # modelfile.FORMAT (spelled here: a Literal needs the text, and importing modelfile
    # would close a cycle; tests/screwcal/kinematics hold the two equal)
    format: Literal["screwcal-model"] = "screwcal-model"
    version: Literal[1] = 1
    name: str = Field(min_length=1)
    base: PoseIn = PoseIn()
    tool: PoseIn = PoseIn()
    gravity: GravityIn | None = None

    def _with_gravity(self, model: SerialModel,
                      joints: list[ScrewJoint] | list[DHJoint]) -> SerialModel:
        """The model with the gravity section and the joints' ratings (when any is given)."""
        if any(j.name or j.effort_nm is not None or j.velocity_deg_s is not None
               for j in joints):
            model = replace(model, ratings=tuple(JointRating(
                j.name or "", j.effort_nm, None if j.velocity_deg_s is None else
                (math.radians(j.velocity_deg_s) if j.type == "R" else j.velocity_deg_s))
                for j in joints))
        if self.gravity is None:
            return model
        return self.gravity.applied_to(model)

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
            axis_dirs=np.array([j.direction for j in self.joints], float),
            axis_points_mm=np.array([j.point_mm for j in self.joints], float),
            home_flange=self.home_flange.transform(), limits=limits, joint_zero=zero,
            base=self.base.transform(), tool=self.tool.transform()), self.joints)


class DHFile(_FileCommon):
    """representation "dh" / "mdh": a DH table with the frames that close it."""

    representation: Literal["dh", "mdh"]
    joints: list[DHJoint] = Field(min_length=1)
    dh_base: PoseIn
    dh_flange: PoseIn

    def to_model(self) -> SerialModel:
        limits, zero = self._numeric(self.joints)
        if self.representation == "dh":
            for i, j in enumerate(self.joints):
                if j.beta_deg != 0.0:
                    raise ModelError(f"joints.{i}.beta_deg: Hayati's beta belongs to the "
                                     "modified table (representation mdh), not standard dh")
        rows = tuple(DHRow(a_mm=j.a_mm, alpha=math.radians(j.alpha_deg), d_mm=j.d_mm,
                           theta=math.radians(j.theta_deg), joint_type=j.type,
                           beta=math.radians(j.beta_deg))
                     for j in self.joints)
        table = DHTable(convention=self.representation, rows=rows,
                        dh_base=self.dh_base.transform(), dh_flange=self.dh_flange.transform())
        return self._with_gravity(model_from_dh(table, self.name, limits, zero,
                                                self.base.transform(), self.tool.transform()),
                                  self.joints)


ModelFile = Annotated[ScrewsFile | DHFile, Field(discriminator="representation")]
ADAPTER: TypeAdapter[ScrewsFile | DHFile] = TypeAdapter(ModelFile)


def describe(err: ValidationError) -> str:
    """Each failed field by its place in the document, with pydantic's message."""
    parts = []
    for e in err.errors():
        loc = e["loc"][1:] if e["loc"] and e["loc"][0] in ("screws", "dh", "mdh") else e["loc"]
        where = ".".join(str(x) for x in loc) or "document"
        parts.append(f"{where}: {e['msg']}")
    return "; ".join(parts)
