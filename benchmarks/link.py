"""Benchmark: the controller link over loopback TCP, client and IRC5 emulator in one process.

    .venv/bin/python benchmarks/link.py [--repeat 5]

STAT round trip, and the software overhead per pose of a 200-pose list at time scale 0 (no
motion time: what remains is the interpreted RAPID module, transport, the controller's
kinematics and the client). Target (issue 24, the module run by the RAPID interpreter):
<= 5 ms per pose (the Python protocol double it replaced: 0.6 ms; issue 4's 2 ms was its
target).
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


def _task_cpu_s(emu: IRC5Emulator) -> float:
    """CPU seconds the RAPID task's thread has used (insensitive to the machine's load)."""
    assert emu._thread is not None and emu._thread.ident is not None
    return time.clock_gettime(time.pthread_getcpuclockid(emu._thread.ident))


async def measure(repeat: int) -> tuple[float, float, float, float]:
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(time_scale=0.0))
    host, port = await emu.start("127.0.0.1", 0)
    targets = np.round(np.degrees(random_configurations(200, np.random.default_rng(0))), 4)
    async with ControllerClient(host, port) as robot:
        await robot.stat()
        stat_times, run_times, cpu_times, all_cpu = [], [], [], []
        for _ in range(repeat):
            start = time.perf_counter()
            for _ in range(100):
                await robot.stat()
            stat_times.append((time.perf_counter() - start) / 100)
            await robot.load("CAL", targets)
            start, cpu, proc = time.perf_counter(), _task_cpu_s(emu), time.process_time()
            n = sum([1 async for _ in robot.run("CAL", "AUTO", count=200)])
            run_times.append((time.perf_counter() - start) / n)
            cpu_times.append((_task_cpu_s(emu) - cpu) / n)
            all_cpu.append((time.process_time() - proc) / n)
    await emu.stop()
    return min(stat_times), min(run_times), min(cpu_times), min(all_cpu)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    stat_s, pose_s, cpu_s, all_s = asyncio.run(measure(args.repeat))
    print(f"{'STAT round trip (loopback)':<42}{stat_s * 1e3:>8.3f} ms")
    verdict = "ok" if pose_s <= 5e-3 else "MISSED"
    print(f"{'per pose, 200-pose list, time scale 0':<42}{pose_s * 1e3:>8.3f} ms   target 5 ms "
          f"{verdict}")
    # CPU times do not depend on the machine's load (the wall time above does, twice over:
    # two threads, the module's and the client's, share the interpreter lock).
    print(f"{'  CPU per pose, client and controller':<42}{all_s * 1e3:>8.3f} ms")
    print(f"{'  of which the RAPID task':<42}{cpu_s * 1e3:>8.3f} ms")


if __name__ == "__main__":
    main()
