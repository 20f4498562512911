"""A link in memory: a client and a server (a test's fake controller, an emulated instrument)
joined in this process, with no socket between them.

`memory_link(serve)` gives an opener that the asyncio client takes instead of opening TCP
(`ControllerClient(..., connect=opener)`): each call starts `serve(reader, writer)` on the other
end, as `asyncio.start_server` would for a connection, and returns the client's two streams.
What one end writes the other reads; closing an end is an end of file for the other.

The instruments' readers are blocking (they run in a thread of their own): they take the
transport as `connect=`, a function giving what they read and write. `socket_link(serve, loop)`
gives, for the tracker driver (`TrackerClient(..., connect=...)`), a `MemorySocket` (a socket's
`sendall`, `recv`, `settimeout`, `close`); `serial_link(serve, loop)` gives, for the arm reader
(`ArmReader(..., connect=...)`), a `MemorySerial` (a pyserial port's `timeout`, `read`, `write`,
`close`). Each opening starts `serve(reader, writer)` on `loop` (the emulator's), which must run
in another thread than the blocking caller's, as it must for a real socket.
"""

from __future__ import annotations

import asyncio
import errno
import threading
import time
from collections.abc import Awaitable, Callable
from typing import Any, Protocol, TypeVar

Streams = tuple[asyncio.StreamReader, asyncio.StreamWriter]
Opener = Callable[[], Awaitable[Streams]]
Serve = Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]


class ByteSocket(Protocol):
    """What the tracker driver needs of its connection (a `socket.socket` is one)."""

    def sendall(self, data: bytes, /) -> None: ...

    def recv(self, size: int, /) -> bytes: ...

    def settimeout(self, value: float | None, /) -> None: ...

    def close(self) -> None: ...


class SerialPort(Protocol):
    """What the arm reader needs of its port (pyserial's ports are ones)."""

    timeout: float | None

    def read(self, size: int = 1) -> bytes: ...

    def write(self, data: bytes) -> int | None: ...

    def close(self) -> None: ...


class _Peer(Protocol):
    """Where one direction of a link delivers: an asyncio reader, or a blocking end's inbox."""

    def feed_data(self, data: bytes) -> None: ...

    def feed_eof(self) -> None: ...


class _Pipe(asyncio.Transport):
    """One direction of the link: what is written here is fed to the peer."""

    def __init__(self, peer: _Peer):
        super().__init__()
        self._peer = peer
        self._closing = False
        self.protocol: asyncio.StreamReaderProtocol | None = None

    def write(self, data: bytes | bytearray | memoryview) -> None:
        if not self._closing:
            self._peer.feed_data(bytes(data))

    def can_write_eof(self) -> bool:
        return True

    def write_eof(self) -> None:
        self._peer.feed_eof()

    def is_closing(self) -> bool:
        return self._closing

    def close(self) -> None:
        if self._closing:
            return
        self._closing = True
        self._peer.feed_eof()
        if self.protocol is not None:  # the writer's wait_closed() ends
            asyncio.get_running_loop().call_soon(self.protocol.connection_lost, None)

    def abort(self) -> None:
        self.close()

    def get_extra_info(self, name: str, default: Any = None) -> Any:
        return {"peername": ("memory", 0), "sockname": ("memory", 0)}.get(name, default)


def _end(reader: asyncio.StreamReader, peer: _Peer) -> asyncio.StreamWriter:
    loop = asyncio.get_running_loop()
    protocol = asyncio.StreamReaderProtocol(reader)
    pipe = _Pipe(peer)
    pipe.protocol = protocol
    protocol.connection_made(pipe)
    return asyncio.StreamWriter(pipe, protocol, reader, loop)


def memory_pair() -> tuple[Streams, Streams]:
    """Two ends of one link: (reader, writer) each."""
    a, b = asyncio.StreamReader(), asyncio.StreamReader()
    return (a, _end(a, b)), (b, _end(b, a))


def memory_link(serve: Serve) -> Opener:
    """An opener of links in memory to `serve` (its tasks kept until they end)."""
    tasks: set[asyncio.Task[None]] = set()

    async def open_link() -> Streams:
        mine, theirs = memory_pair()
        task = asyncio.ensure_future(serve(*theirs))
        tasks.add(task)
        task.add_done_callback(tasks.discard)
        return mine

    return open_link


