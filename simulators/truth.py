"""The emulators' true robot: the nominal IRB 1600 with imposed errors (the thesis's Table 11,
a JSON of virtual-joint errors, a whole model file, or random errors from a seed), what it has
beyond its geometry (`simulators.realism`: compliance under its own masses, payload, backlash,
read-back lag, drift, repeatability), and the world it lives in (the measuring arm's frame)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from screwcal.calibration.virtual_joints import (
    THESIS_TABLE11,
    apply_virtual_joints,
    perturbed_axes,
)
from screwcal.errors import ModelError
from screwcal.instrument import STAND_MM
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import parse_model
from screwcal.kinematics.robots import irb1600
from simulators.realism import IDEAL, Realism, with_realism
from simulators.world import World

# Where the measuring arm stands by default: (500, 0, 600) mm in the robot frame.
DEFAULT_ARM_POSITION_MM = STAND_MM


def arm_base(arm_position_mm: tuple[float, float, float]) -> np.ndarray:
    """The arm frame <- robot base transform for an arm standing at this robot-frame point."""
    T = np.eye(4)
    T[:3, 3] = -np.asarray(arm_position_mm, dtype=float)
    return T


def random_errors(nominal: SerialModel, seed: int) -> SerialModel:
    """Thesis-like errors drawn from a seed: joint offsets within +-3 deg, link offsets within
    +-0.5 mm, axes tilted by ~0.05 deg and shifted by ~0.2 mm."""
    rng = np.random.default_rng(seed)
    names = ["J1rz", "J2ry", "J3rz", "J4rx", "J5ry", "J6rx"]
    errors = {n: float(rng.uniform(-3, 3)) for n in names}
    errors |= {n: float(rng.uniform(-0.5, 0.5)) for n in ("J1pz", "J1px", "J2pz", "J4px")}
    return perturbed_axes(apply_virtual_joints(nominal, errors), rng)


def true_robot(errors_file: str | None, seed: int | None) -> SerialModel:
    nominal = irb1600()
    if errors_file is None:
        return random_errors(nominal, seed) if seed is not None else \
            apply_virtual_joints(nominal, THESIS_TABLE11)
    try:
        doc = json.loads(Path(errors_file).read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:  # JSONDecodeError, UnicodeDecodeError
        raise ModelError(f"{errors_file}: cannot read the errors file ({err})") from None
    if isinstance(doc, dict) and ("representation" in doc or "model" in doc):
        return parse_model(doc, errors_file)  # a whole true model
    if not isinstance(doc, dict) or not all(isinstance(v, int | float) for v in doc.values()):
        raise ModelError(f"{errors_file}: expected {{\"J1rz\": 2.0, ...}} or a model file")
    return apply_virtual_joints(nominal, doc)


DEFAULT_REALISM_SEED = 2018  # the realism's draws when neither --realism-seed nor --seed is given


def make_world(errors_file: str | None, seed: int | None,
               arm_position_mm: tuple[float, float, float] = DEFAULT_ARM_POSITION_MM,
               realism: Realism = IDEAL, realism_seed: int | None = None) -> World:
    """The emulators' world. The realism's draws (the robot's own masses, then its stops) come
    from `realism_seed`, by default `seed` (or 2018 without one): a seed gives one robot."""
    if realism_seed is None:
        realism_seed = DEFAULT_REALISM_SEED if seed is None else seed
    nominal = irb1600()
    truth = true_robot(errors_file, seed).with_frames(base=arm_base(arm_position_mm))
    if not truth.masses:  # a model file without a gravity section: the nominal table
        truth = replace(truth, masses=nominal.masses)
    truth = with_realism(truth, realism, np.random.default_rng([realism_seed, 1]))
    return World(nominal=nominal, truth=truth, realism=realism, realism_seed=realism_seed)
