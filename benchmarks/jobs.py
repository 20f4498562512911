"""Benchmark: calibration jobs through the REST API against emulated robots at time scale 0.

    .venv/bin/python benchmarks/jobs.py [--robots 20] [--rounds 10] [--hogs 2]
                                        [--cells-in-process]

One 40-pose calibration job from the REST call to its result, then N such jobs on N emulated
robots at once (one service), alternated for `--rounds` rounds; the median with min and max of
each (one run hides how much the figure depends on what else the host runs). With `--hogs K`,
each round's N jobs run twice, alone and beside K CPU-bound processes (`while True: pass`,
started before the jobs are posted, ended after), and the ratio of each pair is reported.

The work each side does. The service under test (this process: the REST app, its job runners
and SQLite store, called in process through ASGI): per job it builds the 40-pose calibration
list, connects to the controller and the arm, loads the list, runs it, receives each pose's
joints and the arm's three points, stores every measurement (SQLite, synchronous=FULL), then
identifies the model with the job's defaults (`full` error model, compliance and lag `auto`,
outlier rounds) and stores the result. The cells (by default one child process,
benchmarks/cells.py, as a plant's controllers are machines of their own; `--cells-in-process`
runs them in this process, competing for its interpreter lock as before): per cell the shipped
RAPID module (protocol/rapid/ScrewcalServer.mod) executed by the RAPID interpreter in a thread,
reading and checking every 80-byte request, moving the emulated robot, answering each pose,
and the arm emulator computing the true robot's forward kinematics and its noisy points. The
benchmark itself posts the jobs and asks one unfinished job's state every 0.1 s (in the order
they were posted), then fetches its result: about a hundred requests in ten seconds, where
asking every pending job every 5 ms made the service answer thousands; the figure ends at most
0.1 s after the last job did.

Reported: the wall seconds, and the CPU seconds over wall seconds of the service's process and
of the cells' process (above 1: more than one core). Targets (issues 7, 29): <= 2 s for one,
<= 10 s for twenty; beside two hogs <= 10 s and within 1.5x of the quiet figure.
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
from cells import Cell, Cells  # the cells' own script, beside this one

from service.app import create_app
from service.settings import ServiceSettings

TOKEN = "bench"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
POLL_S = 0.1  # how often the benchmark asks an unfinished job's state
_names = itertools.count(1)  # robot names are unique in a service


class ChildCells:
    """The cells in a child process (benchmarks/cells.py), driven over its stdin and stdout."""

    def __init__(self) -> None:
        self._proc: asyncio.subprocess.Process | None = None

    async def _ask(self, command: str) -> Any:
        if self._proc is None:
            self._proc = await asyncio.create_subprocess_exec(
                sys.executable, str(Path(__file__).with_name("cells.py")),
                stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE)
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._proc.stdin.write(f"{command}\n".encode())
        await self._proc.stdin.drain()
        line = await self._proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the cells' process ended (exit {await self._proc.wait()})")
        answer = json.loads(line)
        if isinstance(answer, dict) and "error" in answer:
            raise RuntimeError(answer["error"])
        return answer

    async def start(self, n: int) -> list[Cell]:
        return [(host, port, arm) for host, port, arm in await self._ask(f"start {n}")]

    async def stop(self) -> None:
        await self._ask("stop")

    async def cpu(self) -> float | None:
        return float(await self._ask("cpu"))

    async def close(self) -> None:
        if self._proc is not None:
            assert self._proc.stdin is not None
            self._proc.stdin.close()
            await self._proc.wait()


class InProcessCells(Cells):
    """The cells in this process: their CPU is in the service's figure."""

    async def cpu(self) -> float | None:
        return None

    async def close(self) -> None:
        await self.stop()


@dataclass(frozen=True)
class Run:
    wall: float  # s, from the first post to the last result
    service_cpu: float  # s, this process
    cells_cpu: float | None  # s, the cells' process (None: they ran in this process)