class _Inbox:
    """The bytes that arrived for a blocking end, fed from the server's loop."""

    def __init__(self) -> None:
        self._data = bytearray()
        self._eof = False
        self._ready = threading.Condition()

    def feed_data(self, data: bytes) -> None:
        with self._ready:
            self._data += data
            self._ready.notify_all()

    def feed_eof(self) -> None:
        with self._ready:
            self._eof = True
            self._ready.notify_all()

    def take(self, size: int, timeout_s: float | None, *, whole: bool) -> bytes | None:
        """Up to `size` bytes, once there are any (`whole`: once there are `size`), or what
        there is when `timeout_s` has passed (None: no limit); None at the end of the stream
        with nothing left."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        with self._ready:
            while len(self._data) < (size if whole else 1) and not self._eof:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    break
                self._ready.wait(left)
            if not self._data and self._eof:
                return None
            out = bytes(self._data[:size])
            del self._data[:size]
            return out


class _BlockingEnd:
    """The client's end of a link whose server end is a pair of asyncio streams on `loop`."""

    def __init__(self, serve: Serve, loop: asyncio.AbstractEventLoop,
                 tasks: set[asyncio.Task[None]]):
        self._loop = loop
        self._inbox = _Inbox()
        self._closed = False
        self._peer: asyncio.StreamReader | None = None  # set on the loop before any delivery
        self._peer_closed = threading.Event()

        def start() -> None:  # on the loop's thread, as start_server would
            self._peer = asyncio.StreamReader()
            writer = _end(self._peer, self)
            task = asyncio.ensure_future(serve(self._peer, writer), loop=loop)
            tasks.add(task)
            task.add_done_callback(tasks.discard)

        loop.call_soon_threadsafe(start)

    # what the server's writer delivers (on the loop's thread)
    def feed_data(self, data: bytes) -> None:
        self._inbox.feed_data(data)

    def feed_eof(self) -> None:
        self._peer_closed.set()
        self._inbox.feed_eof()

    def _deliver(self, data: bytes) -> None:
        if self._peer is not None:
            self._peer.feed_data(data)

    def _deliver_eof(self) -> None:
        if self._peer is not None:
            self._peer.feed_eof()

    def _check_open(self) -> None:
        if self._closed:
            raise OSError(errno.EBADF, "the link in memory is closed")

    def _send(self, data: bytes) -> None:
        self._check_open()
        if self._peer_closed.is_set():
            raise BrokenPipeError(errno.EPIPE, "the peer closed the link in memory")
        self._loop.call_soon_threadsafe(self._deliver, bytes(data))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if not self._loop.is_closed():
            self._loop.call_soon_threadsafe(self._deliver_eof)


class MemorySocket(_BlockingEnd):
    """A link in memory in a socket's form (`ByteSocket`): `recv` waits up to the time-out set
    with `settimeout` and raises TimeoutError after it; b"" is the end of the stream."""

    def __init__(self, serve: Serve, loop: asyncio.AbstractEventLoop,
                 tasks: set[asyncio.Task[None]]):
        super().__init__(serve, loop, tasks)
        self._timeout_s: float | None = None

    def settimeout(self, value: float | None, /) -> None:
        self._timeout_s = value

    def sendall(self, data: bytes, /) -> None:
        self._send(data)

    def recv(self, size: int, /) -> bytes:
        self._check_open()
        got = self._inbox.take(size, self._timeout_s, whole=False)
        if got is None:
            return b""
        if not got:
            raise TimeoutError("timed out")
        return got


class MemorySerial(_BlockingEnd):
    """A link in memory in a pyserial port's form (`SerialPort`): `read(size)` waits up to
    `timeout` for `size` bytes and returns what came (0: what is there now; None: waits for
    all); the end of the stream is a ConnectionResetError, as pyserial's socket:// says
    "socket disconnected"."""

    def __init__(self, serve: Serve, loop: asyncio.AbstractEventLoop,
                 tasks: set[asyncio.Task[None]]):
        super().__init__(serve, loop, tasks)
        self.timeout: float | None = None

    def write(self, data: bytes) -> int:
        self._send(data)
        return len(data)

    def read(self, size: int = 1) -> bytes:
        self._check_open()
        got = self._inbox.take(size, self.timeout, whole=True)
        if got is None:
            raise ConnectionResetError(errno.ECONNRESET, "the peer closed the link in memory")
        return got


End = TypeVar("End", MemorySocket, MemorySerial)


def _blocking_link(kind: type[End], serve: Serve, loop: asyncio.AbstractEventLoop
                   ) -> Callable[[], End]:
    tasks: set[asyncio.Task[None]] = set()
    return lambda: kind(serve, loop, tasks)


def socket_link(serve: Serve, loop: asyncio.AbstractEventLoop) -> Callable[[], MemorySocket]:
    """An opener of links in memory to `serve` on `loop`, for a blocking client that takes a
    socket (the tracker driver)."""
    return _blocking_link(MemorySocket, serve, loop)


def serial_link(serve: Serve, loop: asyncio.AbstractEventLoop) -> Callable[[], MemorySerial]:
    """An opener of links in memory to `serve` on `loop`, for a blocking client that takes a
    pyserial port (the arm reader)."""
    return _blocking_link(MemorySerial, serve, loop)
