"""Several service processes on one PostgreSQL database (issue 28, point 3): each job is held by
one service's lease; a second service can neither start a job on a robot another runs nor take
the job over while its holder lives; when the holder is SIGKILLed mid-job, another service
resumes its job after the lease, at the pose it waits for: every committed pose kept, none
measured twice."""

import asyncio
import contextlib
import signal

import httpx
import pytest

from tests.integration.conftest import FAST, TOKEN, peek, start_rig, stop_rig
from tests.integration.test_restart import committed, start_service

AUTH = {"Authorization": f"Bearer {TOKEN}"}
LEASE_S = 1.0


async def add_robot(http, rig, name: str) -> int:
    host, port = rig.address
    r = await http.post("/robots", json={"name": name, "controller_host": host,
                                         "controller_port": port, "arm_url": rig.arm.url})
    assert r.status_code == 201, r.text
    return r.json()["id"]


def holder(db, job_id) -> str:
    return peek(db, "SELECT holder FROM jobs WHERE id = ?", (job_id,))[0][0]


async def state_of(http, job_id, until=("done", "failed", "aborted"), timeout_s=90) -> dict:
    async with asyncio.timeout(timeout_s):
        while (job := (await http.get(f"/jobs/{job_id}")).json())["state"] not in until:
            await asyncio.sleep(0.05)
    return job


def stop(proc) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=30)


@pytest.mark.slow
async def test_two_services_share_a_database_and_one_resumes_the_others_jobs(postgres_server):
    db = postgres_server.new_database()
    cells = [await start_rig(time_scale=0.05) for _ in range(2)]
    a, url_a = start_service(db, LEASE_S, instance="A")
    b, url_b = start_service(db, LEASE_S, instance="B")
    try:
        async with httpx.AsyncClient(base_url=url_a, headers=AUTH) as http_a, \
                httpx.AsyncClient(base_url=url_b, headers=AUTH) as http_b:
            robots = [await add_robot(http_a, cells[0], "cell 1"),
                      await add_robot(http_b, cells[1], "cell 2")]
            assert [r["id"] for r in (await http_b.get("/robots")).json()] == robots
            jobs = [(await http.post("/jobs", json={"robot_id": robot, "kind": "calibration",
                                                    "options": FAST})).json()["id"]
                    for http, robot in ((http_a, robots[0]), (http_b, robots[1]))]
            assert [holder(db, j) for j in jobs] == ["A", "B"]
            # B can neither start a second job on A's robot nor act on A's job
            again = await http_b.post("/jobs", json={"robot_id": robots[0],
                                                     "kind": "calibration", "options": FAST})
            assert again.status_code == 409 and f"job {jobs[0]}" in again.json()["detail"]
            abort = await http_b.post(f"/jobs/{jobs[0]}/abort")
            assert abort.status_code == 409 and "another service (A)" in abort.json()["detail"]
            async with asyncio.timeout(60):
                while len(committed(db, jobs[0])) < 5:
                    await asyncio.sleep(0.02)
            await asyncio.sleep(1.5 * LEASE_S)  # renewals: A keeps its job, B its own
            assert [holder(db, j) for j in jobs] == ["A", "B"]
            a.send_signal(signal.SIGKILL)  # mid-list
            a.communicate(timeout=10)
            for cell in cells:  # the rest of both lists at full speed
                cell.emu.settings.time_scale = 0.0
            before = committed(db, jobs[0])
            assert 5 <= len(before) < 30
            done = [await state_of(http_b, j) for j in jobs]
            assert [j["state"] for j in done] == ["done", "done"], [j["reason"] for j in done]
            assert [holder(db, j) for j in jobs] == ["B", "B"]  # B took A's job over
            after = committed(db, jobs[0])
            assert sorted(after) == list(range(30))  # each pose once
            assert all(after[k] == before[k] for k in before)  # the same rows: none re-measured
            assert sorted(committed(db, jobs[1])) == list(range(30))
    finally:
        for proc in (a, b):
            with contextlib.suppress(Exception):
                stop(proc)
        for cell in cells:
            await stop_rig(cell)