async def run_jobs(http: httpx.AsyncClient, cells: ChildCells | InProcessCells, n: int,
                   hogs: int = 0) -> Run:
    """n jobs at once on n new cells, beside `hogs` CPU-bound processes."""
    robots = []
    for host, port, arm in await cells.start(n):
        r = await http.post("/robots", headers=AUTH, json={
            "name": f"bench-{next(_names)}", "controller_host": host, "controller_port": port,
            "arm_url": arm})
        assert r.status_code == 201, r.text
        robots.append(r.json()["id"])
    spinning = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(hogs)]
    await asyncio.sleep(0.2 if hogs else 0.0)  # the hogs up and spinning
    cells_cpu = await cells.cpu()
    start, cpu = time.perf_counter(), time.process_time()
    ids = [(await http.post("/jobs", headers=AUTH, json={
        "robot_id": rid, "kind": "calibration", "options": {"calibration_poses": 40}})).json()[
        "id"] for rid in robots]
    for job_id in ids:  # the first unfinished one, then the next: one request per POLL_S
        while (await http.get(f"/jobs/{job_id}")).json()["state"] not in (
                "done", "failed", "aborted"):
            await asyncio.sleep(POLL_S)
        result = (await http.get(f"/jobs/{job_id}/result")).json()
        assert result["state"] == "done", result.get("reason")
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    after = await cells.cpu()
    for hog in spinning:
        hog.kill()
        hog.wait()
    await cells.stop()
    return Run(elapsed, cpu, None if cells_cpu is None or after is None else after - cells_cpu)


def spread(label: str, times: list[float], target: float) -> str:
    """One line: median (min-max, rounds) against the target."""
    med = statistics.median(times)
    return (f"{label:<48}{med:>7.2f} s  ({min(times):.2f}-{max(times):.2f}, {len(times)} runs)"
            f"   target {target:g} s " + ("ok" if med <= target else "MISSED"))


def cpu_share(runs: list[Run]) -> str:
    """The median CPU over wall seconds of the service, and of the cells in their process."""
    text = f"; CPU/wall service {statistics.median(r.service_cpu / r.wall for r in runs):.2f}"
    if runs[0].cells_cpu is None:
        return text + " (cells included)"
    cells = statistics.median((r.cells_cpu or 0.0) / r.wall for r in runs)
    return text + f", cells {cells:.2f}"


async def main_async(robots: int, rounds: int, hogs: int, in_process: bool) -> None:
    ones: list[Run] = []
    manys: list[Run] = []
    loaded: list[Run] = []
    cells = InProcessCells() if in_process else ChildCells()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            app = create_app(ServiceSettings(db_path=Path(tmp) / "bench.db", token=TOKEN))
            async with app.router.lifespan_context(app):
                async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                             base_url="http://service", headers=AUTH) as http:
                    for _ in range(rounds):
                        ones.append(await run_jobs(http, cells, 1))
                        manys.append(await run_jobs(http, cells, robots))
                        if hogs:
                            loaded.append(await run_jobs(http, cells, robots, hogs))
    finally:
        await cells.close()
    print(spread("one 40-pose calibration job, REST to result", [r.wall for r in ones], 2))
    print(spread(f"{robots} such jobs on {robots} robots at once", [r.wall for r in manys], 10)
          + cpu_share(manys))
    if hogs:
        print(spread(f"the same beside {hogs} CPU-bound processes", [r.wall for r in loaded],
                     10) + cpu_share(loaded))
        ratios = [b.wall / a.wall for a, b in zip(manys, loaded, strict=True)]
        med = statistics.median(ratios)
        print(f"{'beside them / alone, pair by pair':<48}{med:>7.2f}x ({min(ratios):.2f}-"
              f"{max(ratios):.2f})   target 1.5x " + ("ok" if med <= 1.5 else "MISSED"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("--hogs", type=int, default=0,
                        help="also run each round beside this many CPU-bound processes")
    parser.add_argument("--cells-in-process", action="store_true",
                        help="run the emulated cells in the service's process (the old "
                             "arrangement; default: one child process hosts them)")
    args = parser.parse_args()
    if args.robots < 1 or args.rounds < 1 or args.hogs < 0:
        parser.error("--robots and --rounds must be at least 1, --hogs at least 0")
    asyncio.run(main_async(args.robots, args.rounds, args.hogs, args.cells_in_process))


if __name__ == "__main__":
    main()
