"""`screwcal demo --instrument tracker`: the calibration procedure with a laser tracker (one SMR on
the flange, positions only) on emulated hardware: the IRC5 emulator with its emulated tracker (a
process, `emulator irc5 --tracker-port`), driven over the wire protocol and emScon TPI.

The tracker stands where the demo puts it (`--stand-mm`, robot frame, facing the robot) and the
poses are planned so that its beam sees the SMR (`calibration.line_of_sight`, on the nominal
robot with margins): the calibration poses are random configurations of the working region that
pass, the ISO 9283 cube's poses face the tracker (the flange toward it). A pose whose beam is still
broken on the true robot (the tracker finds no reflector, even after searching) is skipped and
counted, never measured; a lost, uninitialised or warming tracker is reconnected, initialised or
waited for, and the pose measured once.

The procedure: ISO 9283 AP before; calibration; compensation of the performance list (each
joint also commanded half the lost motion the calibration found beyond its target, on the side it
comes from in the list: `lag.commands_for_lost_motion`); AP after; the same with the
geometric-only model (no compliance, no read-back lag, no lost motion) on the same data, as the
arm's demo prints it. Positions in the tracker's frame are taken into the robot's base frame
with the base frame the calibration identified.
"""

from __future__ import annotations

import asyncio
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from protocol.client import ControllerClient
from screwcal.calibration.beam_weighting import BeamLevels, identify_beam_weighted
from screwcal.calibration.correction import compensate
from screwcal.calibration.flange import frame_from_holes
from screwcal.calibration.identify import CalibrationResult, identify
from screwcal.calibration.lag import commands_for_lost_motion
from screwcal.calibration.line_of_sight import (
    DEFAULT_SMR_MM,
    THREE_SMRS_MM,
    visible,
    visible_configurations,
)
from screwcal.calibration.measurements import MeasurementSet
from screwcal.instrument import TRACKER_STAND_MM
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import Array, invert_transform, transform_points
from screwcal.performance.iso9283 import pose_metrics
from screwcal.performance.testcube import PosePlan, find_test_cube, performance_pose_list
from service.demo import NOISE_SEED, TrackerStand, emulators
from service.errors import ServiceError
from service.plans import FACING_TRACKER_DEG
from service.tracker_cell import Cell, Point, TrackerRun

CUBE_EDGE_MM = 300.0
LOCATE_POSES = 6  # calibration poses whose first SMR locates the tracker (three SMRs)
SMRS: dict[int, tuple[Point, ...]] = {1: (DEFAULT_SMR_MM,), 3: THREE_SMRS_MM}
SMR_WORDS = {1: "one SMR (positions)", 3: "three SMRs (full pose)"}


def calibration_poses(model: SerialModel, n: int, stand_mm: Sequence[float], seed: int,
                      smrs_mm: tuple[Point, ...] = (DEFAULT_SMR_MM,)) -> Array:
    """n configurations (deg) of the working region whose SMRs the tracker at `stand_mm`
    (robot frame) sees on the nominal robot, with margins."""
    try:
        q = visible_configurations(model, n, np.asarray(stand_mm, dtype=float),
                                   np.random.default_rng(seed), smrs_mm)
    except ValueError as err:
        raise ServiceError(str(err)) from None
    return np.asarray(np.round(np.degrees(q), 4), dtype=float)


def performance_poses(model: SerialModel, cycles: int, stand_mm: Sequence[float],
                      smrs_mm: tuple[Point, ...] = (DEFAULT_SMR_MM,)) -> list[PosePlan]:
    """The ISO 9283 cube's list (approach and target of P1-P5 per cycle), the flange facing
    the tracker; refused when the tracker would not see a target."""
    cube = find_test_cube(model, CUBE_EDGE_MM, orientation_deg=FACING_TRACKER_DEG)
    plans = performance_pose_list(model, cube, cycles)
    q = np.radians([p.q_deg for p in plans[:10]])  # one cycle: every pose of the list
    if not all(visible(model, q, np.asarray(stand_mm, dtype=float), smr_mm=smr).all()
               for smr in smrs_mm):
        raise ServiceError(f"the tracker at {list(stand_mm)} mm does not see every ISO 9283 "
                           "pose: stand it in front of the cube")
    return plans


