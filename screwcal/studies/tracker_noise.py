"""Identification with a laser tracker's noise: each point weighted by its own covariance against
one isotropic level, a Monte Carlo against the Cramer-Rao bound.

    python -m screwcal.studies.tracker_noise [--samples 100] [--seed 0] [--poses 40]

The set-up: the IRB 1600 with Table 11's errors, a tracker 3 m in front of it (the measuring
frame: the tracker's head at its origin), one SMR 30, 20, 40 mm off tool0, positions only, at
`poses` configurations the tracker sees (`line_of_sight`). The tracker's noise (screwcal/
instrument.py): 5 um along the beam, half of 15 um + 6 um/m across it, per direction; the joint
readings exact, so the bound is the measuring noise's. Every sample draws new noise on the same
poses and identifies the thesis model (frames known) three ways: weighted by each point's
reported covariance (the data's `position_cov_mm2`); with one isotropic level (the covariance left
out); and by the reported covariance plus the excess a first fit's residuals show along and across
the beam (`beam_weighting`, the route for real robots). The bound is sqrt(diag((J^T S^-1 J)^-1))
of the weighted problem at the truth; every estimator is scored on it and on the position error
at 200 held-out poses the tracker sees. The noise per component (along and across the beam) is
the beam route's first fit's.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

import numpy as np

from screwcal.calibration.beam_weighting import identify_beam_weighted
from screwcal.calibration.identify import NoiseModel, identify
from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM, visible_configurations
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.instrument import TRACKER_STAND_MM, tracker_covariance_mm2, tracker_noise_mm
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import Array
from screwcal.studies.markdown import markdown_table

EXACT_JOINTS_DEG = 1e-6  # the joint level, fixed: the readings are exact in this study


def tracker_models() -> tuple[SerialModel, SerialModel]:
    """The nominal and the true robot, both in the tracker's frame with the SMR as their tool."""
    base = np.eye(4)
    base[:3, 3] = -np.asarray(TRACKER_STAND_MM)
    tool = np.eye(4)
    tool[:3, 3] = DEFAULT_SMR_MM
    nominal = irb1600().with_frames(base, tool)
    return nominal, apply_virtual_joints(irb1600(), THESIS_TABLE11).with_frames(base, tool)


def tracker_measurements(truth: SerialModel, q: Array, rng: np.random.Generator | None,
                         weighted: bool = True) -> MeasurementSet:
    """The SMR's positions at q (N, n) rad with the tracker's noise (none without `rng`), each
    with its covariance when `weighted`."""
    p = forward_kinematics(truth, q)[:, :3, 3]
    C = tracker_covariance_mm2(p)
    if rng is not None:
        p = p + np.einsum("nij,nj->ni", np.linalg.cholesky(C), rng.normal(size=p.shape))
    return MeasurementSet(q.copy(), p, None, position_cov_mm2=C if weighted else None)


@dataclass(frozen=True)
class TrackerNoiseStudy:
    names: tuple[str, ...]
    units: tuple[str, ...]
    bound: Array  # (p,) the Cramer-Rao bound of the weighted problem
    rms_weighted: Array  # (p,) RMS parameter error over the samples
    rms_isotropic: Array
    rms_beam: Array
    held_out_weighted_mm: float  # RMS position error at held-out poses, over the samples
    held_out_isotropic_mm: float
    held_out_beam_mm: float
    radial_mm: float  # the noise along the beam, mean of the samples' estimates
    lateral_mm: float  # ... across it, per direction
    radial_true_mm: float
    lateral_true_mm: float  # at the poses' mean range
    samples: int


