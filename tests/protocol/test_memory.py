"""The link in memory (protocol/memory.py) behaves as a socket's streams do for the client, and
its blocking ends as a socket and a pyserial port do for the tracker driver and the arm reader."""

import asyncio
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

from protocol.arm import ArmReader
from protocol.client import ControllerClient, Timeouts
from protocol.errors import ArmLineError, LinkLostError, LinkTimeoutError
from protocol.memory import memory_link, memory_pair, serial_link, socket_link
from protocol.tracker import TrackerClient
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


@contextmanager
def loop_in_a_thread() -> Iterator[asyncio.AbstractEventLoop]:
    """An event loop run by its own thread: the server side of a blocking client's link."""
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        yield loop
    finally:
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5)
        loop.close()


def echo_until(word: bytes) -> tuple[list[bytes], Callable]:
    """A server that echoes each line back until `word`, then hangs up; what it read."""
    lines: list[bytes] = []

    async def serve(reader, writer):
        while (line := await reader.readline()) and line != word:
            lines.append(line)
            writer.write(line)
        lines.append(line)
        writer.close()

    return lines, serve


def test_a_blocking_socket_end_waits_its_time_out_then_reads_the_end_of_the_stream():
    lines, serve = echo_until(b"bye\n")
    with loop_in_a_thread() as loop:
        end = socket_link(serve, loop)()
        end.settimeout(0.05)
        start = time.monotonic()
        with pytest.raises(TimeoutError):
            end.recv(10)  # nothing sent yet
        assert time.monotonic() - start >= 0.05
        end.settimeout(2.0)
        end.sendall(b"one\n")
        assert end.recv(2) == b"on" and end.recv(10) == b"e\n"  # at most what is asked
        end.sendall(b"bye\n")
        assert end.recv(10) == b""  # the server hung up: the end of the stream
        with pytest.raises(BrokenPipeError):
            end.sendall(b"more\n")
        end.close()
        with pytest.raises(OSError, match="closed"):
            end.recv(1)
    assert lines == [b"one\n", b"bye\n"]


def test_a_blocking_serial_end_reads_as_pyserial_does():
    lines, serve = echo_until(b"bye\n")
    with loop_in_a_thread() as loop:
        port = serial_link(serve, loop)()
        port.timeout = 0.05
        assert port.read(1) == b""  # the time-out passed with nothing
        port.timeout = 2.0
        assert port.write(b"abc\n") == 4
        assert port.read(3) == b"abc"  # waits for all it asks ...
        port.timeout = 0.05
        assert port.read(10) == b"\n"  # ... or what came within the time-out
        port.write(b"bye\n")
        port.timeout = 2.0
        with pytest.raises(ConnectionResetError):
            port.read(1)  # the end of the stream, as socket:// says "socket disconnected"
        port.close()
    assert lines == [b"abc\n", b"bye\n"]


def test_a_client_closing_its_blocking_end_is_an_end_of_file_for_the_server():
    seen = threading.Event()

    async def serve(reader, writer):
        if await reader.read() == b"last words":
            seen.set()
        writer.close()

    with loop_in_a_thread() as loop:
        end = socket_link(serve, loop)()
        end.sendall(b"last words")
        end.close()
        assert seen.wait(2)


def test_the_readers_take_their_link_in_memory_and_say_its_faults_in_their_words():
    async def silent(reader, writer):
        await reader.read()  # reads until the client leaves, never answers
        writer.close()

    async def hangs_up(reader, writer):
        writer.close()

    with loop_in_a_thread() as loop:
        with TrackerClient("tracker", connect=socket_link(silent, loop), timeout_s=0.1) as t:
            with pytest.raises(LinkTimeoutError, match="no answer"):
                t.units()
        with TrackerClient("tracker", connect=socket_link(hangs_up, loop)) as t:
            with pytest.raises(LinkLostError, match=r"(closed|dropped) the connection"):
                t.units()  # (the send itself fails when the hang-up came first)
        with ArmReader("arm", connect=serial_link(silent, loop)) as arm:
            arm.request()
            with pytest.raises(LinkTimeoutError, match="P1-P3"):
                arm.read_holes(0.1)
        with ArmReader("arm", connect=serial_link(hangs_up, loop)) as arm:
            with pytest.raises(ArmLineError, match="port arm failed"):
                arm.read_holes(2.0)
