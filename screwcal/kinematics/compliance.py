"""Joint compliance under gravity: the joints bend by c_j * tau_j(q).

A servo holds each motor where it is told; the gear and the link behind it give way under the
load a little, so the joint stands at q_j + c_j tau_j(q), with tau_j the gravity torque about
joint j of everything it carries (the arm's links as lumped masses, and the payload). Published
calibrations of ABB and FANUC arms model this with a few joint stiffnesses (k_j = 1 / c_j).

Units: masses kg, positions mm, torques N m, compliance rad/(N m) inside the numeric code; at the
interface compliance is given in deg per kN m (`COMPLIANCE_UNIT`), stiffness in kN m per deg.

The lumped masses are a built-in table per robot (`ROBOT_MASSES`): approximate link masses at
their centres, from the manufacturers' total masses; the identified c_j absorbs the scale, so
only the shape of tau_j(q) over the workspace matters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from screwcal.kinematics.se3 import Array, skew

GRAVITY_M_S2 = 9.80665
COMPLIANCE_UNIT = "deg/kNm"


@dataclass(frozen=True)
class LumpedMass:
    """A mass that moves with joint `link` (0-based), centred at `home_mm` when every joint is
    at 0 (robot base frame)."""

    link: int
    kg: float
    home_mm: tuple[float, float, float]


@dataclass(frozen=True)
class Payload:
    """What the flange carries: mass and centre of gravity in the flange (tool0) frame."""

    kg: float = 0.0
    cog_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)


# Approximate lumped masses (the arm's, without payload): upper arm, forearm, wrist.
ROBOT_MASSES: dict[str, tuple[LumpedMass, ...]] = {
    "irb1600": (LumpedMass(1, 40.0, (150.0, 0.0, 724.0)),  # upper arm: between joints 2 and 3
                LumpedMass(2, 35.0, (350.0, 0.0, 961.5)),  # forearm and joint-4 motor
                LumpedMass(4, 6.0, (750.0, 0.0, 961.5))),  # wrist
    "irb120": (LumpedMass(1, 4.0, (0.0, 0.0, 425.0)),
               LumpedMass(2, 3.5, (120.0, 0.0, 630.0)),
               LumpedMass(4, 0.7, (302.0, 0.0, 630.0))),
}

COMPLIANCE_JOINTS = {"none": (), "j23": (1, 2), "wrist": (1, 2, 3, 4, 5), "j23-free": (1, 2)}
# "j23-free": a coefficient per joint and per arm mass that loads it (the data correct the mass
# table's proportions); the payload loads a joint with its last arm mass's coefficient.
FREE_COMPLIANCE = ("j23-free",)


def gravity_torques_by_mass(axis_dirs: Array, axis_points: Array, partial: list[Array],
                            masses: tuple[LumpedMass, ...], up: Array) -> Array:
    """(N, n, M) the gravity torque (N m) about each joint's axis from each mass, at the
    configurations whose partial products of screws are `partial` (A_0..A_n, each (N, 3, 4),
    A_j placing joint j's axis); `up` is the robot base's +z in the world frame."""
    n = len(axis_dirs)
    N = partial[0].shape[0]
    tau = np.zeros((N, n, len(masses)))
    if not masses:
        return tau
    g = -GRAVITY_M_S2 * up / 1000.0  # N per kg, with mm lever arms -> N m
    # every joint that carries a mass: its axis (w) and a point on it (a), (J, N, 3), once
    carrying = max(m.link for m in masses) + 1
    frames = np.stack(partial[:carrying])
    w = np.einsum("jnab,jb->jna", frames[..., :3], axis_dirs[:carrying])
    a = np.einsum("jnab,jb->jna", frames[..., :3], axis_points[:carrying]) + frames[..., 3]
    for k, m in enumerate(masses):
        A = partial[m.link + 1]
        r = A[:, :, :3] @ np.asarray(m.home_mm) + A[:, :, 3]  # (N, 3) the mass now
        moment = skew(m.kg * g)  # (r - a) @ skew(F) = (r - a) x F, for row vectors
        J = m.link + 1  # the joints that carry it
        tau[:, :J, k] = np.einsum("jni,jni->nj", w[:J], (r - a[:J]) @ moment)
    return tau


def payload_mass(payload: Payload, home_flange: Array, n_joints: int) -> tuple[LumpedMass, ...]:
    """The payload as a lumped mass on the last link."""
    if payload.kg <= 0.0:
        return ()
    home = home_flange[:3, :3] @ np.asarray(payload.cog_mm, float) + home_flange[:3, 3]
    x, y, z = (float(v) for v in home)
    return (LumpedMass(n_joints - 1, payload.kg, (x, y, z)),)
