"""An IRC5 emulator on port 0 around a true IRB 1600 with the thesis's errors."""

from __future__ import annotations

import numpy as np
import pytest

from protocol.client import ControllerClient, Timeouts
from screwcal.calibration.posesets import WORKING_REGION_DEG
from simulators.faults import FaultPlan
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.truth import make_world as cli_make_world
from simulators.world import World


def make_world() -> World:
    """The emulator command's default world: Table 11's errors, the arm at (500, 0, 600) mm in
    the robot frame (every test target within its reach)."""
    return cli_make_world(None, None)


@pytest.fixture
async def emulator():
    emu = IRC5Emulator(make_world(), EmulatorSettings(time_scale=0.0, faults=FaultPlan()))
    host, port = await emu.start("127.0.0.1", 0)
    emu.address = (host, port)
    yield emu
    await emu.stop()


@pytest.fixture
async def client(emulator):
    """A client that waits long enough for a loaded host (the RAPID interpreter runs in a thread
    of the test's process, beside other tests' processes): its time-outs guard against a hang,
    and the tests of time-outs make clients of their own."""
    c = ControllerClient(*emulator.address, Timeouts(reply_s=10.0, pose_s=10.0, motion_s=10.0))
    await c.connect()
    yield c
    await c.close()


def targets(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.round(rng.uniform(WORKING_REGION_DEG[:, 0], WORKING_REGION_DEG[:, 1], (n, 6)), 4)
