"""An arm line that sends triples twice, late, or stale: every pose keeps its own holes."""

import asyncio

import numpy as np
import pytest

from simulators.arm import ArmEmulator, ArmFaults
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.truth import make_world
from tests.integration.conftest import AUTH, FAST, serving
from tests.integration.test_jobs import wait_state


class _Rig:
    def __init__(self, emu: IRC5Emulator, arm: ArmEmulator):
        self.emu, self.arm = emu, arm

    @property
    def address(self) -> tuple[str, int]:
        return self.emu.address


async def _cell(faults: ArmFaults | None, seed: int) -> _Rig:
    world = make_world(None, None)
    emu = IRC5Emulator(world, EmulatorSettings(time_scale=0.02))
    emu.address = await emu.start("127.0.0.1", 0)
    arm = ArmEmulator(world, seed=seed, faults=faults)
    host, port = await arm.start("127.0.0.1", 0)
    arm.url = f"socket://{host}:{port}"
    return _Rig(emu, arm)


async def _calibrate(service, rig: _Rig, name: str) -> tuple[dict, list[dict]]:
    host, port = rig.address
    r = await service.post("/robots", headers=AUTH, json={
        "name": name, "controller_host": host, "controller_port": port, "arm_url": rig.arm.url})
    assert r.status_code == 201, r.text
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": r.json()["id"], "kind": "calibration",
        "options": FAST | {"calibration_poses": 40}})).json()["id"]
    job = await wait_state(service, job_id, timeout_s=120)
    assert job["state"] == "done", job["reason"]
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    return result, (await service.get(f"/jobs/{job_id}/measurements")).json()


def _true_holes_mm(rig: _Rig, joints_deg: list[float]) -> np.ndarray:
    world = rig.emu.world
    saved = world.q_deg
    world.q_deg = np.asarray(joints_deg, dtype=np.float32)
    try:
        return world.true_holes_mm()
    finally:
        world.q_deg = saved


@pytest.fixture
async def service(tmp_path):
    """The service waiting 1 s for a pose's holes (the suite's 3 s): a triple late by 0.4 s
    or stale by up to 0.6 s still comes within it, and each of the few poses whose every
    triple was discarded is probed again after 1 s, not 3."""
    async with serving(tmp_path / "jobs.db", arm_timeout_s=1.0) as http:
        yield http


@pytest.mark.slow
async def test_duplicated_late_and_stale_triples_never_land_on_the_wrong_pose(service):
    faults = ArmFaults(duplicate=0.3, late=0.2, stale=0.3)
    dirty = await _cell(faults, seed=11)
    clean = await _cell(None, seed=11)
    try:
        job, measured = await _calibrate(service, dirty, "dirty arm")
        sent = dirty.arm.sent_faults
        assert sent["duplicate"] >= 5 and sent["late"] >= 3 and sent["stale"] >= 5, sent
        assert sorted(m["idx"] for m in measured) == list(range(40))
        wrong = [m["idx"] for m in measured
                 if np.max(np.abs(np.array(m["holes_mm"])
                                  - _true_holes_mm(dirty, m["joints_deg"]))) > 0.1]
        assert wrong == []  # 0 poses with another pose's holes
        discarded = job["arm_readings_discarded"]
        print("arm faults sent", sent, "discarded", discarded)
        assert discarded["duplicate"] + discarded["stale"] + discarded["motion"] >= 5
        reference, _ = await _calibrate(service, clean, "clean arm")
    finally:
        for rig in (dirty, clean):
            await rig.arm.stop()
            await rig.emu.stop()

    # the estimate unchanged within noise: each robot parameter within 4 combined std errors
    got = {p["name"]: p for p in job["estimation"]["parameters"]}
    ref = {p["name"]: p for p in reference["estimation"]["parameters"]}
    assert got.keys() == ref.keys()
    for name, p in got.items():
        allowed = 4 * np.hypot(p["std_error"], ref[name]["std_error"])
        assert abs(p["value"] - ref[name]["value"]) <= allowed, (name, p, ref[name])


def test_arm_fault_options_are_checked():
    assert ArmFaults.parse("duplicate=0.3, late=0.1") == ArmFaults(duplicate=0.3, late=0.1)
    for bad in ("duplicate=2", "echo=0.1", "late=x"):
        with pytest.raises(ValueError, match="arm fault"):
            ArmFaults.parse(bad)


async def test_the_emulator_really_sends_a_copy_of_the_triple():
    """The fault itself (so the job test above cannot pass with a fault that never fires)."""
    from protocol.arm import ArmReader

    world = make_world(None, None)
    arm = ArmEmulator(world, seed=1, faults=ArmFaults(duplicate=1.0))
    host, port = await arm.start("127.0.0.1", 0)
    try:
        reader = await asyncio.to_thread(ArmReader, f"socket://{host}:{port}")
        await asyncio.sleep(0.1)
        await world.set_joints(np.zeros(6))
        first = await asyncio.to_thread(reader.read_holes, 2.0)
        copy = await asyncio.to_thread(reader.read_holes, 2.0)
        await asyncio.to_thread(reader.close)
    finally:
        await arm.stop()
    assert first.points_mm == copy.points_mm and first.seqs != copy.seqs


@pytest.mark.slow
async def test_a_pose_whose_every_reading_is_refused_pauses_saying_why(tmp_path, rig):
    """A check set tighter than the robot's own errors must not look like a dead arm."""
    import httpx

    from service.app import create_app
    from service.settings import ServiceSettings
    from tests.integration.conftest import TOKEN, add_robot

    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN,
                                     arm_timeout_s=0.5, remeasure_attempts=1,
                                     motion_tolerance_mm=0.01, motion_tolerance_rel=0.0,
                                     motion_tolerance_deg=0.001))
    async with app.router.lifespan_context(app):
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service", headers=AUTH) as http:
            robot = await add_robot(http, rig)
            job_id = (await http.post("/jobs", headers=AUTH, json={
                "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
            async with asyncio.timeout(30):
                while "every reading" not in ((job := (await http.get(
                        f"/jobs/{job_id}")).json())["reason"] or ""):
                    await asyncio.sleep(0.02)
            assert job["state"] == "paused" and "motion_tolerance" in job["reason"]
            await http.post(f"/jobs/{job_id}/abort", headers=AUTH)
