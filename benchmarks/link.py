"""Benchmark: the controller link over loopback TCP, client and IRC5 emulator in one process.

    .venv/bin/python benchmarks/link.py [--repeat 5]

STAT round trip, and the software overhead per pose of a 200-pose list at time scale 0 (no
motion time: what remains is codec, transport, the emulator's kinematics and the client).
Target (issue 4): <= 2 ms per pose.
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import asyncio
import time

import numpy as np

from protocol.client import ControllerClient
from screwcal.calibration.posesets import random_configurations
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.truth import make_world


async def measure(repeat: int) -> tuple[float, float]:
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(time_scale=0.0))
    host, port = await emu.start("127.0.0.1", 0)
    targets = np.round(np.degrees(random_configurations(200, np.random.default_rng(0))), 4)
    async with ControllerClient(host, port) as robot:
        await robot.stat()
        stat_times, run_times = [], []
        for _ in range(repeat):
            start = time.perf_counter()
            for _ in range(100):
                await robot.stat()
            stat_times.append((time.perf_counter() - start) / 100)
            await robot.load("CAL", targets)
            start = time.perf_counter()
            n = sum([1 async for _ in robot.run("CAL", "AUTO", count=200)])
            run_times.append((time.perf_counter() - start) / n)
    await emu.stop()
    return min(stat_times), min(run_times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    stat_s, pose_s = asyncio.run(measure(args.repeat))
    print(f"{'STAT round trip (loopback)':<42}{stat_s * 1e3:>8.3f} ms")
    verdict = "ok" if pose_s <= 2e-3 else "MISSED"
    print(f"{'per pose, 200-pose list, time scale 0':<42}{pose_s * 1e3:>8.3f} ms   target 2 ms "
          f"{verdict}")


if __name__ == "__main__":
    main()
