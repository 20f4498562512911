"""Benchmark: calibration jobs through the REST API against emulated robots at time scale 0.

    .venv/bin/python benchmarks/jobs.py [--robots 20] [--rounds 5] [--hogs 2]

One 40-pose calibration job from the REST call to its result, then N such jobs on N emulated
robots at once (one service), alternated for `--rounds` rounds; the median with min and max of
each (one run hides how much the figure depends on what else the host runs), and the process's
CPU seconds over its wall seconds during the N jobs (above 1: it used more than one core).
With `--hogs K`, each round's N jobs run twice, alone and beside K CPU-bound processes
(`while True: pass`, started before the jobs are posted, ended after), and the ratio of each
pair is reported. The emulated robots (a RAPID interpreter thread each, and the arms) run in
this process. Targets (issues 7, 29): <= 2 s for one, <= 10 s for twenty; beside two hogs
<= 10 s and within 1.5x of the quiet figure.
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import asyncio
import itertools
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

from service.app import create_app
from service.settings import ServiceSettings
from simulators.arm import ArmEmulator
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.truth import make_world

TOKEN = "bench"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
_names = itertools.count(1)  # robot names are unique in a service


async def cell() -> tuple[str, int, str, list]:
    world = make_world(None, None)
    emu = IRC5Emulator(world, EmulatorSettings(time_scale=0.0))
    host, port = await emu.start("127.0.0.1", 0)
    arm = ArmEmulator(world, seed=1)
    ahost, aport = await arm.start("127.0.0.1", 0)
    return host, port, f"socket://{ahost}:{aport}", [emu, arm]


async def run_jobs(http: httpx.AsyncClient, n: int, hogs: int = 0) -> tuple[float, float]:
    """Wall and CPU seconds of n jobs at once, beside `hogs` CPU-bound processes."""
    cells = [await cell() for _ in range(n)]
    robots = []
    for host, port, arm, _ in cells:
        r = await http.post("/robots", headers=AUTH, json={
            "name": f"bench-{next(_names)}", "controller_host": host, "controller_port": port,
            "arm_url": arm})
        assert r.status_code == 201, r.text
        robots.append(r.json()["id"])
    spinning = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(hogs)]
    await asyncio.sleep(0.2 if hogs else 0.0)  # the hogs up and spinning
    start, cpu = time.perf_counter(), time.process_time()
    ids = [(await http.post("/jobs", headers=AUTH, json={
        "robot_id": rid, "kind": "calibration", "options": {"calibration_poses": 40}})).json()[
        "id"] for rid in robots]
    pending = set(ids)
    while pending:
        for job_id in list(pending):
            if (await http.get(f"/jobs/{job_id}")).json()["state"] in ("done", "failed"):
                result = (await http.get(f"/jobs/{job_id}/result")).json()
                assert result["state"] == "done", result["reason"]
                pending.discard(job_id)
        await asyncio.sleep(0.005)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    for hog in spinning:
        hog.kill()
        hog.wait()
    for *_, parts in cells:
        for part in parts:
            await part.stop()
    return elapsed, cpu


def spread(label: str, times: list[float], target: float) -> str:
    """One line: median (min-max, rounds) against the target."""
    med = statistics.median(times)
    return (f"{label:<48}{med:>7.2f} s  ({min(times):.2f}-{max(times):.2f}, {len(times)} runs)"
            f"   target {target:g} s " + ("ok" if med <= target else "MISSED"))


async def main_async(robots: int, rounds: int, hogs: int) -> None:
    ones, manys, cpus, loaded, loaded_cpus = [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(ServiceSettings(db_path=Path(tmp) / "bench.db", token=TOKEN))
        async with app.router.lifespan_context(app):
            async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                         base_url="http://service", headers=AUTH) as http:
                for _ in range(rounds):
                    ones.append((await run_jobs(http, 1))[0])
                    wall, cpu = await run_jobs(http, robots)
                    manys.append(wall)
                    cpus.append(cpu / wall)
                    if hogs:
                        wall, cpu = await run_jobs(http, robots, hogs)
                        loaded.append(wall)
                        loaded_cpus.append(cpu / wall)
    print(spread("one 40-pose calibration job, REST to result", ones, 2))
    print(spread(f"{robots} such jobs on {robots} robots at once", manys, 10)
          + f"; CPU/wall {statistics.median(cpus):.2f}")
    if hogs:
        print(spread(f"the same beside {hogs} CPU-bound processes", loaded, 10)
              + f"; CPU/wall {statistics.median(loaded_cpus):.2f}")
        ratios = [b / a for a, b in zip(manys, loaded, strict=True)]
        med = statistics.median(ratios)
        print(f"{'beside them / alone, pair by pair':<48}{med:>7.2f}x ({min(ratios):.2f}-"
              f"{max(ratios):.2f})   target 1.5x " + ("ok" if med <= 1.5 else "MISSED"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robots", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--hogs", type=int, default=0,
                        help="also run each round beside this many CPU-bound processes")
    args = parser.parse_args()
    if args.robots < 1 or args.rounds < 1 or args.hogs < 0:
        parser.error("--robots and --rounds must be at least 1, --hogs at least 0")
    asyncio.run(main_async(args.robots, args.rounds, args.hogs))


if __name__ == "__main__":
    main()
