"""The oracle floor: the accuracy the emulated robot would have if its true geometry and its
true compliance were compensated exactly, i.e. what no model of ours can remove (backlash, the
drift since, the repeatability error and the arm's noise).

The robot is moved through the same lists a job runs before its performance test (so that its
warm-up and the sides its joints stopped on are those of the job), then through the
performance list compensated with the true model as it is then (its own masses and compliance,
the list's payload, the geometry grown by the warm-up so far; for a job that takes up the lost
motion it finds, the true backlash taken up the same way); the arm probes the holes with its
noise.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence

import numpy as np

from screwcal.calibration.correction import compensate
from screwcal.calibration.flange import MeasuringFlange
from screwcal.calibration.lag import commands_for_lost_motion
from screwcal.instrument import POSITION_NOISE_MM
from screwcal.kinematics.compliance import Payload
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.se3 import Array, invert_transform
from simulators.world import World


async def _visit(world: World, q_deg: Array, probe: bool, rng: np.random.Generator
                 ) -> Array | None:
    holes = []
    for q in q_deg:
        await world.set_joints(np.asarray(q, dtype=np.float32))
        if probe:
            holes.append(world.true_holes_mm() + rng.normal(0.0, POSITION_NOISE_MM, (3, 3)))
    return np.array(holes) if probe else None


def oracle_attained(world: World, before_deg: Sequence[Sequence[float]], perf_deg: Array,
                    payload: Payload, noise_seed: int | None = None,
                    lost_motion_deg: Sequence[float] | None = None) -> Array:
    """(N, 4, 4) the flange poses the arm measures, in the true robot base frame, when the
    performance list `perf_deg` (N, n; nominal joint targets) is sent compensated by the true
    model carrying `payload`, after the robot ran through `before_deg`: the true robot as it is
    then (warm: its lengths grown by the running so far), so that a calibration made on the warm
    robot cannot land below the floor. `lost_motion_deg` (n,): the true backlash taken up as a
    job that takes up the lost motion it finds does (`lag.commands_for_lost_motion`)."""
    rng = np.random.default_rng(noise_seed)
    q_nominal = np.radians(np.asarray(perf_deg, dtype=float))
    targets = flange_kinematics(world.nominal, q_nominal)
    world.set_payload(payload)

    async def run() -> Array:
        if len(before_deg):
            await _visit(world, np.asarray(before_deg, dtype=float), False, rng)
        robot = world.true_model().derived(payload=payload).with_frames(base=np.eye(4))
        comp = compensate(robot, world.nominal, targets, q_nominal, frame="base")
        sent: Array = np.round(np.degrees(comp.q_rad), 4).astype(float)
        if lost_motion_deg is not None:
            sent = np.round(commands_for_lost_motion(sent, np.asarray(lost_motion_deg, float)),
                            4)
        holes = await _visit(world, sent, True, rng)
        assert holes is not None
        return holes

    holes = asyncio.run(run())
    flange = MeasuringFlange.from_holes_in_flange(world.holes_mm)
    return invert_transform(world.truth.base) @ flange.flange_poses(holes)
