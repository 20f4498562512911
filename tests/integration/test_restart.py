"""The service killed with SIGKILL mid-job and restarted resumes the job: every committed
measurement kept, none measured twice; on SQLite and on PostgreSQL."""

import asyncio
import os
import re
import signal
import subprocess
import sys

import httpx
import pytest

from tests.integration.conftest import FAST, TOKEN, peek

AUTH = {"Authorization": f"Bearer {TOKEN}"}


def start_service(db, lease_s: float = 1.0, instance: str = ""):
    """`screwcal serve` on this database (a file or a URL), its jobs held by lease_s leases
    under the name `instance` (default: host:pid:random)."""
    proc = subprocess.Popen([sys.executable, "-m", "screwcal", "serve", "--db", str(db),
                             "--port", "0", "--token", TOKEN], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "SCREWCAL_LEASE_S": str(lease_s),
                                 "SCREWCAL_INSTANCE": instance})
    line = proc.stdout.readline()
    m = re.search(r"http://[\d.]+:\d+", line)
    assert m, line + proc.stderr.read()
    return proc, m.group(0)


def committed(db, job_id, phase="cal"):
    return {r[0]: r[1] for r in peek(
        db, "SELECT idx, id FROM measurements WHERE job_id = ? AND phase = ?", (job_id, phase))}


@pytest.mark.slow
async def test_sigkill_mid_job_then_restart_resumes_without_loss(db_target, rig):
    rig.emu.settings.time_scale = 0.02  # slow enough to be killed mid-list
    db = db_target  # on PostgreSQL the restarted service (a new holder) waits out the lease
    proc, url = start_service(db)
    try:
        async with httpx.AsyncClient(base_url=url, headers=AUTH) as http:
            host, port = rig.address
            robot = (await http.post("/robots", headers=AUTH, json={
                "name": "cell", "controller_host": host, "controller_port": port,
                "arm_url": rig.arm.url})).json()["id"]
            job_id = (await http.post("/jobs", headers=AUTH, json={
                "robot_id": robot, "kind": "calibration", "options": {
                    **FAST, "drift_poses": 2, "drift_period_poses": 5}})).json()["id"]
            async with asyncio.timeout(30):
                while len(committed(db, job_id)) < 8:
                    await asyncio.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=10)
        rig.emu.settings.time_scale = 0.0  # killed mid-list: the rest of it at full speed
        before = committed(db, job_id)
        references = committed(db, job_id, "drift")  # the drift checks' reference poses
        assert len(references) >= 4
        assert 8 <= len(before) < 30
        proc, url = start_service(db)
        async with httpx.AsyncClient(base_url=url, headers=AUTH) as http:
            async with asyncio.timeout(60):
                while (job := (await http.get(f"/jobs/{job_id}")).json())["state"] not in (
                        "done", "failed"):
                    await asyncio.sleep(0.05)
        assert job["state"] == "done", job["reason"]
        after = committed(db, job_id)
        assert sorted(after) == list(range(30))  # each pose once (UNIQUE would refuse twice)
        assert all(after[k] == before[k] for k in before)  # the same rows: nothing re-measured
        # the reference poses too: checks at 0, 5, ... 30 poses (4 poses each), each once
        drift_after = committed(db, job_id, "drift")
        assert sorted(drift_after) == list(range(4 * 7))
        assert all(drift_after[k] == references[k] for k in references)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=10)
