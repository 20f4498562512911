"""The measuring arm's port, opened in a thread: pyserial's open blocks (a real port, or a
`socket://` connect), so it never runs on the event loop, and a thread cannot be cancelled.

A job aborted while the port opens must still leave nothing open. Whoever comes second closes
the port: the thread, when its opening finishes after the job let go (`abandon`), or `abandon`
itself, when the port opened and nobody took it (`claim`). The thread needs no event loop for
that: the service may have stopped by then (a callback on the loop would never run, and the
socket would be left to the garbage collector).
"""

from __future__ import annotations

import asyncio
import threading

from protocol.arm import ArmReader
from protocol.errors import ArmLineError


class ArmOpening:
    """One opening of the arm's port at `url`, started at once in a worker thread."""

    def __init__(self, url: str):
        self.url = url
        self._lock = threading.Lock()
        self._abandoned = False
        self._opened: ArmReader | None = None  # open, not yet claimed
        self.future: asyncio.Future[ArmReader] = asyncio.ensure_future(
            asyncio.to_thread(self._open))
        self.future.add_done_callback(_seen)  # its error is the claimer's, if any claims it

    def _open(self) -> ArmReader:
        reader = ArmReader(self.url)
        with self._lock:
            if not self._abandoned:
                self._opened = reader
                return reader
        reader.close()  # let go of while it opened: nobody will take it
        raise ArmLineError(f"the measuring arm's port {self.url} was let go of while it opened")

    async def claim(self) -> ArmReader:
        """The open port, once open (its opening's errors raised); the caller closes it.
        A cancellation leaves the opening running: `abandon` it."""
        reader = await asyncio.shield(self.future)
        with self._lock:
            self._opened = None
        return reader

    def abandon(self) -> None:
        """Nobody will claim the port: closed now if open (in a thread of its own: pyserial's
        `socket://` close sleeps 0.3 s), else by the opening thread when it opens."""
        with self._lock:
            self._abandoned = True
            reader, self._opened = self._opened, None
        if reader is not None:
            threading.Thread(target=reader.close, name="arm-close", daemon=True).start()


def _seen(future: asyncio.Future[ArmReader]) -> None:
    if not future.cancelled():
        future.exception()
