"""Benchmark: a plant's procedure jobs on one PostgreSQL shared by two services, against one
service on SQLite (issue 28).

    .venv/bin/python benchmarks/plant.py [--robots 20] [--rounds 3] [--cycles 5] [--poses 40]
                                         [--pg-services 2] [--no-kill]

N emulated cells (time scale 0, in this process) each run one procedure job at once (home
check, performance before, calibration, estimation, compensation, performance after), driven by
`screwcal serve` processes: one on a SQLite file, then two on one PostgreSQL database (a real
server, started like the tests' one: tests/postgres_server.py), the robots' jobs posted half to
each. The two set-ups alternate for `--rounds` rounds; each line gives the median wall time
from the first POST to the last job done, and their ratio (target <= 1.2). Then one round with
the first PostgreSQL service SIGKILLed mid-job: the other resumes its jobs after the lease;
counted from the databases' rows: jobs done, committed poses lost (a row before the kill gone
or replaced), poses measured twice (a (job, phase, idx) stored twice, or a row committed before
the kill measured again), the plan's poses missing at the end (targets: all done, 0, 0, 0).
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import asyncio
import contextlib
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
from cells import Cells  # the benchmarks' own emulated cells

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' PostgreSQL server
from tests.postgres_server import INSTALL, PostgresServer, find_bin_dir

TOKEN = "bench"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
LEASE_S = 2.0


class Service:
    """`screwcal serve` in its own process."""

    def __init__(self, db: str, instance: str):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "screwcal", "serve", "--db", db, "--port", "0", "--token",
             TOKEN], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env={**os.environ, "SCREWCAL_LEASE_S": str(LEASE_S), "SCREWCAL_INSTANCE": instance})
        line = self.proc.stdout.readline()  # type: ignore[union-attr]
        m = re.search(r"http://[\d.]+:\d+", line)
        if not m:
            raise RuntimeError(line + self.proc.stderr.read())  # type: ignore[union-attr]
        self.url = m.group(0)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        self.proc.communicate(timeout=60)

    def kill(self) -> None:
        self.proc.send_signal(signal.SIGKILL)
        self.proc.communicate(timeout=60)


def rows(db: str, sql: str) -> list[tuple]:
    if db.startswith("postgresql://"):
        import psycopg

        with psycopg.connect(db) as con:
            return [tuple(r) for r in con.execute(sql).fetchall()]
    import sqlite3

    con = sqlite3.connect(db)
    try:
        return con.execute(sql).fetchall()
    finally:
        con.close()


async def run_plant(db: str, n_services: int, n_robots: int, options: dict,
                    kill_after_poses: int | None = None) -> dict:
    """Post one procedure job per cell, spread over the services; wait for all. Returns the
    wall time and, when a service is killed, what the rows say."""
    services = [Service(db, f"S{k}") for k in range(n_services)]
    cells = Cells()
    plant = await cells.start(n_robots)
    https = [httpx.AsyncClient(base_url=s.url, headers=AUTH, timeout=60) for s in services]
    out: dict = {}
    try:
        jobs = []
        for k, (host, port, arm) in enumerate(plant):
            http = https[k % n_services]
            r = await http.post("/robots", json={"name": f"cell {k}", "controller_host": host,
                                                 "controller_port": port, "arm_url": arm})
            assert r.status_code == 201, r.text
            jobs.append((http, r.json()["id"]))
        start = time.perf_counter()

        async def post(http: httpx.AsyncClient, robot: int) -> int:
            r = await http.post("/jobs", json={"robot_id": robot, "kind": "procedure",
                                               "options": options})
            assert r.status_code == 202, r.text
            return int(r.json()["id"])

        # all at once: each service plans the jobs posted to it (2 at a time) as they come
        ids = await asyncio.gather(*(post(http, robot) for http, robot in jobs))
        live = https
        if kill_after_poses is not None:
            def count() -> int:
                return int(rows(db, "SELECT count(*) FROM measurements")[0][0])

            while await asyncio.to_thread(count) < kill_after_poses:
                await asyncio.sleep(0.05)
            services[0].kill()
            out["killed_at"] = time.perf_counter() - start
            out["before"] = {(j, p, i): mid for j, p, i, mid in rows(
                db, "SELECT job_id, phase, idx, id FROM measurements")}
            out["orphaned"] = len(rows(db, "SELECT id FROM jobs WHERE holder = 'S0' AND state "
                                           "IN ('queued', 'running', 'paused')"))
            live = https[1:]
        pending = set(ids)
        while pending:
            for job_id in list(pending):
                job = (await live[0].get(f"/jobs/{job_id}")).json()
                if job["state"] in ("done", "failed", "aborted"):
                    pending.discard(job_id)
                    out.setdefault("states", []).append(job["state"])
            await asyncio.sleep(0.02)
        out["wall_s"] = time.perf_counter() - start
        if kill_after_poses is not None:
            after = rows(db, "SELECT job_id, phase, idx, id FROM measurements")
            keys = [(j, p, i) for j, p, i, _ in after]
            now = {(j, p, i): mid for j, p, i, mid in after}
            out["twice"] = len(keys) - len(set(keys)) + sum(
                now.get(k) != mid for k, mid in out["before"].items() if k in now)
            out["lost"] = sum(k not in now for k in out["before"])
            per_job = {}
            for j, p, _i in keys:
                per_job.setdefault(j, {}).setdefault(p, 0)
                per_job[j][p] += 1
            counts = {tuple(sorted(v.items())) for v in per_job.values()}
            out["uniform"] = len(counts) == 1  # every job measured the same plan in full
            out["poses"] = len(keys)
    finally:
        for http in https:
            await http.aclose()
        for s in services:
            with contextlib.suppress(Exception):
                s.stop()
        await cells.stop()
    return out


def spread(times: list[float]) -> str:
    return f"{statistics.median(times):7.2f} s ({min(times):.2f}-{max(times):.2f}, " \
           f"{len(times)} runs)"


async def main_async(args: argparse.Namespace) -> None:
    bin_dir = find_bin_dir()
    if bin_dir is None:
        sys.exit(f"no PostgreSQL server binaries: install them with `{INSTALL}`")
    options = {"calibration_poses": args.poses, "cycles": args.cycles}
    server = PostgresServer(bin_dir)
    server.start()
    try:
        with tempfile.TemporaryDirectory() as tmp:
            sqlite_s, pg_s, ratios = [], [], []
            for k in range(args.rounds):
                a = await run_plant(str(Path(tmp) / f"plant{k}.db"), 1, args.robots, options)
                b = await run_plant(server.new_database(), args.pg_services, args.robots,
                                    options)
                assert set(a["states"]) == set(b["states"]) == {"done"}, (a, b)
                sqlite_s.append(a["wall_s"])
                pg_s.append(b["wall_s"])
                ratios.append(b["wall_s"] / a["wall_s"])
            print(f"{args.robots} procedure jobs, 1 service on SQLite      {spread(sqlite_s)}")
            print(f"{args.robots} procedure jobs, {args.pg_services} service(s) on PostgreSQL "
                  f"{spread(pg_s)}")
            med = statistics.median(ratios)
            print(f"ratio PostgreSQL/SQLite (per interleaved pair): median {med:.2f} "
                  f"({min(ratios):.2f}-{max(ratios):.2f})   target <= 1.2 "
                  + ("ok" if med <= 1.2 else "MISSED"))
        if args.no_kill:
            return
        killed = await run_plant(server.new_database(), 2, args.robots, options,
                                 kill_after_poses=args.robots * args.poses // 2)
        done = killed["states"].count("done")
        print(f"one of 2 services SIGKILLed at {killed['killed_at']:.1f} s "
              f"({len(killed['before'])} poses committed, {killed['orphaned']} of its jobs "
              f"unfinished): {done}/{args.robots} jobs done in "
              f"{killed['wall_s']:.1f} s (lease {LEASE_S:g} s), {killed['lost']} poses lost, "
              f"{killed['twice']} measured twice, every job's plan complete: "
              f"{killed['uniform']} ({killed['poses']} poses)")
    finally:
        server.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cycles", type=int, default=5, help="ISO 9283 cycles per list")
    parser.add_argument("--poses", type=int, default=40, help="calibration poses")
    parser.add_argument("--pg-services", type=int, default=2,
                        help="services on the PostgreSQL database (1: the database's own cost)")
    parser.add_argument("--no-kill", action="store_true", help="skip the SIGKILL round")
    args = parser.parse_args()
    if args.robots < 2 or args.rounds < 1 or args.pg_services < 1:
        parser.error("--robots must be at least 2, --rounds and --pg-services at least 1")
    asyncio.run(main_async(args))


if __name__ == "__main__":
    main()