def measurement_set(run: TrackerRun, weighted: bool = True) -> MeasurementSet:
    """The measured poses (the skipped ones left out) as the identification reads them: each
    point with the covariance the tracker reported (`weighted`), else one isotropic level."""
    keep = [k for k, p in enumerate(run.points) if p is not None]
    points = [p for p in run.points if p is not None]
    rotations = None
    others = [run.others[k] or [] for k in keep]
    if others and others[0]:  # three SMRs: the frame of their triangle (full pose)
        triangles = np.array([[p.xyz_mm, *(o.xyz_mm for o in rest)]
                              for p, rest in zip(points, others, strict=True)])
        rotations = frame_from_holes(triangles)[:, :3, :3]
    return MeasurementSet(np.radians([run.joints_deg[k] for k in keep]),
                          np.array([p.xyz_mm for p in points]), rotations,
                          tuple(str(k) for k in keep),
                          q_previous=np.radians([run.previous_deg[k] for k in keep]),
                          position_cov_mm2=np.array([p.covariance for p in points])
                          if weighted else None)


def ap_mean_mm(run: TrackerRun, plans: Sequence[PosePlan], nominal: SerialModel,
               result: CalibrationResult) -> float:
    """ISO 9283 AP of the SMR, mean over P1-P5: attained positions in the robot base frame
    (the identified base), commanded ones the nominal tool0 poses carrying the identified SMR."""
    targets = [p for p in plans if p.role == "target"]
    to_base = invert_transform(result.model.base)
    smr = result.model.tool[:3, 3]
    aps = []
    for label in sorted({p.point for p in targets}):
        rows = [(t, m) for t, m in zip(targets, run.points, strict=True)
                if t.point == label and m is not None]
        q_cmd = np.radians([rows[0][0].q_deg])
        p_cmd = transform_points(flange_kinematics(nominal, q_cmd)[0], smr[None])[0]
        attained = transform_points(to_base, np.array([m.xyz_mm for _, m in rows]))
        aps.append(pose_metrics(p_cmd, attained).ap_mm)
    return float(np.mean(aps))


def compensated(plans: Sequence[PosePlan], calibrated: SerialModel, nominal: SerialModel,
                lost_motion: Array | None = None) -> list[list[float]]:
    """The list's joints that take the calibrated robot's tool0 to the nominal targets; with
    the `lost_motion` (n,) the calibration found, each joint commanded half of it beyond, on
    the side it comes from in the list's order."""
    q = np.radians([p.q_deg for p in plans])
    comp = compensate(calibrated, nominal, flange_kinematics(nominal, q), q, frame="base")
    sent = comp.q_rad if lost_motion is None else \
        commands_for_lost_motion(comp.q_rad, lost_motion)
    return np.round(np.degrees(sent), 4).tolist()


@dataclass
class TrackerDemo:
    """The figures of one run."""

    ap_before_mm: float
    ap_after_mm: float
    ap_after_geometric_mm: float
    calibration: CalibrationResult
    geometric: CalibrationResult
    runs: dict[str, TrackerRun]
    levels: BeamLevels  # the noise along and across the beam, from the first fit
    excess: BeamLevels  # what of it the tracker's reported covariances did not explain
    smr_words: str = SMR_WORDS[1]


