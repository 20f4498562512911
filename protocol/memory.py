"""A link in memory: asyncio streams joined to each other in this process, for a client and a
server (a test's fake controller) that need no socket between them.

`memory_link(serve)` gives an opener that the client takes instead of opening TCP
(`ControllerClient(..., connect=opener)`): each call starts `serve(reader, writer)` on the other
end, as `asyncio.start_server` would for a connection, and returns the client's two streams.
What one end writes the other reads; closing an end is an end of file for the other.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any

Streams = tuple[asyncio.StreamReader, asyncio.StreamWriter]
Opener = Callable[[], Awaitable[Streams]]


class _Pipe(asyncio.Transport):
    """One direction of the link: what is written here is fed to the peer's reader."""

    def __init__(self, peer: asyncio.StreamReader):
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


def _end(reader: asyncio.StreamReader, peer: asyncio.StreamReader) -> asyncio.StreamWriter:
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


def memory_link(serve: Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]
                ) -> Opener:
    """An opener of links in memory to `serve` (its tasks kept until they end)."""
    tasks: set[asyncio.Task[None]] = set()

    async def open_link() -> Streams:
        mine, theirs = memory_pair()
        task = asyncio.ensure_future(serve(*theirs))
        tasks.add(task)
        task.add_done_callback(tasks.discard)
        return mine

    return open_link
