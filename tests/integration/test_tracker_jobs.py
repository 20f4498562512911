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

from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM, THREE_SMRS_MM
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


async def start_tracker_rig(faults: str = "", smrs_mm=(DEFAULT_SMR_MM,)) -> TrackerRig:
    rig = await start_rig()
    tracker = TrackerEmulator(WorldSource(rig.world, tuple(smrs_mm)), TRACKER_STAND_MM, seed=7,
                              faults=TrackerFaults.parse(faults) if faults else None,
                              initialise_s=0.0, measure_s=0.0)
    address = await tracker.start("127.0.0.1", 0)
    return TrackerRig(rig, tracker, address)


@pytest.fixture
async def cell():
    made: list[TrackerRig] = []

    async def make(faults: str = "", smrs_mm=(DEFAULT_SMR_MM,)) -> TrackerRig:
        made.append(await start_tracker_rig(faults, smrs_mm))
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


# -- the fault suite, as the arm's ----------------------------------------------------------------
async def _calibrate_through(service, c: TrackerRig, robot: int, fault=None) -> tuple[dict, set]:
    """A calibration job on the tracker cell (`fault` done to it after a few poses, if any):
    its end, and the states it went through with their reasons' error names (from the audit
    trail's state changes: a pause too short for a poll is there too)."""
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": CAL})).json()["id"]
    if fault is not None:
        async with asyncio.timeout(30):
            while len((await service.get(f"/jobs/{job_id}/measurements")).json()) < 5:
                await asyncio.sleep(0.01)
        await fault()
    job = await wait_state(service, job_id, timeout_s=90)
    trail = (await service.get("/audit", params={"limit": 1000})).json()
    seen = {(e["outcome"].split(" -> ")[1], e["detail"].split(":")[0]) for e in trail
            if e["action"] == "job state" and e["target"] == f"job {job_id}"}
    return job, seen


def _each_pose_once(c: TrackerRig, measured: list[dict]) -> None:
    assert sorted(m["idx"] for m in measured) == list(range(POSES))  # none lost, none twice
    # and the tracker measured each pose once: no measurement answered and thrown away (its
    # StartMeasurement requests less those it refused)
    state = c.tracker.state
    refused = sum(n for why, n in state.refused.items() if not why.startswith("find reflector"))
    assert state.attempts - refused == POSES, (state.attempts, state.refused)


@pytest.mark.parametrize(("faults", "error", "refusals"), [
    ("beam=8,beam_n=3", "BeamBrokenError", "beam broken (fault)"),
    ("drop=8", "LinkLostError", "connection dropped (fault)"),
    ("uninit=8", "TrackerNotInitialisedError", None),
    ("warm=8", "TrackerWarmingUpError", None),
])
async def test_a_tracker_fault_mid_job_pauses_it_and_it_resumes_each_pose_measured_once(
        service, cell, faults, error, refusals):
    """Beam broken for three attempts (the reflector not found again meanwhile), the
    connection dropped, the initialisation lost, the laser warming up, at the 9th pose: the
    job pauses with the tracker's error as its reason and resumes at that pose."""
    c = await cell(faults)
    robot = await add_tracker_robot(service, c, initialise=False)  # initialised at start-up
    c.tracker.state.initialised = True
    job, seen = await _calibrate_through(service, c, robot)
    assert job["state"] == "done", job["reason"]
    assert ("paused", error) in seen, seen
    _each_pose_once(c, (await service.get(f"/jobs/{job['id']}/measurements")).json())
    if refusals is not None:
        assert any(refusals in why for why in c.tracker.state.refused), c.tracker.state.refused
    result = (await service.get(f"/jobs/{job['id']}/result")).json()
    assert result["estimation"]["residual_after_mm"] < 0.05


async def test_the_tracker_restarted_alone_mid_job(service, cell):
    """The tracker's controller restarted (its initialisation lost with it): the job
    reconnects, initialises it and measures on."""
    c = await cell()
    robot = await add_tracker_robot(service, c)

    async def restart() -> None:
        await c.restart_tracker()
        c.tracker.state.initialised = False  # a restarted tracker must be initialised again

    job, seen = await _calibrate_through(service, c, robot, restart)
    assert job["state"] == "done", job["reason"]
    assert any(state == "paused" for state, _ in seen), seen
    measured = (await service.get(f"/jobs/{job['id']}/measurements")).json()
    assert sorted(m["idx"] for m in measured) == list(range(POSES))


async def test_three_smrs_give_the_flange_pose_through_a_drop_mid_triangle(service, cell):
    """Three SMRs: SMRs 2 and 3 found by pointing from the first; the connection dropped
    between the SMRs of a pose: that pose's triangle is measured again, whole, once."""
    c = await cell("drop=25", THREE_SMRS_MM)  # pose 8's second SMR
    robot = await add_tracker_robot(service, c, smrs_mm=[list(p) for p in THREE_SMRS_MM])
    job, seen = await _calibrate_through(service, c, robot)
    assert job["state"] == "done", job["reason"]
    assert ("paused", "LinkLostError") in seen, seen
    measured = (await service.get(f"/jobs/{job['id']}/measurements")).json()
    assert sorted(m["idx"] for m in measured) == list(range(POSES))
    assert all(len(m["holes_mm"]) == 3 and len(m["flange_pose"]) == 6 for m in measured)
    result = (await service.get(f"/jobs/{job['id']}/result")).json()
    assert result["estimation"]["residual_after_mm"] < 0.05


async def test_a_procedure_with_the_tracker_reports_positions_accuracy(service, cell):
    """Performance before, calibration, compensation, performance after, one SMR: ISO 9283
    accuracy of positions (the SMR's, where the calibration put it on the flange)."""
    c = await cell()
    robot = await add_tracker_robot(service, c)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "procedure", "options": CAL})).json()["id"]
    job = await wait_state(service, job_id, timeout_s=120)
    assert job["state"] == "done", job["reason"]
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    before = result["performance"]["perf_before"]["overall"]["ap_mm_mean"]
    after = result["performance"]["perf_after"]["overall"]["ap_mm_mean"]
    assert before > 40 and after < 0.05, (before, after)  # the arm's: > 40 and < 0.1
    assert "laser tracker" in result["test_conditions"]["instrument"]


async def test_a_beam_that_stays_broken_skips_its_poses_counted_never_measured(service, cell):
    """The beam broken for ten attempts from the 9th pose's: each pose is tried three times
    (the job pausing between), then skipped and counted, the robot moving on; poses 8, 9 and 10
    are skipped, the 11th is found again; the rest measured once; the result says so."""
    c = await cell("beam=8,beam_n=10")
    robot = await add_tracker_robot(service, c)
    job, seen = await _calibrate_through(service, c, robot)
    assert job["state"] == "done", job["reason"]
    assert ("paused", "BeamBrokenError") in seen, seen
    measured = (await service.get(f"/jobs/{job['id']}/measurements")).json()
    assert sorted(m["idx"] for m in measured) == [k for k in range(POSES) if k not in (8, 9, 10)]
    state = c.tracker.state
    refused = sum(n for why, n in state.refused.items() if not why.startswith("find reflector"))
    assert state.attempts - refused == POSES - 3  # none measured with the beam broken
    result = (await service.get(f"/jobs/{job['id']}/result")).json()
    assert result["poses_skipped"] == {"cal": [8, 9, 10]}
    assert any("3 cal pose(s) skipped" in w for w in result["warnings"]), result["warnings"]