async def procedure(host: str, port: int, tracker_url: str, *, poses: int, cycles: int,
                    stand_mm: Sequence[float], seed: int,
                    smrs_mm: tuple[Point, ...] = (DEFAULT_SMR_MM,)) -> TrackerDemo:
    nominal = irb1600()
    cal_q = calibration_poses(nominal, poses, stand_mm, seed, smrs_mm)
    perf = performance_poses(nominal, cycles, stand_mm, smrs_mm)
    targets = [p.role == "target" for p in perf]
    runs = {name: TrackerRun() for name in ("before", "calibration", "after", "geometric")}
    async with ControllerClient(host, port) as robot:
        cell = Cell(robot, tracker_url, smrs_mm)
        try:
            if len(smrs_mm) > 1:  # the beam is pointed at SMRs 2 and 3: locate the tracker
                runs["locate"] = TrackerRun()
                at = await cell.locate(cal_q[:LOCATE_POSES].tolist(), runs["locate"])
                yaw = np.degrees(np.arctan2(cell.to_tracker[1, 0], cell.to_tracker[0, 0]))
                print(f"  tracker located at {np.round(at).tolist()} mm, its frame turned "
                      f"{-yaw:.1f} deg about the vertical (first SMR at {LOCATE_POSES} poses)",
                      flush=True)
            await cell.visit([p.q_deg for p in perf], targets, runs["before"])
            await cell.visit(cal_q.tolist(), [True] * len(cal_q), runs["calibration"])
            data = measurement_set(runs["calibration"])
            beam = await asyncio.to_thread(identify_beam_weighted, nominal, data, kind="full",
                                           compliance="auto", lag="auto")
            ours = beam.result
            geo = await asyncio.to_thread(identify, nominal, data, kind="full")
            for name, result in (("after", ours), ("geometric", geo)):
                await cell.visit(compensated(perf, result.model, nominal,
                                             result.reading_lost_motion), targets, runs[name])
        finally:
            cell.close()
    return TrackerDemo(ap_mean_mm(runs["before"], perf, nominal, ours),
                       ap_mean_mm(runs["after"], perf, nominal, ours),
                       ap_mean_mm(runs["geometric"], perf, nominal, geo), ours, geo, runs,
                       beam.levels, beam.excess, SMR_WORDS[len(smrs_mm)])


def run_demo(*, seed: int | None, poses: int, cycles: int, time_scale: float, realism: str,
             stand_mm: Sequence[float] = TRACKER_STAND_MM, tracker_faults: str = "",
             smrs: int = 1, yaw_deg: float = 0.0) -> TrackerDemo:
    """The emulators (a process) and the procedure; prints what it does as it goes.
    `tracker_faults`: the emulated tracker's (`emulator irc5 --tracker-faults`); `smrs`: 1
    (positions) or 3 (full pose)."""
    smrs_mm = SMRS[smrs]
    noise_seed = NOISE_SEED if seed is None else seed
    stand = TrackerStand(tuple(stand_mm), yaw_deg, smrs, tracker_faults)
    with tempfile.TemporaryDirectory() as tmp, \
            emulators(time_scale, seed, Path(tmp) / "world.json", realism, stand) as \
            (host, port, url):
        print(f"screwcal demo: emulated IRB 1600 (realism {realism}) at {host}:{port}, laser "
              f"tracker {url} standing at {list(stand_mm)} mm (robot frame), "
              f"{SMR_WORDS[smrs]}; "
              f"{poses} calibration poses, ISO 9283 {cycles} cycles", flush=True)
        started = time.perf_counter()
        done = asyncio.run(procedure(host, port, url, poses=poses, cycles=cycles,
                                     stand_mm=stand_mm, seed=noise_seed, smrs_mm=smrs_mm))
        print(f"  measured in {time.perf_counter() - started:.1f} s", flush=True)
    return done


