"""The emulator (and the rules the RAPID module keeps) against a peer that does not follow
the protocol: nothing moves out of turn, the session and the server survive, one client owns
the controller at a time, and nothing a peer sends or leaves unread grows without bound
(issue 12, server side)."""

import asyncio
import contextlib
import random
import socket

import pytest

from protocol.client import ControllerClient, Timeouts
from protocol.codec import FRAME_LEN, frame
from protocol.errors import ControllerBusyError, LinkTimeoutError
from tests.simulators.conftest import targets


async def _exchange(emulator, payloads: list[str], replies: int) -> list[str]:
    reader, writer = await asyncio.open_connection(*emulator.address)
    try:
        writer.write(b"".join(frame(p) for p in payloads))
        await writer.drain()
        data = await asyncio.wait_for(reader.readexactly(replies * FRAME_LEN), 10)
    finally:
        writer.close()
        await writer.wait_closed()
    return [data[k:k + FRAME_LEN].decode().split("#")[0]
            for k in range(0, len(data), FRAME_LEN)]


async def _still_serves(emulator) -> None:
    async with asyncio.timeout(10):
        c = ControllerClient(*emulator.address, Timeouts(pose_s=5))
        await c.reconnect(first_delay_s=0.01)  # busy until the server has seen the last leave
        await c.load("CAL", targets(2))
        got = [p async for p in c.run("CAL", "AUTO", count=2)]
        assert [p.idx for p in got] == [0, 1]
        await c.close()


async def test_a_request_mid_load_never_moves_the_robot(emulator):
    # a previous list the RUN would have run
    c = ControllerClient(*emulator.address, Timeouts(pose_s=5))
    await c.connect()
    await c.load("CAL", targets(2))
    await c.close()
    moves = emulator.world.arrivals
    q = " ".join(f"{v:.4f}" for v in targets(1)[0])
    out = await _exchange(emulator, ["1 HELO 1", "2 LOAD CAL 3", f"2 j 0 0 {q}",
                                     "3 RUN CAL AUTO"], 3)
    assert out[0].startswith("1 ACK HELO")
    assert out[1].startswith("3 ERR 13") and out[2].startswith("2 ERR 13")
    await asyncio.sleep(0.1)
    assert emulator.world.arrivals == moves  # neither the old list nor anything else ran
    out = await _exchange(emulator, ["1 HELO 1", "2 LOAD CAL 2", f"2 j 0 0 {q}",
                                     f"3 MOVJ {q}"], 3)
    assert out[1].startswith("3 ERR 13") and emulator.world.arrivals == moves
    await _still_serves(emulator)


async def test_nested_loads_do_not_kill_the_session(emulator):
    frames = ["1 HELO 1", *(f"{k + 2} LOAD CAL 1" for k in range(600))]
    # each LOAD is cut short by the next (both answered ERR 13), which starts nothing
    out = await _exchange(emulator, frames, 1 + 600)
    assert all(" ERR 13 " in line for line in out[1:])
    await _still_serves(emulator)


async def test_a_list_too_long_and_numbers_beyond_reason(emulator):
    big = "1" + "0" * 50
    out = await _exchange(emulator, ["1 HELO 1", "2 LOAD CAL 1000000",
                                     f"3 MOVJ 0 0 0 0 {big} 0",
                                     "4 LOAD PERF 1", f"4 p 2 0 800 0 900 0 {big} 0"], 4)
    assert out[1].startswith("2 ERR 14")
    assert out[2].startswith("3 ERR 12")
    assert out[3].startswith("4 ERR 12")
    await _still_serves(emulator)


async def _closed_by_server(reader: asyncio.StreamReader, within_s: float) -> bytes:
    """Everything the server sent until it closed the connection (fails if it does not)."""
    async with asyncio.timeout(within_s):
        return await reader.read(-1)