def tracker_noise_study(samples: int = 100, seed: int = 0, poses: int = 40
                        ) -> TrackerNoiseStudy:
    rng = np.random.default_rng(seed)
    nominal, truth = tracker_models()
    station = np.asarray(TRACKER_STAND_MM, dtype=float)
    q = visible_configurations(irb1600(), poses, station, rng)
    q_test = visible_configurations(irb1600(), 200, station, rng)
    fixed = NoiseModel(joint_deg=EXACT_JOINTS_DEG)
    exact = tracker_measurements(truth, q, None)
    cov = tracker_covariance_mm2(exact.positions_mm)
    scale = float(np.sqrt(np.trace(cov, axis1=1, axis2=2).mean() / 3.0))
    at_truth = identify(nominal, exact, kind="thesis", frames="known", plausible=None,
                        outliers="keep", noise=NoiseModel(position_mm=scale,
                                                          joint_deg=EXACT_JOINTS_DEG))
    imposed = np.array([THESIS_TABLE11[n] for n in at_truth.names])
    p_true = forward_kinematics(truth, q_test)[:, :3, 3]
    routes = ("reported", "isotropic", "beam")
    errors: dict[str, list[Array]] = {name: [] for name in routes}
    held: dict[str, list[float]] = {name: [] for name in routes}
    levels = []
    options: dict[str, Any] = {"kind": "thesis", "frames": "known", "plausible": None,
                               "outliers": "keep", "noise": fixed}
    for _ in range(samples):
        noisy = tracker_measurements(truth, q, rng)
        beam = identify_beam_weighted(nominal, noisy, **options)
        levels.append((beam.levels.radial_mm, beam.levels.lateral_mm))
        fits = {"reported": identify(nominal, noisy, **options),
                "isotropic": identify(nominal, MeasurementSet(noisy.q, noisy.positions_mm),
                                      **options),
                "beam": beam.result}
        for name, r in fits.items():
            errors[name].append(r.values - imposed)
            d = forward_kinematics(r.model, q_test)[:, :3, 3] - p_true
            held[name].append(float(np.mean(np.sum(d**2, axis=1))))

    def rms(e: list[Array]) -> Array:
        return np.asarray(np.sqrt(np.mean(np.square(e), axis=0)), dtype=float)

    radial_true, lateral_true = tracker_noise_mm(float(np.linalg.norm(
        exact.positions_mm, axis=1).mean()))
    return TrackerNoiseStudy(
        at_truth.names, tuple(p.unit for p in at_truth.params), at_truth.std_errors,
        rms(errors["reported"]), rms(errors["isotropic"]), rms(errors["beam"]),
        float(np.sqrt(np.mean(held["reported"]))), float(np.sqrt(np.mean(held["isotropic"]))),
        float(np.sqrt(np.mean(held["beam"]))), float(np.mean([v[0] for v in levels])),
        float(np.mean([v[1] for v in levels])), radial_true, lateral_true, samples)


def format_table(s: TrackerNoiseStudy) -> str:
    header = ("parameter", "unit", "bound", "RMS reported", "ratio", "RMS isotropic", "ratio",
              "RMS beam", "ratio")
    cells = [(n, u, f"{b:.5f}", f"{w:.5f}", f"{w / b:.2f}", f"{i:.5f}", f"{i / b:.2f}",
              f"{m:.5f}", f"{m / b:.2f}")
             for n, u, b, w, i, m in zip(s.names, s.units, s.bound, s.rms_weighted,
                                         s.rms_isotropic, s.rms_beam, strict=True)]
    ratio_w = s.rms_weighted / s.bound
    ratio_i = s.rms_isotropic / s.bound
    ratio_b = s.rms_beam / s.bound
    return "\n".join([
        f"Monte Carlo of {s.samples} calibrations with a laser tracker's noise (thesis model, "
        "positions of one SMR) vs Cramer-Rao bound", *markdown_table(header, cells), "",
        f"RMS / bound, mean over parameters: reported covariance {ratio_w.mean():.2f} "
        f"({ratio_w.min():.2f}-{ratio_w.max():.2f}), isotropic {ratio_i.mean():.2f} "
        f"({ratio_i.min():.2f}-{ratio_i.max():.2f}), beam {ratio_b.mean():.2f} "
        f"({ratio_b.min():.2f}-{ratio_b.max():.2f})",
        f"held-out position error (200 poses): reported covariance "
        f"{s.held_out_weighted_mm * 1000:.2f} um, isotropic "
        f"{s.held_out_isotropic_mm * 1000:.2f} um, beam {s.held_out_beam_mm * 1000:.2f} um",
        f"noise estimated: along the beam {s.radial_mm * 1000:.2f} um (true "
        f"{s.radial_true_mm * 1000:.2f}), across {s.lateral_mm * 1000:.2f} um per direction "
        f"(true {s.lateral_true_mm * 1000:.2f} at the mean range)"])


def parser() -> argparse.ArgumentParser:
    """`python -m screwcal.studies.tracker_noise`'s options."""
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=100, help="simulated calibrations (100)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--poses", type=int, default=40, help="calibration poses (40)")
    return p


def main() -> None:
    args = parser().parse_args()
    print(format_table(tracker_noise_study(args.samples, args.seed, args.poses)))


if __name__ == "__main__":
    main()
