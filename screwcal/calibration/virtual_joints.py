"""The thesis's virtual joints (3.1-3.2): geometric errors imposed on, or read off, a 6R model.

A name is J<i>r<axis> for a joint offset (revolute virtual joint R') of joint i, or J<i>p<axis>
for a link offset (prismatic virtual joint P') after joint i along the home-frame axis. The
thesis writes the joint-3 offset as J3rz although joint 3 turns about y in the usual frame; here
every J<i>r* is the offset about joint i's own axis (the thesis's meaning), so J3rz and J3ry name
the same thing.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import exp_twist, transform_from_rotation_translation

# Table 11: the errors imposed on the simulated IRB 1600 (degrees for r, mm for p).
THESIS_TABLE11: dict[str, float] = {
    "J1rz": 2.0, "J1pz": 0.3, "J1px": 0.3, "J2ry": 1.1, "J2pz": 0.3,
    "J3rz": 3.1, "J4rx": -2.0, "J4px": 0.3, "J5ry": 3.7, "J6rx": -4.6,
}

_NAME = re.compile(r"^J([1-9])([rp])([xyz])$")


def parse_name(name: str) -> tuple[int, str, int]:
    """(joint index 0-based, 'r' or 'p', axis index) of a virtual-joint name."""
    m = _NAME.match(name)
    if not m:
        raise ModelError(f"'{name}' is not a virtual-joint name like J2ry or J1pz")
    return int(m.group(1)) - 1, m.group(2), "xyz".index(m.group(3))


def apply_virtual_joints(model: SerialModel, errors: Mapping[str, float]) -> SerialModel:
    """A copy of `model` with the virtual-joint errors imposed (deg for r, mm for p).

    A joint offset adds to the joint zero; a link offset after joint i translates everything
    downstream of joint i (the next axes and the home flange) along the base-frame axis at home.
    """
    zero = model.joint_zero.copy()
    points = model.axis_points_mm.copy()
    shift_flange = np.zeros(3)
    for name, value in errors.items():
        i, kind, axis = parse_name(name)
        if i >= model.n_joints:
            raise ModelError(f"{name}: model '{model.name}' has {model.n_joints} joints")
        if kind == "r":
            zero[i] += np.radians(value)
        else:
            step = np.zeros(3)
            step[axis] = value
            points[i + 1:] += step
            shift_flange += step
    flange = transform_from_rotation_translation(model.home_flange[:3, :3],
                                                 model.home_flange[:3, 3] + shift_flange)
    return replace(model, joint_zero=zero, axis_points_mm=points, home_flange=flange)


def perturbed_axes(model: SerialModel, rng: np.random.Generator, *, tilt_deg: float = 0.05,
                   shift_mm: float = 0.2, zero_deg: float | None = None,
                   flange: bool = True) -> SerialModel:
    """`model` with the small errors no virtual joint describes, drawn from `rng`: every axis
    tilted by ~`tilt_deg` and shifted by ~`shift_mm` (1 sigma, each direction and point
    component), with `zero_deg` every joint's zero offset by ~that much, and with `flange` the
    home flange moved by ~0.06 deg and ~0.2 mm; drawn in that order. The true robots of the
    simulated studies, of the emulators and of the tests are drawn so."""
    dirs = model.axis_dirs + rng.normal(0, np.radians(tilt_deg), model.axis_dirs.shape)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    points = model.axis_points_mm + rng.normal(0, shift_mm, model.axis_points_mm.shape)
    zero = model.joint_zero
    if zero_deg is not None:
        zero = zero + rng.normal(0, np.radians(zero_deg), model.n_joints)
    home = model.home_flange
    if flange:
        home = exp_twist(np.r_[rng.normal(0, 1e-3, 3), rng.normal(0, 0.2, 3)]) @ home
    return replace(model, axis_dirs=dirs, axis_points_mm=points, joint_zero=zero,
                   home_flange=home)
