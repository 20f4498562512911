"""The pose lists a job runs: a calibration set and the ISO 9283 performance list.

Calibration: by default the Klimchik-style set of 40 configurations
(`screwcal.calibration.posesets`: one quadrant, the TCP in a 600 mm cube within the arm's reach,
the thesis's choice of Table 7), drawn from a fixed seed so that a job is repeatable; a robot
that cannot reach that cube gets 40 poses spread over a region well inside its joint limits.

Performance: the ISO 9283 cube's P1-P5 with return points (`screwcal.performance.testcube`)
for n cycles, then a straight line of points from P2 to P4 for the straightness (thesis 2.3.2).

A robot measured by a laser tracker (its record's `tracker` instrument) gets lists its beam sees
(`screwcal.calibration.line_of_sight`, on the nominal robot with margins, from where the record
says the tracker stands): calibration poses drawn from the working region among those whose SMRs
the tracker sees, the cube's poses turned to face the tracker; a list the tracker would not see
is refused when the job is posted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from screwcal.calibration.line_of_sight import visible, visible_configurations
from screwcal.calibration.posesets import cube_set, random_configurations
from screwcal.errors import ScrewcalError
from screwcal.kinematics.ik import closed_form_ik
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import transform_from_pose
from screwcal.performance.testcube import ArmSphere, find_test_cube, performance_pose_list
from service.document import JobOptions
from service.robot_record import InstrumentSetup, TrackerSetup

FACING_TRACKER_DEG = (0.0, 90.0, 0.0)  # a tracker's cube: the flange toward +x, the tracker


@dataclass(frozen=True)
class PlannedPose:
    idx: int
    joints_deg: tuple[float, ...]
    role: str  # "cal", "approach", "target", "line"
    point: str = ""  # ISO point label (P1..P5) for performance targets
    cycle: int = 0
    commanded: tuple[float, ...] = ()  # x, y, z (mm), rx, ry, rz (deg) of tool0, base frame


BACKLASH_APPROACH_DEG = 1.0  # each joint's move onto a two-direction pose: beyond any lost motion
BACKLASH_ROLES = ("backlash_a", "backlash_b")  # approached from below, then from above


def calibration_plan(model: SerialModel, n: int = 40, seed: int = 2018,
                     backlash_poses: int = 0) -> list[PlannedPose]:
    """The calibration list; `backlash_poses` of its poses are appended twice more, each time
    after a return point: BACKLASH_APPROACH_DEG below on every joint (role backlash_a), then
    as far above (backlash_b), so that every joint comes from each side once
    (`screwcal.calibration.backlash`)."""
    try:
        q = np.round(np.degrees(cube_set(model, "Klimchik", n, seed=seed)), 4)
    except ScrewcalError:  # this robot does not reach the cube: a spread region instead
        rng = np.random.default_rng(seed)
        q = np.round(np.degrees(random_configurations(n, rng)), 4)
    model.check_limits(np.radians(q), "calibration pose")
    plan = [PlannedPose(k, tuple(float(v) for v in q[k]), "cal") for k in range(n)]
    step = BACKLASH_APPROACH_DEG
    chosen = [k for k in range(n) if model.within_limits(np.radians(q[k] - step))
              and model.within_limits(np.radians(q[k] + step))][:backlash_poses]
    if len(chosen) < backlash_poses:
        raise ScrewcalError(f"only {len(chosen)} calibration poses can be approached from "
                            f"{step:g} deg on both sides within the limits; asked "
                            f"{backlash_poses}")
    for pair, k in enumerate(chosen):
        label = f"B{pair + 1}"
        for side, role in zip((-step, step), BACKLASH_ROLES, strict=True):
            plan.append(PlannedPose(len(plan), tuple(float(v) for v in q[k] + side),
                                    "approach", label))
            plan.append(PlannedPose(len(plan), plan[k].joints_deg, role, label))
    return plan


def tracker_calibration_plan(model: SerialModel, n: int, tracker: TrackerSetup,
                             seed: int = 2018) -> list[PlannedPose]:
    """n configurations of the working region whose SMRs the tracker sees (from a fixed seed:
    a job is repeatable)."""
    try:
        q = visible_configurations(model, n, np.asarray(tracker.stand_mm, dtype=float),
                                   np.random.default_rng(seed),
                                   tuple((p[0], p[1], p[2]) for p in tracker.smrs_mm))
    except ValueError as err:
        raise ScrewcalError(f"the tracker at {tracker.stand_mm} mm: {err}") from None
    deg = np.round(np.degrees(q), 4)
    return [PlannedPose(k, tuple(float(v) for v in deg[k]), "cal") for k in range(n)]


def performance_plan(model: SerialModel, cycles: int = 30, edge_mm: float = 300.0,
                     arm_position_mm: tuple[float, float, float] | None = None,
                     line_points: int = 11, tracker: TrackerSetup | None = None
                     ) -> list[PlannedPose]:
    arm = ArmSphere(arm_position_mm, 1150.0) if arm_position_mm is not None and \
        tracker is None else None
    cube = find_test_cube(model, edge_mm, arm=arm) if tracker is None else \
        find_test_cube(model, edge_mm, orientation_deg=FACING_TRACKER_DEG)
    plans = [PlannedPose(p.index, p.q_deg, p.role, p.point, p.cycle, p.pose_cmd)
             for p in performance_pose_list(model, cube, cycles)]
    pts = cube.points_mm
    t = np.linspace(0.0, 1.0, line_points)[:, None]
    line = pts["P2"] + t * (pts["P4"] - pts["P2"])
    poses = cube.poses(line)
    sol = closed_form_ik(model, transform_from_pose(poses))
    q = np.degrees(sol.nearest(np.radians(plans[-1].joints_deg)))
    model.check_limits(np.radians(q), "straightness pose")
    start = len(plans)
    plans += [PlannedPose(start + k, tuple(float(v) for v in q[k]), "line",
                          commanded=tuple(float(v) for v in poses[k]))
              for k in range(line_points)]
    if tracker is not None:
        q_all = np.radians([p.joints_deg for p in plans])
        stand = np.asarray(tracker.stand_mm, dtype=float)
        for smr in tracker.smrs_mm:
            seen = visible(model, q_all, stand, smr_mm=(smr[0], smr[1], smr[2]))
            if not seen.all():
                raise ScrewcalError(f"the tracker at {tracker.stand_mm} mm does not see "
                                    f"{int((~seen).sum())} poses of the ISO 9283 list (the "
                                    f"first: pose {int(np.flatnonzero(~seen)[0])}): stand it "
                                    "in front of the cube, facing the robot")
    return plans


def plan_for(model: SerialModel, kind: str, options: JobOptions,
             instrument: InstrumentSetup | None = None) -> list[PlannedPose]:
    """A job's "cal" or "perf" list from its options (deterministic) and the robot's
    instrument (a tracker's lists are those its beam sees): what the job runs, and what is
    built when the job is posted to refuse one that cannot run."""
    tracker = instrument if isinstance(instrument, TrackerSetup) else None
    if kind == "cal":
        if tracker is not None:
            if options.backlash_poses:
                raise ScrewcalError("backlash poses are not planned for a tracker's beam yet: "
                                    "set backlash_poses 0")
            return tracker_calibration_plan(model, options.calibration_poses, tracker)
        return calibration_plan(model, options.calibration_poses,
                                backlash_poses=options.backlash_poses)
    return performance_plan(model, options.cycles, options.cube_edge_mm,
                            options.arm_position_mm, tracker=tracker)


LISTS_OF_KIND = {"performance": ("perf",), "calibration": ("cal",), "procedure": ("cal", "perf"),
                 "verify": ("perf",)}
