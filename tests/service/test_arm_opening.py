"""The arm's port opened in a thread: a job let go of while it opens leaves nothing open, even
when the event loop is gone before the port opens (a socket left to the garbage collector was a
ResourceWarning in a later test)."""

import asyncio
import socket
import threading
import time

import pytest

import service.arm_opening as arm_opening
from protocol.arm import ArmReader
from protocol.errors import ArmLineError
from service.arm_opening import ArmOpening


@pytest.fixture
def arm_server():
    """A TCP server on loopback standing in for the arm's socket: its `socket://` URL and the
    connections it accepted (to see them closed: recv gives b"")."""
    server = socket.create_server(("127.0.0.1", 0))
    accepted: list[socket.socket] = []
    stop = threading.Event()

    def accept() -> None:
        server.settimeout(0.05)
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except TimeoutError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"socket://127.0.0.1:{server.getsockname()[1]}", accepted
    stop.set()
    thread.join()
    for conn in accepted:
        conn.close()
    server.close()


def _slow_opening(monkeypatch, seconds: float) -> list[ArmReader]:
    """The real reader, opened after `seconds` (a port slow to open); returns those opened."""
    opened: list[ArmReader] = []

    class SlowReader(ArmReader):
        def __init__(self, url: str):
            time.sleep(seconds)
            super().__init__(url)
            opened.append(self)

    monkeypatch.setattr(arm_opening, "ArmReader", SlowReader)
    return opened


def _closed_by_peer(accepted: list[socket.socket], timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not accepted and time.monotonic() < deadline:
        time.sleep(0.01)
    conn = accepted[0]
    conn.settimeout(max(deadline - time.monotonic(), 0.01))
    return conn.recv(1) == b""


def test_let_go_of_while_opening_its_thread_closes_it_after_the_loop_is_gone(monkeypatch,
                                                                             arm_server):
    url, accepted = arm_server
    opened = _slow_opening(monkeypatch, 0.3)

    async def job() -> None:
        opening = ArmOpening(url)
        await asyncio.sleep(0.05)
        opening.abandon()  # the job aborted; the loop then ends before the port opens

    asyncio.run(job())  # (cancels what still runs on the loop: the thread runs on)
    assert _closed_by_peer(accepted)
    assert len(opened) == 1 and not opened[0].port.is_open


async def test_open_and_never_claimed_it_is_closed_when_let_go_of(monkeypatch, arm_server):
    url, accepted = arm_server
    opened = _slow_opening(monkeypatch, 0.0)
    opening = ArmOpening(url)
    await asyncio.wait({opening.future})
    assert opened[0].port.is_open
    opening.abandon()
    assert await asyncio.to_thread(_closed_by_peer, accepted)


async def test_a_claimed_port_is_the_claimers(monkeypatch, arm_server):
    url, accepted = arm_server
    _slow_opening(monkeypatch, 0.0)
    opening = ArmOpening(url)
    reader = await opening.claim()
    opening.abandon()  # too late: the job has it
    await asyncio.sleep(0.1)
    assert reader.port.is_open
    reader.close()
    assert await asyncio.to_thread(_closed_by_peer, accepted)


async def test_a_claim_cancelled_leaves_the_opening_to_be_let_go_of(monkeypatch, arm_server):
    url, accepted = arm_server
    opened = _slow_opening(monkeypatch, 0.3)
    opening = ArmOpening(url)
    claim = asyncio.create_task(opening.claim())
    await asyncio.sleep(0.05)
    claim.cancel()
    with pytest.raises(asyncio.CancelledError):
        await claim
    opening.abandon()
    assert await asyncio.to_thread(_closed_by_peer, accepted)
    assert not opened[0].port.is_open
    with pytest.raises(ArmLineError, match="let go of"):
        await opening.future
