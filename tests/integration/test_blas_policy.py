"""The service holds one BLAS thread for its whole life (issue 29): jobs call BLAS in many
worker threads at once, and a limit set and restored around each identification gave the
others the default, spinning pools back whenever no identification happened to run."""

import asyncio
import threading

import pytest
from threadpoolctl import ThreadpoolController

from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.robots import irb1600
from screwcal.studies.simulated_measurements import simulate_measurements
from tests.integration.conftest import AUTH, add_robot


def blas_threads():
    return sorted({p["num_threads"] for p in ThreadpoolController().info()
                   if p["user_api"] == "blas"})


@pytest.fixture
def two_threads():
    """Every BLAS at two threads around the test (the machines here may have two cores)."""
    import scipy.linalg  # noqa: F401  (scipy's own OpenBLAS loaded before the limit)

    with ThreadpoolController().limit(limits=2, user_api="blas"):
        if blas_threads() != [2]:
            pytest.skip(f"this machine's BLAS cannot run two threads: {blas_threads()}")
        yield


@pytest.fixture
def started_with_two(two_threads, service):
    """The service, started while every BLAS ran two threads."""
    return service


async def test_one_thread_for_the_whole_service_while_jobs_identify(started_with_two, rig, rng):
    http = started_with_two
    assert blas_threads() == [1]  # from the start, before any identification
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(30, rng), rng)
    seen: list[list[int]] = []
    stop = threading.Event()

    def watch() -> None:  # another thread, as the service's other workers
        while not stop.is_set():
            seen.append(blas_threads())
            stop.wait(0.002)

    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        robot = await add_robot(http, rig)
        job = (await http.post("/jobs", headers=AUTH, json={
            "robot_id": robot, "kind": "calibration",
            "options": {"calibration_poses": 30}})).json()["id"]
        # two identifications in worker threads beside the job, each entering and leaving
        for _ in range(3):
            await asyncio.gather(*(asyncio.to_thread(
                identify, irb1600(), data, kind="thesis", frames="known") for _ in range(2)))
            assert blas_threads() == [1]  # none running now: still one
        for _ in range(2000):
            state = (await http.get(f"/jobs/{job}")).json()["state"]
            if state in ("done", "failed"):
                break
            await asyncio.sleep(0.01)
        assert state == "done", (await http.get(f"/jobs/{job}/result")).json()
    finally:
        stop.set()
        watcher.join()
    assert seen and all(s == [1] for s in seen), sorted({tuple(s) for s in seen})
    assert blas_threads() == [1]


async def test_the_users_threads_back_when_the_service_stops(two_threads, tmp_path):
    from service.app import create_app
    from service.settings import ServiceSettings

    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", token="t"))
    async with app.router.lifespan_context(app):
        assert blas_threads() == [1]
    assert blas_threads() == [2]
