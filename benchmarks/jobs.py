"""Benchmark: calibration jobs through the REST API against emulated robots at time scale 0.

    .venv/bin/python benchmarks/jobs.py [--robots 20]

One 40-pose calibration job from the REST call to its result, then N such jobs on N emulated
robots at once (one service). Targets (issue 7): <= 2 s for one, <= 10 s for twenty.
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import asyncio
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
            "name": "bench", "controller_host": host, "controller_port": port, "arm_url": arm})
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


async def main_async(robots: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        app = create_app(ServiceSettings(db_path=Path(tmp) / "bench.db", token=TOKEN))
        async with app.router.lifespan_context(app):
            async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                         base_url="http://service", headers=AUTH) as http:
                one = await run_jobs(http, 1)
                many = await run_jobs(http, robots)
    print(f"{'one 40-pose calibration job, REST to result':<48}{one:>7.2f} s   target 2 s "
          + ("ok" if one <= 2 else "MISSED"))
    print(f"{f'{robots} such jobs on {robots} robots at once':<48}{many:>7.2f} s   target 10 s "
          + ("ok" if many <= 10 else "MISSED"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--robots", type=int, default=20)
    asyncio.run(main_async(parser.parse_args().robots))


if __name__ == "__main__":
    main()
