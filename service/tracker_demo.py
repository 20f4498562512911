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

The procedure: ISO 9283 AP before; calibration; compensation of the performance list; AP after;
the same with the geometric-only model (no compliance, no read-back lag) on the same data, as the
arm's demo prints it. Positions in the tracker's frame are taken into the robot's base frame
with the base frame the calibration identified.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from protocol.client import ControllerClient
from protocol.errors import (
    BeamBrokenError,
    LinkError,
    ProtocolError,
    TrackerNotInitialisedError,
    TrackerWarmingUpError,
)
from protocol.tracker import TrackerClient, TrackerPoint
from screwcal.calibration.beam_weighting import BeamLevels, identify_beam_weighted
from screwcal.calibration.correction import compensate
from screwcal.calibration.flange import frame_from_holes
from screwcal.calibration.identify import CalibrationResult, identify
from screwcal.calibration.initial_frames import rigid_motion
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
from service.errors import ServiceError

FACING_TRACKER_DEG = (0.0, 90.0, 0.0)  # the cube's orientation: the flange toward +x
CUBE_EDGE_MM = 300.0
MAX_TRIES = 6  # a pose measured after at most this many link failures, else the run stops
RIGIDITY_MM = 1.0  # the SMRs measured at a pose keep the nests' distances within this
LOCATE_POSES = 6  # calibration poses whose first SMR locates the tracker (three SMRs)
Point = tuple[float, float, float]
SMRS: dict[int, tuple[Point, ...]] = {1: (DEFAULT_SMR_MM,), 3: THREE_SMRS_MM}
SMR_WORDS = {1: "one SMR (positions)", 3: "three SMRs (full pose)"}


@dataclass
class TrackerRun:
    """What was measured: per pose its reported joints (deg) and its point, or None (skipped:
    the beam was broken), and the link failures met on the way."""

    joints_deg: list[list[float]] = field(default_factory=list)
    points: list[TrackerPoint | None] = field(default_factory=list)
    previous_deg: list[list[float]] = field(default_factory=list)  # the joints read before
    others: list[list[TrackerPoint] | None] = field(default_factory=list)  # SMRs 2, 3
    faults: dict[str, int] = field(default_factory=dict)

    @property
    def skipped(self) -> int:
        return sum(p is None for p in self.points)


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


class Cell:
    """The robot and the tracker of one run, with the tracker's failures handled. With several
    SMRs, the tracker stays locked on the first through the moves; at each pose the others are
    found by pointing where the nominal robot's orientation puts them from the first
    (GoPosition), then the beam goes back to the first."""

    def __init__(self, robot: ControllerClient, tracker_url: str,
                 smrs_mm: Sequence[Point] = (DEFAULT_SMR_MM,)):
        self.robot, self.tracker_url = robot, tracker_url
        self.smrs = np.array(smrs_mm, dtype=float)
        self.tracker: TrackerClient | None = None
        self.nominal = irb1600()
        self._anchor: tuple[float, float, float] | None = None  # the first SMR at this pose
        self.to_tracker = np.eye(3)  # the tracker's frame <- the robot's, once located
        self.last_deg: Sequence[float] | None = None  # the joints read at the last move

    async def _tracker(self, initialise: bool) -> TrackerClient:
        if self.tracker is None:
            self.tracker = await asyncio.to_thread(TrackerClient.open, self.tracker_url)
            await asyncio.to_thread(self.tracker.setup, initialise=initialise)
        return self.tracker

    def close(self) -> None:
        if self.tracker is not None:
            self.tracker.close()
            self.tracker = None

    def _measure_all(self, tracker: TrackerClient, joints_deg: Sequence[float]
                     ) -> list[TrackerPoint]:
        """Every SMR of this pose, the first first (blocking: in a thread)."""
        if self._anchor is not None:  # a retry: the beam may have been left on another SMR
            tracker.go_position(self._anchor)
        first = tracker.measure()
        self._anchor = first.xyz_mm
        points = [first]
        if len(self.smrs) == 1:
            return points
        R = self.to_tracker @ flange_kinematics(self.nominal, np.radians([joints_deg]))[0][:3, :3]
        try:
            for smr in self.smrs[1:]:
                tracker.go_position(np.asarray(first.xyz_mm) + R @ (smr - self.smrs[0]))
                points.append(tracker.measure())
        finally:
            with contextlib.suppress(ProtocolError):  # tracked through the next move
                tracker.go_position(first.xyz_mm)
        measured = np.array([p.xyz_mm for p in points])
        mismatch = _triangle_mismatch_mm(measured, self.smrs)
        if mismatch > RIGIDITY_MM:
            raise BeamBrokenError(f"the reflectors measured are not the SMRs' triangle (sides "
                                  f"off by {mismatch:.2f} mm): a wrong reflector was locked")
        return points

    async def measure(self, run: TrackerRun, joints_deg: Sequence[float]
                      ) -> list[TrackerPoint] | None:
        """The SMRs of the pose just reached: None when a beam is broken even after a search
        (the pose is skipped); link failures cured and the pose measured once."""
        initialise = self.tracker is None
        self._anchor = None
        for _ in range(MAX_TRIES):
            try:
                tracker = await self._tracker(initialise)
                return await asyncio.to_thread(self._measure_all, tracker, joints_deg)
            except BeamBrokenError:
                run.faults["beam broken (pose skipped)"] = \
                    run.faults.get("beam broken (pose skipped)", 0) + 1
                return None
            except TrackerNotInitialisedError:
                run.faults["not initialised"] = run.faults.get("not initialised", 0) + 1
                initialise = True
                self.close()
            except TrackerWarmingUpError:
                run.faults["warming up"] = run.faults.get("warming up", 0) + 1
                await asyncio.sleep(0.2)
            except LinkError as err:  # lost or silent: reconnect, measure the pose again
                run.faults[type(err).__name__] = run.faults.get(type(err).__name__, 0) + 1
                self.close()
                await asyncio.sleep(0.1)
        raise ServiceError(f"the tracker at {self.tracker_url} failed {MAX_TRIES} times on one "
                           "pose")

    async def locate(self, q_list: Sequence[Sequence[float]], run: TrackerRun) -> Array:
        """Where the tracker stands, roughly: the first SMR measured at `q_list` laid on the
        nominal robot's (Kabsch); its frame's rotation then points the beam at the other SMRs.
        Returns the tracker's place in the robot frame (mm)."""
        smrs, self.smrs = self.smrs, self.smrs[:1]
        try:
            await self.visit(q_list, [True] * len(q_list), run)
        finally:
            self.smrs = smrs
        keep = [k for k, p in enumerate(run.points) if p is not None]
        if len(keep) < 3:
            raise ServiceError(f"the tracker saw the SMR at {len(keep)} of {len(q_list)} "
                               "poses: too few to locate it")
        T = flange_kinematics(self.nominal, np.radians([run.joints_deg[k] for k in keep]))
        nominal = T[:, :3, :3] @ self.smrs[0] + T[:, :3, 3]
        measured = np.array([p.xyz_mm for p in run.points if p is not None])
        self.to_tracker, t = rigid_motion(nominal, measured)
        return np.asarray(-self.to_tracker.T @ t, dtype=float)

    async def visit(self, q_list: Sequence[Sequence[float]], measured: Sequence[bool],
                    run: TrackerRun) -> None:
        """Move through `q_list`; measure the poses flagged in `measured`."""
        for q, measure in zip(q_list, measured, strict=True):
            pose = await self.robot.movj([float(v) for v in q])
            last = self.last_deg  # where the robot came from, in this list or the one before
            if measure:
                run.previous_deg.append(list(last) if last is not None else [np.nan] * 6)
                run.joints_deg.append(list(pose.joints_deg))
                got = await self.measure(run, pose.joints_deg)
                run.points.append(None if got is None else got[0])
                run.others.append(None if got is None else got[1:])
            self.last_deg = pose.joints_deg


