"""A laser tracker as the job's instrument: the robot record names it (emScon host and port,
its SMRs, where it stands), the job's lists are planned for its beam, and the runner asks it for
each pose's measurement through the same acquisition as the arm's: the emulated IRC5 and the
emulated tracker (real TCP, emScon TPI) around one true robot, the service through httpx.

The fault suite, as the arm's (test_faults.py): beam broken, connection lost, tracker not
initialised, each mid-job: the job pauses, resumes, and every pose is measured once."""

from __future__ import annotations

import asyncio
import contextlib

import numpy as np
import pytest

from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM
from screwcal.instrument import TRACKER_STAND_MM
from simulators.tracker import TrackerEmulator, TrackerFaults, WorldSource
from tests.integration.conftest import AUTH, start_rig, stop_rig
from tests.integration.test_jobs import wait_state

POSES = 24
CAL = {"calibration_poses": POSES, "cycles": 2, "cube_edge_mm": 250.0}


class TrackerRig:
    """The IRC5 emulator and an emulated tracker (its faults injectable) on one true robot."""

    def __init__(self, rig, tracker: TrackerEmulator, address: tuple[str, int]):
        self.rig, self.tracker, self.address = rig, tracker, address

    async def restart_tracker(self) -> None:
        await self.tracker.stop()
        await asyncio.sleep(0.2)
        await self.tracker.start(*self.address)


async def start_tracker_rig(faults: str = "", realism=None) -> TrackerRig:
    rig = await start_rig() if realism is None else await start_rig(realism=realism)
    tracker = TrackerEmulator(WorldSource(rig.world), TRACKER_STAND_MM, seed=7,
                              faults=TrackerFaults.parse(faults) if faults else None,
                              initialise_s=0.0, measure_s=0.0)
    address = await tracker.start("127.0.0.1", 0)
    return TrackerRig(rig, tracker, address)


@pytest.fixture
async def cell():
    made: list[TrackerRig] = []

    async def make(faults: str = "") -> TrackerRig:
        made.append(await start_tracker_rig(faults))
        return made[-1]

    yield make
    for c in made:
        with contextlib.suppress(Exception):
            await c.tracker.stop()
        await stop_rig(c.rig)


async def add_tracker_robot(http, cell: TrackerRig, **instrument) -> int:
    host, port = cell.rig.address
    r = await http.post("/robots", headers=AUTH, json={
        "name": "IRB 1600 (emulated), tracker", "controller_host": host,
        "controller_port": port, "instrument": {
            "kind": "tracker", "host": cell.address[0], "port": cell.address[1],
            "stand_mm": list(TRACKER_STAND_MM), **instrument}})
    assert r.status_code == 201, r.text
    return r.json()["id"]


async def calibrate(service, robot: int, timeout_s: float = 90.0) -> tuple[dict, list[dict]]:
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": CAL})).json()["id"]
    job = await wait_state(service, job_id, timeout_s=timeout_s)
    return job, (await service.get(f"/jobs/{job_id}/measurements")).json()


async def test_a_tracker_job_measures_each_pose_with_its_covariance_and_weather(service, cell):
    c = await cell()
    robot = await add_tracker_robot(service, c)
    record = (await service.get(f"/robots/{robot}")).json()
    assert record["instrument"]["kind"] == "tracker" and record["arm_url"] == ""
    job, measured = await calibrate(service, robot)
    assert job["state"] == "done", job["reason"]
    assert sorted(m["idx"] for m in measured) == list(range(POSES))
    for m in measured:
        assert len(m["holes_mm"]) == 1 and m["flange_pose"] == []  # one SMR: positions
        cov = np.array(m["covariance_mm2"][0])
        assert cov.shape == (3, 3) and np.all(np.linalg.eigvalsh(cov) > 0)
        assert 15 < m["conditions"]["temperature_c"] < 30
        assert abs(m["measured_at"] - m["created"]) < 5
    result = (await service.get(f"/jobs/{job['id']}/result")).json()
    assert result["estimation"]["residual_after_mm"] < 0.05


async def test_a_tracker_that_cannot_see_the_list_is_refused_when_the_job_is_posted(service,
                                                                                   cell):
    c = await cell()
    robot = await add_tracker_robot(service, c, stand_mm=[-3000.0, 0.0, 900.0])  # behind it
    r = await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "performance", "options": CAL})
    assert r.status_code == 422 and "does not see" in r.json()["detail"], r.text


__all__ = ["DEFAULT_SMR_MM"]
