"""A lost link pauses the job and it resumes from the next unmeasured pose."""

import asyncio

from tests.integration.conftest import AUTH, FAST, add_robot
from tests.integration.test_jobs import wait_state


async def test_a_dropped_controller_link_pauses_and_resumes_without_loss(service, rig):
    rig.emu.settings.faults.drop_at_pose = 9  # once, while the calibration list runs
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
    states = set()
    async with asyncio.timeout(30):
        while (job := (await service.get(f"/jobs/{job_id}")).json())["state"] not in (
                "done", "failed"):
            states.add(job["state"])
            if job["state"] == "paused":
                assert "LinkLostError" in job["reason"]
            await asyncio.sleep(0.005)
    assert job["state"] == "done", job["reason"]
    measured = (await service.get(f"/jobs/{job_id}/measurements")).json()
    assert sorted(m["idx"] for m in measured) == list(range(30))  # none lost, none twice
    assert rig.emu.sessions >= 2  # it did reconnect


async def test_a_dead_arm_pauses_the_job_until_it_is_back(service, rig):
    robot = await add_robot(service, rig)
    host, port = rig.arm.url.removeprefix("socket://").split(":")
    await rig.arm.stop()
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
    async with asyncio.timeout(10):
        while (job := (await service.get(f"/jobs/{job_id}")).json())["state"] != "paused":
            await asyncio.sleep(0.01)
    assert job["reason"]  # says why
    await rig.arm.start(host, int(port))
    job = await wait_state(service, job_id, timeout_s=30)
    assert job["state"] == "done", job["reason"]
    assert len((await service.get(f"/jobs/{job_id}/measurements")).json()) == 30


async def _run_with(service, rig, fault) -> dict:
    """A calibration job with `fault` done to it after a few poses: it must end done, every
    pose measured once."""
    rig.emu.settings.time_scale = 0.02
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
    async with asyncio.timeout(30):
        while len((await service.get(f"/jobs/{job_id}/measurements")).json()) < 5:
            await asyncio.sleep(0.01)
    await fault()
    rig.emu.settings.time_scale = 0.0  # done mid-list: the rest of it at full speed
    job = await wait_state(service, job_id, timeout_s=60)
    assert job["state"] == "done", job["reason"]
    measured = (await service.get(f"/jobs/{job_id}/measurements")).json()
    assert sorted(m["idx"] for m in measured) == list(range(30))  # none lost, none twice
    return job


async def test_the_controller_emulator_restarted_alone_mid_list(service, rig):
    await _run_with(service, rig, rig.restart_controller)


async def test_the_arm_restarted_alone_mid_list(service, rig):
    host, port = rig.arm.url.removeprefix("socket://").split(":")

    async def restart_arm() -> None:
        await rig.arm.stop()
        await asyncio.sleep(0.2)
        await rig.arm.start(host, int(port))

    await _run_with(service, rig, restart_arm)


async def test_reference_poses_of_a_dropped_link_are_measured_once(service, rig):
    """The link drops inside the job's first drift check (its pose 2): the check is completed
    after the reconnection from the store, each reference pose committed once, none lost."""
    rig.emu.settings.faults.drop_at_pose = 2  # the first list sent is the first drift check
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": {
            **FAST, "drift_poses": 2, "drift_period_poses": 10}})).json()["id"]
    job = await wait_state(service, job_id, timeout_s=30)
    assert job["state"] == "done", job["reason"]
    assert rig.emu.sessions >= 2  # it did reconnect
    measured = (await service.get(f"/jobs/{job_id}/measurements")).json()
    cal = sorted(m["idx"] for m in measured if m["phase"] == "cal")
    drift = sorted(m["idx"] for m in measured if m["phase"] == "drift")
    assert cal == list(range(30))
    # checks at the start, after 10 and 20 poses and after the list: 4 x (approach, reference) x 2
    assert drift == list(range(16))
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    assert result["drift"]["poses_before"] == [0, 10, 20, 30]