def _triangle_mismatch_mm(measured: Array, nests: Array) -> float:
    """The largest difference between the measured SMRs' mutual distances and the nests'."""
    k = len(nests)
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    return max((abs(float(np.linalg.norm(measured[i] - measured[j])
                          - np.linalg.norm(nests[i] - nests[j]))) for i, j in pairs),
               default=0.0)


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


def compensated(plans: Sequence[PosePlan], calibrated: SerialModel, nominal: SerialModel
                ) -> list[list[float]]:
    """The list's joints that take the calibrated robot's tool0 to the nominal targets."""
    q = np.radians([p.q_deg for p in plans])
    comp = compensate(calibrated, nominal, flange_kinematics(nominal, q), q, frame="base")
    return np.round(np.degrees(comp.q_rad), 4).tolist()


@contextlib.contextmanager
def emulators(args_: Sequence[str]) -> Iterator[tuple[str, int, str]]:
    """`screwcal emulator irc5 ... --tracker-port 0` as a process: (host, port, tracker URL)."""
    cmd = [sys.executable, "-m", "screwcal", "emulator", "irc5", "--port", "0",
           "--tracker-port", "0", *args_]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline() if proc.stdout else ""
        m = re.match(r"irc5 emulator on ([\d.]+):(\d+); laser tracker on (\S+)", line)
        if not m:
            raise ServiceError(f"the emulators did not start: {line}"
                               f"{proc.stderr.read() if proc.stderr else ''}")
        yield m.group(1), int(m.group(2)), m.group(3)
    finally:
        proc.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.communicate(timeout=10)


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
                await cell.visit(compensated(perf, result.model, nominal), targets, runs[name])
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
    noise_seed = 2018 if seed is None else seed
    args_ = ["--time-scale", str(time_scale), "--realism", realism, "--noise-seed",
             str(noise_seed), "--stand-mm", *(f"{v:g}" for v in stand_mm), "--smrs",
             str(smrs), "--stand-yaw-deg", f"{yaw_deg:g}"]
    if seed is not None:
        args_ += ["--seed", str(seed)]
    if tracker_faults:
        args_ += ["--tracker-faults", tracker_faults]
    with tempfile.TemporaryDirectory() as tmp, \
            emulators([*args_, "--world", str(Path(tmp) / "world.json")]) as (host, port, url):
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
        f"  AP mean after  {done.ap_after_mm:10.3f} mm  (full model, compliance and lag auto)",
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