def summary_lines(done: TrackerDemo, stand_mm: Sequence[float]) -> list[str]:
    """What the run achieved and with what: the instrument, its uncertainty, the conditions."""
    from screwcal.instrument import (
        TRACKER_MPE_CONSTANT_MM,
        TRACKER_MPE_PER_M_MM,
        TRACKER_RADIAL_NOISE_MM,
    )

    points = [p for r in done.runs.values() for p in r.points if p is not None]
    weather = np.array([(p.temperature_c, p.pressure_mbar, p.humidity_pct) for p in points])
    ratio = done.ap_after_geometric_mm / done.ap_after_mm
    lines = [
        f"  instrument: laser tracker (emScon TPI), {done.smr_words}, standing at "
        f"{list(stand_mm)} mm; "
        f"U = {TRACKER_MPE_CONSTANT_MM * 1000:g} um + {TRACKER_MPE_PER_M_MM * 1000:g} um/m "
        f"(lateral), radial {TRACKER_RADIAL_NOISE_MM * 1000:g} um (1 sigma)",
        f"  conditions: {weather[:, 0].mean():.1f} deg C, {weather[:, 1].mean():.1f} mbar, "
        f"{weather[:, 2].mean():.0f} %RH (the tracker's weather, {len(points)} points)",
        f"  AP mean before {done.ap_before_mm:10.3f} mm",
        f"  AP mean after  {done.ap_after_mm:10.3f} mm  (full model, compliance and lag auto"
        + (", the lost motion found taken up on each target's approach side)"
           if done.calibration.reading_lost_motion is not None else ")"),
        f"  {'geometric only (compliance none, lag none)':<44}{done.ap_after_geometric_mm:8.3f}"
        f" mm  ({ratio:.2f}x ours)",
    ]
    lv, ex = done.levels, done.excess
    lines.append(f"  noise along the beam {lv.radial_mm * 1000:.1f} um, across it "
                 f"{lv.lateral_mm * 1000:.1f} um per direction (the fit's residuals, the robot's "
                 f"misfit included); beyond the tracker's reported covariances "
                 f"{ex.radial_mm * 1000:.1f} um and {ex.lateral_mm * 1000:.1f} um, added to each "
                 "point's weight")
    for name, run in done.runs.items():
        if run.skipped or run.faults:
            lines.append(f"  {name}: {len(run.points) - run.skipped} poses measured, "
                         f"{run.skipped} skipped (beam broken); tracker faults {run.faults}")
    return lines


def result_json(done: TrackerDemo, stand_mm: Sequence[float]) -> dict[str, Any]:
    """The run's result document: the instrument, its uncertainty, the conditions measured in,
    the accuracy figures, the poses measured or skipped, and the calibration's own result."""
    from screwcal.calibration.resultfile import result_document
    from screwcal.instrument import (
        SMR_ACCEPTANCE_DEG,
        TRACKER_MPE_CONSTANT_MM,
        TRACKER_MPE_PER_M_MM,
        TRACKER_RADIAL_NOISE_MM,
    )

    points = [p for r in done.runs.values() for p in r.points if p is not None]
    weather = np.array([(p.temperature_c, p.pressure_mbar, p.humidity_pct) for p in points])
    conditions = {name: {"mean": float(weather[:, k].mean()), "min": float(weather[:, k].min()),
                         "max": float(weather[:, k].max())}
                  for k, name in enumerate(("temperature_c", "pressure_mbar", "humidity_pct"))}
    settings = {"model": "full", "frames": "unknown", "compliance": "auto", "lag": "auto",
                "weighting": "the tracker's reported covariances plus the excess along and "
                "across the beam (screwcal.calibration.beam_weighting)",
                "poses": len(done.runs["calibration"].points)}
    return {
        "instrument": {"kind": "laser tracker", "protocol": "Leica emScon TPI",
                       "reflectors": done.smr_words, "stand_mm": [float(v) for v in stand_mm],
                       "uncertainty": {"mpe_mm": f"{TRACKER_MPE_CONSTANT_MM:g} + "
                                       f"{TRACKER_MPE_PER_M_MM:g} per m (k = 2, across the "
                                       "beam)", "radial_sigma_mm": TRACKER_RADIAL_NOISE_MM,
                                       "acceptance_deg": SMR_ACCEPTANCE_DEG}},
        "conditions": conditions,
        "ap_mean_mm": {"before": done.ap_before_mm, "after": done.ap_after_mm,
                       "after_geometric_only": done.ap_after_geometric_mm},
        "noise_mm": {"along_beam": done.levels.radial_mm, "across_beam": done.levels.lateral_mm,
                     "excess_along_beam": done.excess.radial_mm,
                     "excess_across_beam": done.excess.lateral_mm},
        "poses": {name: {"measured": len(r.points) - r.skipped, "skipped_beam_broken": r.skipped,
                         "tracker_faults": r.faults} for name, r in done.runs.items()},
        "calibration": result_document(done.calibration, "irb1600", settings),
    }
