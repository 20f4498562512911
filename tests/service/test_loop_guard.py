"""The guard every service test runs under (tests/loop_guard.py) sees what it is meant to see."""

import asyncio

from service.history import robot_history
from service.store import Store
from tests.loop_guard import guard_store


async def test_a_store_call_of_the_service_on_the_loop_is_seen_and_one_in_a_thread_is_not(
        tmp_path, monkeypatch):
    store = Store(tmp_path / "jobs.db")
    robot = store.add_robot("cell", "127.0.0.1", 1, "socket://127.0.0.1:1", {"name": "x"},
                            [[0, 0, 0], [10, 0, 0], [0, 10, 0]])  # a test's own call: passes
    seen = guard_store(monkeypatch)
    await asyncio.to_thread(robot_history, store, robot.id, 1.0)
    assert seen == []
    robot_history(store, robot.id, 1.0)  # a test's own call (setting data up): passes
    assert seen == []
    # the service's code run by the loop (as a request's handler or a runner is), on its thread
    asyncio.get_running_loop().call_soon(robot_history, store, robot.id, 1.0)
    await asyncio.sleep(0.01)
    assert seen and all("from service.history" in s for s in seen), seen
    store.close()
