"""The link in memory (protocol/memory.py) behaves as a socket's streams do for the client."""

import asyncio

import pytest

from protocol.client import ControllerClient, Timeouts
from protocol.errors import LinkLostError
from protocol.memory import memory_link, memory_pair
from tests.protocol.fake_controller import FakeController, well_behaved


async def test_what_one_end_writes_the_other_reads_and_a_close_is_an_end_of_file():
    (ra, wa), (rb, wb) = memory_pair()
    wa.write(b"12345")
    await wa.drain()
    assert await rb.readexactly(5) == b"12345"
    wb.write(b"back")
    assert await ra.readexactly(4) == b"back"
    wa.close()
    await asyncio.wait_for(wa.wait_closed(), 1)
    with pytest.raises(asyncio.IncompleteReadError):
        await rb.readexactly(1)
    wb.close()


async def test_each_opening_serves_a_new_link():
    served = []

    async def serve(reader, writer):
        served.append(await reader.readexactly(2))
        writer.close()

    open_link = memory_link(serve)
    writers = []
    for word in (b"ab", b"cd"):
        _, writer = await open_link()
        writer.write(word)
        writers.append(writer)
        await asyncio.sleep(0)
    await asyncio.sleep(0.01)
    assert served == [b"ab", b"cd"]
    for writer in writers:
        writer.close()


async def test_the_client_talks_to_a_controller_in_memory_and_sees_it_leave():
    fake = FakeController(well_behaved)
    timeouts = Timeouts(connect_s=1, reply_s=0.5, pose_s=1, motion_s=1, keepalive_s=30)
    client = ControllerClient("memory", 0, timeouts, connect=fake.opener)
    stat = await client.reconnect(first_delay_s=0.01)
    assert stat.state == "IDLE" and fake.connections == 1
    await client.close()
    await asyncio.wait_for(fake.client_closed.wait(), 1)
    with pytest.raises(LinkLostError):
        await client.stat()
