"""Statistical efficiency of the identification: a Monte Carlo of simulated calibrations against
the Cramer-Rao bound.

    python -m screwcal.studies.montecarlo [--samples 200] [--seed 0]

The thesis's set-up (3.2, Table 11): the IRB 1600 with Table 11's errors, 40 poses, full-pose
measurements with 0.013 mm noise, random joint error uniform +-0.05 deg, frames known (aligned).
Every sample draws new noise on the same 40 poses and identifies the thesis model by LM. The bound
is sqrt(diag((J^T S^-1 J)^-1)) from the same Jacobian and noise model at the truth: an efficient
estimator's RMS error reaches it.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from screwcal.calibration.identify import NoiseModel, identify
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.robots import irb1600
from screwcal.studies.markdown import markdown_table
from screwcal.studies.simulated_measurements import (
    JOINT_NOISE_DEG,
    NOISE_MM,
    orientation_noise_rad,
    simulate_measurements,
)

# Thesis Table 11, "Residuo LM": |estimated - imposed| of its one LM calibration.
THESIS_RESIDUAL_LM = {"J1rz": 0.028, "J1pz": 0.161, "J1px": 0.184, "J2ry": 0.006,
                      "J2pz": 0.102, "J3rz": 0.001, "J4rx": 0.063, "J4px": 0.097, "J5ry": 0.086,
                      "J6rx": 0.013}
IMPOSED = THESIS_TABLE11


@dataclass(frozen=True)
class EfficiencyRow:
    name: str
    unit: str
    rms_error: float
    bound: float
    thesis_residual: float

    @property
    def ratio(self) -> float:
        return self.rms_error / self.bound


def efficiency_study(samples: int = 200, seed: int = 0, poses: int = 40) -> list[EfficiencyRow]:
    """`samples` simulated calibrations of the Table 11 robot at `poses` random poses: each
    estimator's spread against the Cramer-Rao bound."""
    rng = np.random.default_rng(seed)
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    q = random_configurations(poses, rng)
    noise = NoiseModel(position_mm=NOISE_MM, joint_deg=JOINT_NOISE_DEG,
                       orientation_deg=float(np.degrees(orientation_noise_rad())))
    # The bound: the same identification on noise-free data gives the covariance at the truth.
    exact = simulate_measurements(truth, q, rng, noise_mm=0.0, joint_noise_deg=0.0)
    at_truth = identify(irb1600(), exact, kind="thesis", frames="known", noise=noise)
    errors = np.zeros((samples, len(at_truth.names)))
    for k in range(samples):
        data = simulate_measurements(truth, q, rng)
        r = identify(irb1600(), data, kind="thesis", frames="known")  # the defaults: the
        # noise levels found in each sample's data, as a user would run it
        errors[k] = r.values - np.array([IMPOSED[n] for n in r.names])
    rms = np.sqrt(np.mean(errors**2, axis=0))
    return [EfficiencyRow(n, p.unit, float(e), float(b), THESIS_RESIDUAL_LM[n])
            for n, p, e, b in zip(at_truth.names, at_truth.params, rms, at_truth.std_errors,
                                  strict=True)]


def format_table(rows: list[EfficiencyRow], samples: int) -> str:
    header = ("parameter", "unit", "RMS error", "bound", "ratio", "thesis Table 11 residual (LM)")
    cells = [(r.name, r.unit, f"{r.rms_error:.4f}", f"{r.bound:.4f}", f"{r.ratio:.2f}",
              f"{r.thesis_residual:.3f}") for r in rows]
    return "\n".join([f"Monte Carlo of {samples} calibrations (thesis model, 40 poses) vs "
                      "Cramer-Rao bound", *markdown_table(header, cells)])


def parser() -> argparse.ArgumentParser:
    """`python -m screwcal.studies.montecarlo`'s options."""
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=200,
                   help="simulated calibrations of the Table 11 robot (default 200)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    return p


def main() -> None:
    args = parser().parse_args()
    print(format_table(efficiency_study(args.samples, args.seed), args.samples))


if __name__ == "__main__":
    main()