async def test_a_second_client_is_told_busy_and_the_owner_goes_on(emulator, client):
    for hello in (b"", frame("1 HELO 1")):  # whether it spoke or not
        reader, writer = await asyncio.open_connection(*emulator.address)
        writer.write(hello)
        assert await _closed_by_server(reader, 2) == frame("0 ERR 16 busy")
        writer.close()
    with pytest.raises(ControllerBusyError):
        await ControllerClient(*emulator.address, Timeouts(reply_s=1)).connect()
    assert (await client.stat()).state == "IDLE" and emulator.refused == 3


@pytest.mark.parametrize("sent", [b"", frame("1 HELO 1") + frame("2 STAT")[:40]])
async def test_a_silent_owner_or_half_a_frame_is_dropped_after_the_idle_time(emulator, sent):
    emulator.settings.idle_timeout_s = 0.3
    reader, writer = await asyncio.open_connection(*emulator.address)
    writer.write(sent)
    got = await _closed_by_server(reader, 3)
    assert got == (frame("1 ACK HELO 1") if sent else b"")
    writer.close()
    await _still_serves(emulator)


async def test_a_client_that_failed_to_connect_does_not_hold_the_controller(emulator):
    bad = ControllerClient(*emulator.address, Timeouts(reply_s=1e-6))  # HELO times out
    with pytest.raises(LinkTimeoutError):
        await bad.connect()
    assert bad._writer is None and emulator.settings.idle_timeout_s == 60
    async with asyncio.timeout(3):  # well before the controller's idle time-out
        await _still_serves(emulator)


async def test_a_peer_that_does_not_read_is_dropped_with_bounded_memory(emulator):
    emulator.settings.send_timeout_s = 0.3
    # A small receive buffer: the replies it never reads fill it in kilobytes (the module
    # answers a few thousand requests a second, not the megabytes a host buffers).
    sock = socket.socket()
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8192)
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, emulator.address)
    _reader, writer = await asyncio.open_connection(sock=sock, limit=4096)
    flood = b"".join(frame(f"{k} STAT") for k in range(1, 1001))
    with pytest.raises(ConnectionError):  # the server cuts it
        async with asyncio.timeout(20):
            while True:
                writer.write(flood)  # 1000 requests at a time, replies never read
                await writer.drain()
    # The module reads one frame at a time: the rest waits in TCP, never in the controller.
    async with asyncio.timeout(5):
        while emulator.data("connected"):  # the session ends (the module notices the cut)
            await asyncio.sleep(0.01)
    writer.transport.abort()
    await _still_serves(emulator)


async def test_random_bytes_connect_storms_and_many_clients(emulator):
    rng = random.Random(12)
    moves = emulator.world.arrivals

    async def hostile(k: int) -> None:
        with contextlib.suppress(ConnectionError, TimeoutError):
            reader, writer = await asyncio.open_connection(*emulator.address)
            if k % 3 == 0:  # a storm: connect and leave at once
                writer.transport.abort()
                return
            try:
                writer.write(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400))))
                await writer.drain()
                async with asyncio.timeout(2):
                    await reader.read(-1)  # the server ends it (bad frame, busy), or resets it
            finally:
                writer.close()

    emulator.settings.idle_timeout_s = 1.0
    await asyncio.gather(*(hostile(k) for k in range(60)))
    assert emulator.world.arrivals == moves  # nothing moved
    # The module refuses newcomers one after another (a RAPID task, as on a real IRC5): the
    # owner must not time out meanwhile.
    emulator.settings.idle_timeout_s = 60.0
    clients = [ControllerClient(*emulator.address, Timeouts(reply_s=2)) for _ in range(12)]
    results = await asyncio.gather(*(c.connect() for c in clients), return_exceptions=True)
    assert sum(r is None for r in results) == 1, results  # one owner at a time
    assert all(isinstance(r, ControllerBusyError) for r in results if r is not None)
    for c in clients:
        await c.close()
    await _still_serves(emulator)
