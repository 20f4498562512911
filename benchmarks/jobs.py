"""Benchmark: calibration jobs through the REST API against emulated robots at time scale 0.

    .venv/bin/python benchmarks/jobs.py [--robots 20] [--rounds 5]

One 40-pose calibration job from the REST call to its result, then N such jobs on N emulated
robots at once (one service), alternated for `--rounds` rounds; the median with min and max of
each (one run hides how much the figure depends on what else the host runs). Targets
(issues 7, 29): <= 2 s for one, <= 10 s for twenty.
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import asyncio
import itertools
import statistics
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


async def run_jobs(http: httpx.AsyncClient, n: int) -> float:
    cells = [await cell() for _ in range(n)]
    robots = []
    for host, port, arm, _ in cells:
        r = await http.post("/robots", headers=AUTH, json={
            "name": f"bench-{next(_names)}", "controller_host": host, "controller_port": port,
            "arm_url": arm})
        assert r.status_code == 201, r.text
        robots.append(r.json()["id"])
    start = time.perf_counter()
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
    elapsed = time.perf_counter() - start
    for *_, parts in cells:
        for part in parts:
            await part.stop()
    return elapsed


def spread(label: str, times: list[float], target: float) -> str:
    """One line: median (min-max, rounds) against the target."""
    med = statistics.median(times)
    return (f"{label:<48}{med:>7.2f} s  ({min(times):.2f}-{max(times):.2f}, {len(times)} runs)"
            f"   target {target:g} s " + ("ok" if med <= target else "MISSED"))


async def main_async(robots: int, rounds: int) -> None:
    ones, manys = [], []
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(ServiceSettings(db_path=Path(tmp) / "bench.db", token=TOKEN))
        async with app.router.lifespan_context(app):
            async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                         base_url="http://service", headers=AUTH) as http:
                for _ in range(rounds):
                    ones.append(await run_jobs(http, 1))
                    manys.append(await run_jobs(http, robots))
    print(spread("one 40-pose calibration job, REST to result", ones, 2))
    print(spread(f"{robots} such jobs on {robots} robots at once", manys, 10))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robots", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    if args.robots < 1 or args.rounds < 1:
        parser.error("--robots and --rounds must be at least 1")
    asyncio.run(main_async(args.robots, args.rounds))


if __name__ == "__main__":
    main()
