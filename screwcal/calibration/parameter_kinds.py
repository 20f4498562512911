"""One identifiable parameter (`Param`): its name and unit, how it acts on the model
(`ParamKind`), and the frame that carries its twist to the world (`Carrier`, which
`error_parameters.ErrorModel.linearisation` reads per column).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, StrEnum

from screwcal.kinematics.compliance import COMPLIANCE_UNIT


class Carrier(Enum):
    """The frame that carries a parameter's local twist to the world (`ErrorModel.
    linearisation`): the partial products of the chain A_0..A_n, the flange pose, the world."""

    JOINT = "its joint's partial product (the chain up to the joint)"
    NEXT_JOINT = "the partial product after its joint"
    AXIS = "its joint's partial product less the next one's (the axis itself moves)"
    HOME = "the last partial product (the home flange rides on every joint)"
    TOOL = "the flange pose (the tool is expressed in the flange frame)"
    WORLD = "the world (the measuring system's frame)"


# each kind's carrier, by its value (a ParamKind is its string)
_CARRIERS: dict[str, Carrier] = {
    "zero": Carrier.JOINT, "compliance": Carrier.JOINT,
    "compliance_mass": Carrier.JOINT,  # compliance: a zero scaled by the torque
    "link": Carrier.NEXT_JOINT,  # a translation of the chain after the joint
    "dir": Carrier.AXIS, "point": Carrier.AXIS,
    "home_rot": Carrier.HOME, "home_pos": Carrier.HOME,
    "base_rot": Carrier.WORLD, "base_pos": Carrier.WORLD,
    "tool_rot": Carrier.TOOL, "tool_pos": Carrier.TOOL,
}


class ParamKind(StrEnum):
    """How a parameter acts on the model, and the frame that carries it (`carrier`)."""

    ZERO = "zero"  # a joint's zero (rad, or mm for a prismatic joint)
    LINK = "link"  # a virtual prismatic joint after a joint, along a home-frame axis (thesis)
    DIR = "dir"  # a joint axis' direction, turned about one of its two normals
    POINT = "point"  # a revolute axis' location, moved along one of its normals
    COMPLIANCE = "compliance"  # a joint's compliance under the gravity torque of every mass
    COMPLIANCE_MASS = "compliance_mass"  # ...under the torque of one arm mass (j23-free)
    HOME_ROT = "home_rot"  # the home flange's rotation (rotation vector) and position
    HOME_POS = "home_pos"
    BASE_ROT = "base_rot"  # the measuring system's frame
    BASE_POS = "base_pos"
    TOOL_ROT = "tool_rot"  # the measured point's frame on the flange
    TOOL_POS = "tool_pos"

    @property
    def carrier(self) -> Carrier:
        return _CARRIERS[self]

    @property
    def frame(self) -> str | None:
        """"home", "base" or "tool" for a frame's parameter, else None (the joints')."""
        head, _, tail = self.value.partition("_")
        return head if tail in ("rot", "pos") else None

    @property
    def is_compliance(self) -> bool:
        return self in (ParamKind.COMPLIANCE, ParamKind.COMPLIANCE_MASS)




@dataclass(frozen=True)
class Param:
    """One identifiable parameter. `kind` says how it acts; `index` the joint (0-based) or axis."""

    name: str
    unit: str  # "deg" or "mm" at the interface; values inside are rad or mm
    kind: ParamKind  # (its value, e.g. "zero", is taken too)
    joint: int = -1
    axis: int = -1  # 0..2 for frames and link offsets, 0..1 for dir/point normals

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", ParamKind(self.kind))

    @property
    def is_angle(self) -> bool:
        """Degrees at the interface, radians inside (compliance: deg vs rad per kN m)."""
        return self.unit in ("deg", COMPLIANCE_UNIT)

    @property
    def group(self) -> str:
        """"robot" for the robot's own geometry, "base"/"tool" for the frames."""
        frame = self.kind.frame
        return frame if frame in ("base", "tool") else "robot"
