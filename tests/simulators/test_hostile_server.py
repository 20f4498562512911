"""The emulator (and the rules the RAPID module keeps) against a peer that does not follow
the protocol: nothing moves out of turn, the session and the server survive (issue 12,
points 1, 2 and 6)."""

import asyncio

from protocol.client import ControllerClient, Timeouts
from protocol.codec import FRAME_LEN, frame
from tests.simulators.conftest import targets


async def _exchange(emulator, payloads: list[str], replies: int) -> list[str]:
    reader, writer = await asyncio.open_connection(*emulator.address)
    try:
        writer.write(b"".join(frame(p) for p in payloads))
        await writer.drain()
        data = await asyncio.wait_for(reader.readexactly(replies * FRAME_LEN), 10)
    finally:
        writer.close()
    return [data[k:k + FRAME_LEN].decode().split("#")[0]
            for k in range(0, len(data), FRAME_LEN)]


async def _still_serves(emulator) -> None:
    async with asyncio.timeout(10):
        c = ControllerClient(*emulator.address, Timeouts(pose_s=5))
        await c.connect()
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
