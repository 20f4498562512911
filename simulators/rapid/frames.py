"""Tools and work objects as the controller uses them (RAPID reference, tooldata and wobjdata):
where the flange (tool0) must be for a robtarget, and which robtarget the flange's pose is.

A robtarget is the TCP's pose in the work object's object frame. With a tool the robot holds
(tooldata.robhold TRUE) and a stationary work object (wobjdata.robhold FALSE):

    base_T_flange @ tframe = uframe @ oframe @ target

With a stationary tool (tooldata.robhold FALSE: its tframe is in the base frame) the work object
is held by the robot (wobjdata.robhold TRUE: its uframe is on the flange):

    base_T_flange @ uframe @ oframe @ target = tframe

Any other pairing is the controller's error (a held tool with a held work object, or neither).
The world frame is the base frame (no `wobjdata.ufmec` mechanical unit, no base frame offset:
a work object coordinated with an external axis is refused).

Orientation: RAPID requires q1^2 + ... + q4^2 = 1. The controller takes an orient whose norm
differs from 1 by at most 0.1 and normalises it (NOrient's limits: beyond 1e-5 it is
"unnormalised", beyond 0.1 "unusable"); an unusable orient is ERR_ARGVALERR.
"""

from __future__ import annotations

import math

import numpy as np

from screwcal.kinematics.pose import rotation_from_quaternion_wxyz
from simulators.rapid.errors import RapidError
from simulators.rapid.values import Record

USABLE_NORM = 0.1  # |1 - |q|| beyond which an orient is unusable (NOrient)
NORMALISED_NORM = 1e-5  # |1 - |q|| within which an orient is normalised (NOrient)


def unit_wxyz(q: tuple[float, float, float, float]) -> np.ndarray:
    """An orient's four numbers normalised, as the controller does; an unusable one (its norm
    more than 0.1 from 1) is ERR_ARGVALERR."""
    wxyz = np.array(q, dtype=float)
    n = float(math.sqrt(float(wxyz @ wxyz)))
    if abs(n - 1) > USABLE_NORM:
        raise RapidError("ERR_ARGVALERR", f"orient not normalised (|q| = {n:.6f}, more than "
                         f"{USABLE_NORM:g} from 1: unusable)")
    unit: np.ndarray = wxyz / n
    return unit


def rotation_of(orient: Record) -> np.ndarray:
    """The rotation matrix of an orient record."""
    f = orient.f
    R: np.ndarray = rotation_from_quaternion_wxyz(unit_wxyz((f["q1"], f["q2"], f["q3"],
                                                             f["q4"])))
    return R


def matrix_of_pose(trans: Record, rot: Record) -> np.ndarray:
    """The 4x4 transform of a (pos, orient) pair (mm)."""
    T = np.eye(4)
    T[:3, :3] = rotation_of(rot)
    t = trans.f
    T[:3, 3] = (t["x"], t["y"], t["z"])
    return T


def pose_matrix(pose: Record) -> np.ndarray:
    """The 4x4 transform of a pose record (tframe, uframe, oframe)."""
    return matrix_of_pose(pose.f["trans"], pose.f["rot"])


def _identity(pose: Record) -> bool:
    t, r = pose.f["trans"].f, pose.f["rot"].f
    return t["x"] == 0.0 and t["y"] == 0.0 and t["z"] == 0.0 and r["q1"] == 1.0 and \
        r["q2"] == 0.0 and r["q3"] == 0.0 and r["q4"] == 0.0


def inverse(T: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


class Frames:
    """A tool and a work object, checked and turned into transforms once."""

    def __init__(self, tool: Record | None, wobj: Record | None):
        self.tool_held = True if tool is None else bool(tool.f["robhold"])
        self.wobj_held = False if wobj is None else bool(wobj.f["robhold"])
        if self.tool_held == self.wobj_held:
            raise RapidError("ERR_ARGVALERR", "a tool held by the robot needs a stationary work "
                             "object, a stationary tool a work object the robot holds "
                             f"(tooldata.robhold {_bool(self.tool_held)}, wobjdata.robhold "
                             f"{_bool(self.wobj_held)})")
        if wobj is not None and wobj.f["ufmec"] != "" and not wobj.f["ufprog"]:
            raise RapidError("ERR_ARGVALERR", f"a work object moved by mechanical unit "
                             f"{wobj.f['ufmec']!r} (coordinated motion) is not supported")
        self.plain = (tool is None or _identity(tool.f["tframe"])) and (
            wobj is None or (_identity(wobj.f["uframe"]) and _identity(wobj.f["oframe"])))
        self.tframe = np.eye(4) if tool is None else pose_matrix(tool.f["tframe"])
        self.wframe = np.eye(4) if wobj is None else \
            pose_matrix(wobj.f["uframe"]) @ pose_matrix(wobj.f["oframe"])

    def flange_of(self, target: np.ndarray) -> np.ndarray:
        """base_T_flange for a robtarget's transform (its pose in the object frame)."""
        if self.plain:
            return target
        if self.tool_held:
            return self.wframe @ target @ inverse(self.tframe)
        return self.tframe @ inverse(self.wframe @ target)

    def target_of(self, flange: np.ndarray) -> np.ndarray:
        """The robtarget's transform (the TCP in the object frame) of a flange pose."""
        if self.plain:
            return flange
        if self.tool_held:
            return inverse(self.wframe) @ flange @ self.tframe
        return inverse(flange @ self.wframe) @ self.tframe


def _bool(b: bool) -> str:
    return "TRUE" if b else "FALSE"
