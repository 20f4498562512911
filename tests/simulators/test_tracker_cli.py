"""`screwcal emulator tracker` and `emulator irc5 --tracker-port`: real processes and ports."""

import asyncio
import re
import subprocess

import numpy as np
import pytest

from protocol.client import ControllerClient
from protocol.errors import BeamBrokenError
from protocol.tracker import TrackerClient
from tests.simulators.test_emulator_cli import EXE, start, stop

SEEN = [0.0, 30.0, 20.0, 0.0, -50.0, 0.0]  # the SMR faces the tracker at its default stand


def _measure(url: str, n: int = 1):
    with TrackerClient.open(url) as tracker:
        tracker.setup()
        return [tracker.measure() for _ in range(n)]


@pytest.mark.slow
async def test_the_tracker_in_the_irc5_process_and_in_its_own(tmp_path):
    world = tmp_path / "world.json"
    irc5, line = start(["irc5", "--port", "0", "--time-scale", "0", "--world", str(world),
                        "--tracker-port", "0", "--tracker-faults", "beam=1,beam_n=2"])
    tracker_proc = None
    try:
        m = re.match(r"irc5 emulator on ([\d.]+):(\d+); laser tracker on (emscon://\S+)", line)
        assert m, line
        tracker_proc, tracker_line = start(["tracker", "--port", "0", "--world", str(world)])
        other = re.match(r"laser tracker on (emscon://\S+)", tracker_line).group(1)
        async with ControllerClient(m.group(1), int(m.group(2))) as robot:
            await robot.movj(SEEN)
        inside = await asyncio.to_thread(_measure, m.group(3))
        alone = await asyncio.to_thread(_measure, other, 3)
        np.testing.assert_allclose(inside[0].xyz_mm, alone[0].xyz_mm, atol=0.1)
        with pytest.raises(BeamBrokenError):  # the injected fault: attempts 1 and 2 broken
            await asyncio.to_thread(_measure, m.group(3))
    finally:
        try:
            stop(irc5)
        finally:
            if tracker_proc is not None:
                stop(tracker_proc)


def test_bad_tracker_options_are_refused():
    for args, what in ((["--tracker-faults", "laser=1"], "tracker fault 'laser'"),
                       (["--stand-mm", "1", "2"], "--stand-mm")):
        out = subprocess.run([*EXE, "tracker", "--port", "0", *args], capture_output=True,
                             text=True, timeout=30)
        assert out.returncode == 2 and what in out.stderr, out.stderr
