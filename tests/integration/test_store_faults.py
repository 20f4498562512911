"""Faults of the job store mid-job pause the job with their cause, and it goes on where it stopped
once the store is back (issue 44): a SQLite file that cannot grow (a file-size limit, ulimit -f:
"disk I/O error"), lifted in place or by a restart without the limit; a PostgreSQL server
restarted under a running service, which reconnects by itself."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from service.store import Store
from tests.integration.conftest import FAST, TOKEN, peek
from tests.integration.test_restart import committed, start_service

AUTH = {"Authorization": f"Bearer {TOKEN}"}
WAL_ROOM = 96 * 1024  # what the limited service may write: some poses' commits in the WAL


def limited_service(db: Path, limit_bytes: int) -> tuple[subprocess.Popen, str]:
    """`screwcal serve` whose files cannot grow beyond `limit_bytes` (RLIMIT_FSIZE's soft limit;
    the write fails with EFBIG, Python ignores SIGXFSZ)."""
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, resource.RLIM_INFINITY))

    proc = subprocess.Popen([sys.executable, "-m", "screwcal", "serve", "--db", str(db),
                             "--port", "0", "--token", TOKEN], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=limit,
                            env={**os.environ, "SCREWCAL_RECONNECT_INTERVAL_S": "0.1"})
    assert proc.stdout is not None and proc.stderr is not None
    line = proc.stdout.readline()
    assert "http://" in line, line + proc.stderr.read()
    return proc, line.split("http://", 1)[1].split()[0].rstrip(")")


def robot_record(rig) -> dict:
    host, port = rig.address
    return {"name": "cell", "controller_host": host, "controller_port": port,
            "arm_url": rig.arm.url}


async def paused_with_cause(http: httpx.AsyncClient, job_id: int, timeout_s: float = 60) -> dict:
    async with asyncio.timeout(timeout_s):
        while (job := (await http.get(f"/jobs/{job_id}")).json())["state"] != "paused":
            assert job["state"] in ("queued", "running"), job
            await asyncio.sleep(0.05)
    return job


async def until_done(http: httpx.AsyncClient, job_id: int, timeout_s: float = 120) -> dict:
    async with asyncio.timeout(timeout_s):
        while (job := (await http.get(f"/jobs/{job_id}")).json())["state"] not in (
                "done", "failed", "aborted"):
            await asyncio.sleep(0.05)
    return job


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        proc.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()


@pytest.mark.slow
@pytest.mark.parametrize("back_by", ["restart without the limit", "limit lifted in place"])
async def test_a_database_file_that_cannot_grow_pauses_the_job_until_it_can(tmp_path, rig,
                                                                             back_by):
    db = tmp_path / "jobs.db"
    Store(db).close()  # created and migrated: the limit leaves room for the job's commits
    rig.emu.settings.time_scale = 0.02
    proc, url = limited_service(db, os.path.getsize(db) + WAL_ROOM)
    try:
        async with httpx.AsyncClient(base_url=f"http://{url}", headers=AUTH,
                                     timeout=30) as http:
            robot = (await http.post("/robots", json=robot_record(rig))).json()["id"]
            job_id = (await http.post("/jobs", json={
                "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
            job = await paused_with_cause(http, job_id)
            assert "disk I/O error" in job["reason"] and "file-size limit" in job["reason"], job
            held = committed(db, job_id)
            assert 1 <= len(held) < FAST["calibration_poses"], held
            await asyncio.sleep(0.5)  # the robot waits at the pose: nothing measured, nothing lost
            assert committed(db, job_id) == held
            rig.emu.settings.time_scale = 0.0  # paused mid-list: the rest of it at full speed
            if back_by == "limit lifted in place":
                resource.prlimit(proc.pid, resource.RLIMIT_FSIZE,
                                 (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
                job = await until_done(http, job_id)
        if back_by == "restart without the limit":
            stop(proc)
            proc, url = start_service(db)
            async with httpx.AsyncClient(base_url=url, headers=AUTH, timeout=30) as http:
                job = await until_done(http, job_id)
        assert job["state"] == "done", job["reason"]
        after = committed(db, job_id)
        assert sorted(after) == list(range(FAST["calibration_poses"]))  # every pose, once
        assert all(after[k] == held[k] for k in held)  # the rows of before: none measured anew
    finally:
        stop(proc)


@pytest.mark.slow
async def test_a_postgresql_server_restarted_mid_job_pauses_it_and_the_service_goes_on(rig):
    from tests.postgres_server import INSTALL, PostgresServer, find_bin_dir

    bin_dir = find_bin_dir()
    if bin_dir is None:
        pytest.skip(f"no PostgreSQL server: install it with `{INSTALL}`")
    server = PostgresServer(bin_dir)  # its own: restarted under the service
    server.start()
    proc = None
    try:
        db = server.new_database()
        rig.emu.settings.time_scale = 0.05
        proc, url = start_service(db, lease_s=5.0)
        async with httpx.AsyncClient(base_url=url, headers=AUTH, timeout=30) as http:
            robot = (await http.post("/robots", json=robot_record(rig))).json()["id"]
            job_id = (await http.post("/jobs", json={
                "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
            events: list[dict] = []
            following = asyncio.create_task(follow(http, job_id, events))
            async with asyncio.timeout(60):
                while len(committed(db, job_id)) < 5:
                    await asyncio.sleep(0.02)
            server.halt()  # the server goes away (immediate stop: connections cut)
            async with asyncio.timeout(30):
                while not any(e["kind"] == "paused" for e in events):
                    await asyncio.sleep(0.05)
            paused = next(e for e in events if e["kind"] == "paused")
            assert "connection to the database" in paused["reason"] or \
                "cannot reach the database" in paused["reason"], paused
            r = await http.get(f"/jobs/{job_id}")  # a request meanwhile: 503, with the cause
            assert r.status_code == 503 and "database" in r.json()["detail"], r.text
            await asyncio.sleep(1.0)
            rig.emu.settings.time_scale = 0.0  # paused mid-list: the rest of it at full speed
            server.resume()  # the same server back, on the same socket
            job = await until_done(http, job_id)
            assert job["state"] == "done", job["reason"]
            assert proc.poll() is None  # the same service, never restarted
            await asyncio.wait_for(following, 30)
        kinds = [e["kind"] for e in events]
        assert "resumed" in kinds[kinds.index("paused"):] and kinds[-1] == "end", kinds
        after = committed(db, job_id)
        assert sorted(after) == list(range(FAST["calibration_poses"]))  # every pose, once
        kinds = [r[0] for r in peek(db, "SELECT state FROM jobs WHERE id = ?", (job_id,))]
        assert kinds == ["done"]
    finally:
        if proc is not None:
            stop(proc)
        with contextlib.suppress(RuntimeError):  # (halted for good by a failure above)
            server.stop()


async def follow(http: httpx.AsyncClient, job_id: int, events: list[dict]) -> None:
    """The job's event stream, into `events`, until its end."""
    async with http.stream("GET", f"/jobs/{job_id}/events", timeout=None) as stream:
        async for line in stream.aiter_lines():
            if line.startswith("data: "):
                events.append(json.loads(line[6:]))
