"""The serial model: joint screws at home, the home flange, base and tool transforms, limits.

A model maps joint values q to the pose of the measured point (the "tool") in the world frame
(the measuring system's frame) by successive screws (thesis 2.2.1.2, Tsai; product of
exponentials):

    T_world_tool(q) = base . exp([S_1](q_1 + z_1)) ... exp([S_n](q_n + z_n)) . home_flange . tool

with S_i the joint-i screw at home expressed in the robot base frame: a unit direction and a point
on the axis (revolute), or a unit direction (prismatic). `z_i` is the joint zero: the controller's
reading q_i differs from the joint's angle by z_i. Values are stored in radians / mm; the interface
units (degrees) live in the names of the accessors that return them.

With `compliance` (rad per N m, per joint) the joints also bend under gravity: joint i stands at
q_i + z_i + c_i tau_i(q), tau from the lumped `masses` and the `payload` (`compliance`).
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, wraps
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import JointLimitError, ModelError
from screwcal.kinematics.compliance import LumpedMass, Payload, payload_mass
from screwcal.kinematics.se3 import Array, Mask

_K = TypeVar("_K")
_V = TypeVar("_V")


def once_per_object(compute: Callable[[_K], _V]) -> Callable[[_K], _V]:
    """`compute(obj)` once per object, forgotten with it: for the tables numeric code derives
    from a model (its arrays are read-only: a changed model is a new object)."""
    cache: weakref.WeakKeyDictionary[_K, _V] = weakref.WeakKeyDictionary()

    @wraps(compute)
    def cached(obj: _K) -> _V:
        try:
            return cache[obj]
        except KeyError:  # (a None result is kept too: the UR geometry of another arm)
            got = cache[obj] = compute(obj)
            return got

    return cached


REVOLUTE = "R"
PRISMATIC = "P"
_UNIT_TOL = 1e-9


def _frozen(a: ArrayLike, shape: tuple[int, ...], what: str) -> Array:
    arr = np.array(a, dtype=float)
    if arr.shape != shape:
        raise ModelError(f"{what}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{what}: every value must be a finite number")
    arr.setflags(write=False)
    return arr


_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
# The default of `joint_zero` and `compliance`: zeros of the model's length, set by
# __post_init__ (which knows the length); this one object marks "not given".
_ZEROS: Array = np.zeros(0)


def _check_rigid(T: Array, what: str) -> None:
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-9 or np.linalg.det(R) < 0:
        raise ModelError(f"{what}: the rotation part is not a proper rotation matrix")
    if np.abs(T[3] - _LAST_ROW).max() > 1e-12:
        raise ModelError(f"{what}: the last row must be (0, 0, 0, 1), got {T[3].tolist()}")


@dataclass(frozen=True)
class JointRating:
    """What a robot description says of a joint beyond its geometry, kept to be written back:
    its name (URDF's joint_a1, shoulder_pan_joint), the largest effort (N m; N prismatic) and
    speed (rad/s; mm/s prismatic); None when not given."""

    name: str = ""
    effort: float | None = None
    velocity: float | None = None


@dataclass(frozen=True, eq=False)
class SerialModel:
    """A serial robot by successive screws. Arrays are read-only; use `dataclasses.replace`.

    Attributes
    ----------
    name : str
    joint_types : tuple of "R" / "P", length n
    axis_dirs : array, shape (n, 3) — unit joint directions at home, robot base frame
    axis_points_mm : array, shape (n, 3) — a point on each joint axis at home (unused for "P")
    home_flange : array, shape (4, 4) — flange (tool0) pose in the robot base frame at q = 0
    limits : array, shape (n, 2) — joint limits, rad (revolute) or mm (prismatic), min < max
    joint_zero : array, shape (n,) — added to the controller's joint values, rad or mm
    base : array, shape (4, 4) — world (measuring system) from robot base; identity by default
    tool : array, shape (4, 4) — flange to measured point; identity by default
    ratings : tuple of JointRating — names, efforts and speeds a description gave, or ()
    """

    name: str
    joint_types: tuple[str, ...]
    axis_dirs: Array
    axis_points_mm: Array
    home_flange: Array
    limits: Array
    joint_zero: Array = field(default_factory=lambda: _ZEROS)
    base: Array = field(default_factory=lambda: np.eye(4))
    tool: Array = field(default_factory=lambda: np.eye(4))
    compliance: Array = field(default_factory=lambda: _ZEROS)  # rad/(N m), (n,)
    masses: tuple[LumpedMass, ...] = ()
    # (n, len(masses)) rad/(N m): per joint and arm mass, replacing `compliance` when given
    compliance_by_mass: Array | None = None
    payload: Payload = field(default_factory=Payload)
    ratings: tuple[JointRating, ...] = ()  # per joint, or () when the description gave none

    def __post_init__(self) -> None:
        n = len(self.joint_types)
        if n == 0:
            raise ModelError(f"model '{self.name}': a serial model needs at least one joint")
        bad = [t for t in self.joint_types if t not in (REVOLUTE, PRISMATIC)]
        if bad:
            raise ModelError(f"model '{self.name}': joint types are 'R' or 'P', got {bad}")
        object.__setattr__(self, "joint_types", tuple(self.joint_types))
        zero = np.zeros(n) if self.joint_zero is _ZEROS else self.joint_zero
        for name, value, shape in (
            ("axis_dirs", self.axis_dirs, (n, 3)),
            ("axis_points_mm", self.axis_points_mm, (n, 3)),
            ("home_flange", self.home_flange, (4, 4)),
            ("limits", self.limits, (n, 2)),
            ("joint_zero", zero, (n,)),
            ("compliance", np.zeros(n) if self.compliance is _ZEROS else self.compliance, (n,)),
            ("base", self.base, (4, 4)),
            ("tool", self.tool, (4, 4)),
        ):
            object.__setattr__(self, name, _frozen(value, shape, f"model '{self.name}', {name}"))
        norms = np.linalg.norm(self.axis_dirs, axis=1)
        for i in np.flatnonzero(np.abs(norms - 1.0) > _UNIT_TOL):
            raise ModelError(f"model '{self.name}', joint {i + 1}: axis direction must be a unit "
                             f"vector, its norm is {norms[i]:.12g}")
        for i in np.flatnonzero(self.limits[:, 0] >= self.limits[:, 1]):
            raise ModelError(f"model '{self.name}', joint {i + 1}: limits must satisfy min < max, "
                             f"got {self.limits[i].tolist()}")
        for what in ("home_flange", "base", "tool"):
            _check_rigid(getattr(self, what), f"model '{self.name}', {what}")
        object.__setattr__(self, "masses", tuple(self.masses))
        if self.ratings and len(self.ratings) != n:
            raise ModelError(f"model '{self.name}': {len(self.ratings)} joint ratings for {n} "
                             "joints")
        if self.compliance_by_mass is not None:
            object.__setattr__(self, "compliance_by_mass", _frozen(
                self.compliance_by_mass, (n, len(self.masses)),
                f"model '{self.name}', compliance_by_mass"))
        if self.has_compliance and not self.all_masses:
            raise ModelError(f"model '{self.name}': joint compliance needs the masses that load "
                             "the joints (a mass table or a payload)")
        if np.any(self.compliance < 0):
            raise ModelError(f"model '{self.name}': a joint compliance cannot be negative, got "
                             f"{self.compliance.tolist()}")

    def derived(self, **changes: object) -> SerialModel:
        """A copy with some arrays replaced, skipping validation: for numeric code that derives
        models from a validated one by steps that keep the invariants (unit axes from
        normalisation, rotations from exponentials). Everything else uses dataclasses.replace."""
        out = object.__new__(SerialModel)
        for name in self.__dataclass_fields__:
            value = changes.get(name, getattr(self, name))
            if isinstance(value, np.ndarray) and value.flags.writeable:
                value = value.view()  # read-only through the model, as validated ones are
                value.setflags(write=False)
            object.__setattr__(out, name, value)
        return out

    @cached_property
    def has_compliance(self) -> bool:
        """Any joint compliance (computed once: the arrays are read-only)."""
        return bool(self.compliance.any()) or (self.compliance_by_mass is not None
                                               and bool(self.compliance_by_mass.any()))

    @property
    def all_masses(self) -> tuple[LumpedMass, ...]:
        """The arm's lumped masses and the payload's."""
        return self.masses + payload_mass(self.payload, self.home_flange, self.n_joints)

    @property
    def n_joints(self) -> int:
        return len(self.joint_types)

    @property
    def is_revolute(self) -> Mask:
        """Boolean mask, shape (n,)."""
        return np.array([t == REVOLUTE for t in self.joint_types])

    @property
    def limits_deg(self) -> Array:
        """Joint limits in the interface units: degrees (revolute) or mm (prismatic)."""
        return np.where(self.is_revolute[:, None], np.degrees(self.limits), self.limits)

    def joints_from_deg(self, q_deg: ArrayLike) -> Array:
        """Controller joint values (deg for revolute, mm for prismatic) -> numeric units."""
        q = np.asarray(q_deg, dtype=float)
        return np.where(self.is_revolute, np.radians(q), q)

    def joints_to_deg(self, q: ArrayLike) -> Array:
        """Numeric joint values -> controller units (deg for revolute, mm for prismatic)."""
        q = np.asarray(q, dtype=float)
        return np.where(self.is_revolute, np.degrees(q), q)

    def within_limits(self, q: ArrayLike, margin: float = 0.0) -> Mask:
        """Mask of configurations (..., n) inside the limits shrunk by `margin` (rad/mm)."""
        q = np.asarray(q, dtype=float)
        inside = (q >= self.limits[:, 0] + margin) & (q <= self.limits[:, 1] - margin)
        within: Mask = np.all(inside, axis=-1)
        return within

    def check_limits(self, q: ArrayLike, what: str = "configuration") -> None:
        """Raise JointLimitError naming the first configuration and joint outside the limits."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        outside = (q < self.limits[:, 0]) | (q > self.limits[:, 1])
        if outside.any():
            k, j = np.argwhere(outside)[0]
            lo, hi = self.limits_deg[j]
            value = self.joints_to_deg(q[k])[j]
            raise JointLimitError(f"{what} {k}: joint {j + 1} = {value:.4f} is outside the limits "
                                  f"[{lo:g}, {hi:g}] of model '{self.name}'", index=int(k))

    def with_frames(self, base: ArrayLike | None = None, tool: ArrayLike | None = None
                    ) -> SerialModel:
        """Copy with another base and/or tool transform. Only the new frames are checked (the
        rest of the model is already valid): a solver or IK call strips frames often."""
        changes = {}
        for name, value in (("base", base), ("tool", tool)):
            if value is not None:
                frame = _frozen(value, (4, 4), f"model '{self.name}', {name}")
                _check_rigid(frame, f"model '{self.name}', {name}")
                changes[name] = frame
        return self.derived(**changes)
