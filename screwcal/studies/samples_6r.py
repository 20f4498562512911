"""The 6R case of the simulated calibration studies (thesis 3.2): the IRB 1600 with Table 11's
errors, calibrated from simulated measurements of the thesis's pose sets and scored as the thesis
scores (`thesis_metrics`) and on held-out configurations. One `sample_*` per study: each draws
one sample's rows from a seed (`study.run_samples` draws many).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Literal

import numpy as np

from screwcal.calibration.design import d_optimal, log_det
from screwcal.calibration.identify import CalibrationResult, NoiseModel, identify
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.posesets import cube_set, quadrant_variants, random_set
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import Array, rotvec_from_rotation
from screwcal.studies.simulated_measurements import (
    JOINT_NOISE_DEG,
    NOISE_MM,
    orientation_noise_rad,
    simulate_measurements,
)
from screwcal.studies.thesis_metrics import Row, pose_errors, scored

NOISE = NoiseModel(NOISE_MM, float(np.degrees(orientation_noise_rad())), JOINT_NOISE_DEG)


# -- the 6R case ----------------------------------------------------------------------------------
def truth_6r() -> SerialModel:
    return apply_virtual_joints(irb1600(), THESIS_TABLE11)


def joints_only(nominal: SerialModel, fitted: SerialModel) -> SerialModel:
    """What a closed controller can correct: the nominal model with the identified zeros."""
    return replace(nominal, joint_zero=fitted.joint_zero)


def calibrate_6r(q: Array, rng: np.random.Generator) -> tuple[SerialModel, CalibrationResult]:
    """The true 6R and its thesis-model calibration from simulated measurements at q."""
    truth = truth_6r()
    data = simulate_measurements(truth, q, rng)
    return truth, identify(irb1600(), data, kind="thesis", frames="known", noise=NOISE)


@functools.cache
def validation_configurations() -> Array:
    """The 200 held-out configurations (200, 6) rad over the IRB 1600's workspace (seed 99),
    drawn on first use (not at import) and read-only: every sample scores on the same ones."""
    q = random_set(irb1600(), 200, seed=99)
    q.setflags(write=False)
    return q


def held_out_mm(model: SerialModel, truth: SerialModel) -> float:
    """Ours: the mean position error on 200 noise-free configurations over the whole workspace
    (what a user gets away from the calibration poses)."""
    return pose_errors(model, truth, validation_configurations())["norm_mm"]


def parameter_errors(names: Sequence[str], values: Array) -> Row:
    """|estimated - imposed| per parameter (Table 11's residuals; Figs. 24-25)."""
    return {f"err_{n}": abs(float(v) - THESIS_TABLE11[n])
            for n, v in zip(names, values, strict=True)}


def case_row(q: Array, rng: np.random.Generator, scored_at: Array | None = None,
             **labels: float | str) -> Row:
    """Calibrate the 6R on configurations q; score at the calibration poses (or `scored_at`)
    with the thesis's metric, and on the held-out poses."""
    truth, r = calibrate_6r(q, rng)
    at = q if scored_at is None else scored_at
    return {**labels, **scored(r.model, truth, at, rng), "val_mm": held_out_mm(r.model, truth),
            **parameter_errors(r.names, r.values)}


SETS = ("Klimchik", "C1", "C2")


def sample_sets(seed: int) -> list[Row]:
    """table8 / table9: the three pose sets, all offsets vs joint offsets only corrected."""
    rng = np.random.default_rng(seed)
    rows = []
    for name in SETS:
        q = cube_set(irb1600(), name, 40, seed=seed)
        truth, r = calibrate_6r(q, rng)
        before = scored(irb1600(), truth, q, rng, "before_")
        for corrected, model in (("all", r.model), ("joints", joints_only(irb1600(), r.model))):
            rows.append({"set": name, "corrected": corrected, **before,
                         **scored(model, truth, q, rng), "val_mm": held_out_mm(model, truth)})
    return rows


def sample_solvers(seed: int) -> list[Row]:
    """Tables 10-11: calibrated on each set by LM and by DE alone (the thesis's two), and by DE
    polished by LM (ours) on the Klimchik-style set; scored on all three sets."""
    rng = np.random.default_rng(seed)
    truth = truth_6r()
    sets = {n: cube_set(irb1600(), n, 40, seed=seed) for n in SETS}
    every = np.vstack(list(sets.values()))
    rows = []
    for name, q in sets.items():
        data = simulate_measurements(truth, q, rng)
        runs: list[tuple[str, Literal["lm", "de"], bool]] = [("LM", "lm", True),
                                                             ("DE", "de", False)]
        if name == "Klimchik":
            runs.append(("DE+LM", "de", True))
        for label, solver, polish in runs:
            start = time.perf_counter()
            r = identify(irb1600(), data, kind="thesis", frames="known", noise=NOISE,
                         solver=solver, weighting="eq2.4", seed=seed, de_polish=polish)
            row: Row = {"case": f"{label} / {name}", "seconds": time.perf_counter() - start,
                        **scored(r.model, truth, every, rng),
                        "val_mm": held_out_mm(r.model, truth)}
            row |= {f"est_{n}": float(v) for n, v in zip(r.names, r.values, strict=True)}
            row |= parameter_errors(r.names, r.values)
            rows.append(row)
    return rows


def residual_spread(truth: SerialModel, data: MeasurementSet) -> tuple[float, float]:
    """Standard deviations of the measured poses about the truth at the reported joints:
    position (mm, per axis) and rotation (deg, per axis). The random joint error sets both."""
    if data.rotations is None:
        raise ValueError("residual_spread needs full-pose measurements (rotations)")
    T = forward_kinematics(truth, data.q)
    dp = data.positions_mm - T[:, :3, 3]
    dr = rotvec_from_rotation(data.rotations @ np.swapaxes(T[:, :3, :3], 1, 2))
    return float(dp.std()), float(np.degrees(dr.std()))


def sample_weight(seed: int) -> list[Row]:
    rng = np.random.default_rng(seed)
    q = cube_set(irb1600(), "Klimchik", 40, seed=seed)
    truth = truth_6r()
    data = simulate_measurements(truth, q, rng)
    sd_mm, sd_deg = residual_spread(truth, data)
    rows = []
    for w in (0.01, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 100.0):
        r = identify(irb1600(), data, kind="thesis", frames="known", weighting="eq2.4",
                     weight_mm=w)
        rows.append({"W_mm": w, **scored(r.model, truth, q, rng),
                     "val_mm": held_out_mm(r.model, truth), "resid_sd_mm": sd_mm,
                     "resid_sd_deg": sd_deg})
    return rows


KLIMCHIK_4 = 4  # Klimchik's configurations that the thesis replicates (3.2.1)


def sample_replications(seed: int) -> list[Row]:
    """Figs. 22-25: Klimchik's 4 configurations replicated (10 replications: 40 measurements),
    scored at the calibration configurations; every parameter's error."""
    rng = np.random.default_rng(seed)
    base_set = cube_set(irb1600(), "Klimchik", KLIMCHIK_4, seed=seed)
    return [case_row(np.repeat(base_set, reps, axis=0), rng, replications=reps,
                     measurements=reps * KLIMCHIK_4) for reps in (1, 2, 5, 10, 20, 30, 40)]


def sample_configurations(seed: int) -> list[Row]:
    rng = np.random.default_rng(seed)
    return [case_row(cube_set(irb1600(), "Klimchik", n, seed=seed), rng, configurations=n)
            for n in (40, 60, 80, 120, 160)]


def sample_quadrants(seed: int) -> list[Row]:
    rng = np.random.default_rng(seed)
    base_set = cube_set(irb1600(), "Klimchik", 40, seed=seed)
    return [case_row(quadrant_variants(base_set, n), rng, quadrants=n) for n in (1, 2, 4)]


def sample_design(seed: int) -> list[Row]:
    """The D-optimal 40 of a pool in the same cube vs the Klimchik-style 40."""
    rng = np.random.default_rng(seed)
    klimchik = cube_set(irb1600(), "Klimchik", 40, seed=seed)
    pool = cube_set(irb1600(), "Klimchik", 600, seed=seed + 1, spread=False)
    designed = d_optimal(irb1600(), pool, 40).q_rad
    return [case_row(q, rng, set=name, log_det=log_det(irb1600(), q))
            for name, q in (("Klimchik-style", klimchik), ("D-optimal", designed))]
