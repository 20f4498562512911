"""The robot and the laser tracker of one tracker demo run (`service/tracker_demo.py`): moving
through a list of poses and measuring the SMRs at each, with the tracker's failures handled (a
broken beam skips the pose; a lost, uninitialised or warming tracker is reconnected, initialised or
waited for, and the pose measured once), and what was measured (`TrackerRun`).
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from protocol.client import ControllerClient
from protocol.errors import (
    BeamBrokenError,
    LinkError,
    TrackerNotInitialisedError,
    TrackerWarmingUpError,
)
from protocol.tracker import TrackerClient, TrackerPoint
from screwcal.calibration.initial_frames import rigid_motion
from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import Array
from service.errors import ServiceError
from service.instruments import measure_others

MAX_TRIES = 6  # a pose measured after at most this many link failures, else the run stops
Point = tuple[float, float, float]


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
        R = self.to_tracker @ flange_kinematics(self.nominal, np.radians([joints_deg]))[0][:3, :3]
        return measure_others(tracker, first, self.smrs, R)

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

