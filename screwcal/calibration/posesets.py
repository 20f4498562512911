"""Calibration pose sets (thesis 2.2.4, 3.1, 3.2): the planar sets of Table 3 and, for the 6R,
a Klimchik-style set, the comparison sets C1 and C2, random sets and their 1-, 2- and 4-quadrant
variants.

The thesis adapts Klimchik's configurations to the measuring arm's reach: 40 configurations in one
quadrant of the workspace, the TCP inside a 600 x 600 x 600 mm cube (3.2.3); C1 and C2 are other
cubic regions. Klimchik's exact adapted configurations are not printed, so here the
"Klimchik-style" set follows his rule for anthropomorphic arms: configurations spread as widely as
the region allows in the joints that carry the errors (a Latin hypercube over joints 2-6, joint 1
covering the quadrant), keeping only those whose TCP lies in the cube and away from the wrist
singularity. C1 and C2 are plain random draws in their own cubes. Every set is drawn from a seed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from screwcal.errors import InputError, ScrewcalError
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

# Table 3 (planar 3R, degrees): each set of four configurations.
PLANAR_SETS_DEG = {
    "Klimchik": [(0, -60, 60), (0, -120, -60), (0, 120, -120), (0, 60, 120)],
    "C1": [(-90, 90, -90), (-90, 90, 90), (-45, 90, -45), (45, -90, -90)],
    "C2": [(-60, 30, -60), (0, 60, 30), (-45, 45, 45), (-45, -135, 45)],
}

# A working region well inside the IRB 1600's limits (deg), like the thesis's one-quadrant sets:
# the default for simulated calibrations and the fallback calibration list.
WORKING_REGION_DEG = np.array([[-60, 60], [-30, 70], [-70, 30], [-150, 150], [-100, 100],
                               [-170, 170]], dtype=float)

# 600 mm cubes in the IRB 1600's workspace (robot base frame, centres in mm): the quadrant of
# the measuring arm in front of the robot, and two other regions for comparison.
CUBE_EDGE_MM = 600.0
CUBES_MM = {"Klimchik": (850.0, -350.0, 700.0), "C1": (850.0, 350.0, 400.0),
            "C2": (550.0, -450.0, 1000.0)}
_WRIST_MARGIN_DEG = 10.0


def _in_cube(model: SerialModel, q_rad: Array, centre: ArrayLike, edge: float
             ) -> NDArray[np.bool_]:
    p = flange_kinematics(model, q_rad)[:, :3, 3]
    return np.all(np.abs(p - np.asarray(centre)) <= edge / 2, axis=1)


def _latin_hypercube(n: int, lo: Array, hi: Array, rng: np.random.Generator) -> Array:
    d = len(lo)
    cut = (np.argsort(rng.random((n, d)), axis=0) + rng.random((n, d))) / n
    return lo + cut * (hi - lo)


def cube_set(model: SerialModel, name: str, n: int = 40, seed: int = 0,
             spread: bool | None = None) -> Array:
    """n configurations (rad) whose TCP lies in the named 600 mm cube. `spread` (default: for
    the Klimchik-style set) draws them as Latin hypercubes, otherwise uniformly."""
    if name not in CUBES_MM:
        raise InputError(f"unknown pose set '{name}'; choose {', '.join(CUBES_MM)}")
    spread = name == "Klimchik" if spread is None else spread
    rng = np.random.default_rng(seed)
    lo, hi = model.limits[:, 0].copy(), model.limits[:, 1].copy()
    centre = np.asarray(CUBES_MM[name])
    heading = np.arctan2(centre[1], centre[0])
    lo[0], hi[0] = heading - np.radians(45), heading + np.radians(45)  # the quadrant
    lo[3:], hi[3:] = np.maximum(lo[3:], -np.pi), np.minimum(hi[3:], np.pi)
    found: list[Array] = []
    for _ in range(400):
        batch = _latin_hypercube(512, lo, hi, rng) if spread else rng.uniform(lo, hi, (512, 6))
        keep = _in_cube(model, batch, centre, CUBE_EDGE_MM) & \
            (np.abs(np.degrees(batch[:, 4])) > _WRIST_MARGIN_DEG)
        found.extend(batch[keep])
        if len(found) >= 8 * n:
            break
    if len(found) < n:
        raise ScrewcalError(f"only {len(found)} configurations of model '{model.name}' reach "
                            f"the {name} cube")
    pool = np.array(found)
    if not spread:
        return pool[rng.choice(len(pool), n, replace=False)]
    # Spread: greedily keep the configurations farthest apart in joint space.
    chosen = [int(rng.integers(len(pool)))]
    dist = np.linalg.norm(pool - pool[chosen[0]], axis=1)
    for _ in range(n - 1):
        k = int(np.argmax(dist))
        chosen.append(k)
        dist = np.minimum(dist, np.linalg.norm(pool - pool[k], axis=1))
    return pool[chosen]


def random_configurations(n: int, rng: np.random.Generator) -> Array:
    """n configurations (rad) uniform in the working region."""
    return np.radians(rng.uniform(WORKING_REGION_DEG[:, 0], WORKING_REGION_DEG[:, 1], (n, 6)))


def random_set(model: SerialModel, n: int, seed: int = 0, margin_deg: float = 5.0) -> Array:
    """n configurations uniform inside the limits less a margin, away from the wrist
    singularity (rad)."""
    rng = np.random.default_rng(seed)
    lo = model.limits[:, 0] + np.radians(margin_deg)
    hi = model.limits[:, 1] - np.radians(margin_deg)
    out: list[Array] = []
    while len(out) < n:
        q = rng.uniform(lo, hi, (2 * n, model.n_joints))
        out.extend(q[np.abs(np.degrees(q[:, 4])) > _WRIST_MARGIN_DEG])
    return np.array(out[:n])


def quadrant_variants(q_rad: ArrayLike, quadrants: int) -> Array:
    """The thesis's 2- and 4-quadrant sets (3.2.3): the same configurations with joint 1 turned
    by 90, 180, 270 deg, the set split evenly among the quadrants (same count)."""
    q = np.array(q_rad, dtype=float)
    if quadrants not in (1, 2, 4):
        raise InputError(f"quadrants are 1, 2 or 4, got {quadrants}")
    turns = {1: [0], 2: [0, 90], 4: [0, 90, 180, 270]}[quadrants]
    for k in range(len(q)):
        q[k, 0] += np.radians(turns[k % len(turns)])
    q[:, 0] = (q[:, 0] + np.pi) % (2 * np.pi) - np.pi
    return q
