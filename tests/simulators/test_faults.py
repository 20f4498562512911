"""Injected faults end in a clear client error or a clean recovery: never a hang, never a lost
or duplicated measurement."""

import asyncio

import numpy as np
import pytest

from protocol.client import ControllerClient, Timeouts
from protocol.errors import LinkLostError, LinkTimeoutError
from tests.simulators.conftest import targets


async def _run_all(client, n):
    return [p async for p in client.run("CAL", "AUTO", count=n)]


@pytest.mark.parametrize("fault", ["split_frames", "merge_frames"])
async def test_split_and_merged_frames_are_reassembled(client, emulator, fault):
    setattr(emulator.settings.faults, fault, True)
    q = targets(12)
    await client.load("CAL", q)
    got = await asyncio.wait_for(_run_all(client, 12), 10)
    assert [p.idx for p in got] == list(range(12))
    np.testing.assert_allclose([p.joints_deg for p in got], q, atol=1e-4)


async def test_dropped_link_loses_nothing_and_resumes_from_the_next_pose(client, emulator):
    emulator.settings.faults.drop_at_pose = 7
    q = targets(20)
    await client.load("CAL", q)
    measured = {}
    with pytest.raises(LinkLostError):
        async with asyncio.timeout(10):
            async for p in client.run("CAL", "AUTO", count=20):
                measured[p.idx] = p
    assert sorted(measured) == list(range(7))  # every pose reported before the drop is kept
    stat = await asyncio.wait_for(client.reconnect(first_delay_s=0.01), 10)
    assert stat.state == "IDLE" and stat.idx == 7  # what finished: poses 0-6 reported
    rest = q[stat.idx:]
    await client.load("CAL", rest)  # the caller, not the client, decides to resume
    async for p in client.run("CAL", "AUTO", count=len(rest)):
        assert stat.idx + p.idx not in measured  # none measured twice
        measured[stat.idx + p.idx] = p
    assert sorted(measured) == list(range(20))
    np.testing.assert_allclose([measured[k].joints_deg for k in range(20)], q, atol=1e-4)


async def test_a_stalled_controller_times_out_cleanly(emulator):
    emulator.settings.faults.stall_at_pose = 3
    emulator.settings.faults.stall_s = 2.0
    c = ControllerClient(*emulator.address, Timeouts(pose_s=0.3))
    await c.connect()
    await c.load("CAL", targets(6))
    seen = []
    with pytest.raises(LinkTimeoutError, match="no pose 3"):
        async with asyncio.timeout(5):
            async for p in c.run("CAL", "AUTO"):
                seen.append(p.idx)
    assert seen == [0, 1, 2]
    await c.close()


async def test_a_garbled_frame_drops_the_link(client, emulator):
    emulator.settings.faults.garble_at_pose = 2
    q = targets(5)
    await client.load("CAL", q)
    seen = {}
    with pytest.raises(LinkLostError, match="bad frame"):
        async with asyncio.timeout(5):
            async for p in client.run("CAL", "AUTO"):
                seen[p.idx] = p
    assert sorted(seen) == [0, 1]
    stat = await asyncio.wait_for(client.reconnect(first_delay_s=0.01), 10)
    # The controller only notices a gone client when a write fails: it may have gone on
    # (here it finished). What was measured is what the client holds, so the caller resumes
    # from its own record, never from STAT's count.
    assert stat.idx >= 3
    await client.load("CAL", q[len(seen):])
    async for p in client.run("CAL", "AUTO", count=3):
        seen[len(seen)] = p
    assert sorted(seen) == list(range(5))
    np.testing.assert_allclose([seen[k].joints_deg for k in range(5)], q, atol=1e-4)


async def test_every_pending_wait_fails_when_the_link_drops(client, emulator):
    await client.load("CAL", targets(3))
    waiting = asyncio.create_task(client.stat())
    await asyncio.sleep(0)
    client._writer.transport.abort()  # the link breaks under a pending request
    with pytest.raises(LinkLostError):
        await asyncio.wait_for(waiting, 5)
    with pytest.raises(LinkLostError):
        await client.stat()


async def test_closing_the_client_fails_its_pending_waits(client):
    waiting = asyncio.create_task(client.stat())
    await asyncio.sleep(0)
    await client.close()
    with pytest.raises(LinkLostError, match="closed"):
        await asyncio.wait_for(waiting, 2)


async def test_reconnect_gives_up_with_a_clear_error(emulator):
    c = ControllerClient(*emulator.address, Timeouts(connect_s=0.2))
    await c.connect()
    await emulator.stop()
    with pytest.raises(LinkLostError, match="unreachable after 3 attempts"):
        await c.reconnect(attempts=3, first_delay_s=0.01)
