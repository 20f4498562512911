"""An IRC5 emulator on port 0 around a true IRB 1600 with the thesis's errors."""

from __future__ import annotations

import numpy as np
import pytest

from protocol.client import ControllerClient, Timeouts
from screwcal.demo import REGION_DEG
from screwcal.robots import irb1600
from screwcal.se3 import exp_twist
from screwcal.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from simulators.faults import FaultPlan
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.world import World

# The arm stands at (500, 0, 600) mm in the robot frame, turned 0.3 rad about z: every test
# target is within its 1200 mm reach. ARM_BASE maps the robot base into the arm's frame.
_R = exp_twist([0.0, 0.0, 0.3, 0.0, 0.0, 0.0])
ARM_BASE = _R.copy()
ARM_BASE[:3, 3] = -_R[:3, :3] @ np.array([500.0, 0.0, 600.0])


def make_world() -> World:
    nominal = irb1600()
    truth = apply_virtual_joints(nominal, THESIS_TABLE11).with_frames(base=ARM_BASE)
    return World(nominal=nominal, truth=truth)


@pytest.fixture
async def emulator():
    emu = IRC5Emulator(make_world(), EmulatorSettings(time_scale=0.0, faults=FaultPlan()))
    host, port = await emu.start("127.0.0.1", 0)
    emu.address = (host, port)
    yield emu
    await emu.stop()


@pytest.fixture
async def client(emulator):
    c = ControllerClient(*emulator.address, Timeouts(reply_s=2.0, pose_s=5.0, motion_s=5.0))
    await c.connect()
    yield c
    await c.close()


def targets(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.round(rng.uniform(REGION_DEG[:, 0], REGION_DEG[:, 1], (n, 6)), 4)
