"""The HTTP server's guard against slow and many clients (uvicorn has neither by default).

- Header timeout: a connection that has not sent a whole request head within
  `header_timeout_s` of connecting (or of its previous response) is closed.
- Room for the operator: at most `max_pending` connections may be waiting for their request
  head; a newcomer beyond that evicts the oldest waiting one, so a thousand half-open
  connections cannot keep the operator's GET out (a request that is being served is never
  evicted).
- No delay: every connection sends without Nagle's algorithm (`without_delay`).
- Body timeout (`BodyTimeout`): a request whose body does not arrive within `body_timeout_s` of
  the previous chunk is ended as a client disconnect.
"""

from __future__ import annotations

import asyncio
import socket
from collections import OrderedDict
from typing import Any, cast

from uvicorn.protocols.http.h11_impl import H11Protocol


def guarded_protocol(header_timeout_s: float, max_pending: int) -> type[H11Protocol]:
    """uvicorn's h11 protocol with the header timeout and the eviction of the oldest waiting
    connection (one registry per server)."""
    waiting: OrderedDict[GuardedH11Protocol, asyncio.TimerHandle] = OrderedDict()

    class GuardedH11Protocol(H11Protocol):
        _served: object = None  # the request cycle that settled this connection's wait

        def _wait_for_head(self) -> None:
            self._served = self.cycle
            waiting[self] = self.loop.call_later(header_timeout_s, self._too_slow)
            while len(waiting) > max_pending:
                oldest, timer = waiting.popitem(last=False)
                timer.cancel()
                oldest.transport.close()

        def _settled(self) -> None:
            timer = waiting.pop(self, None)
            if timer is not None:
                timer.cancel()

        def _too_slow(self) -> None:
            waiting.pop(self, None)
            self.transport.close()

        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            # asyncio's Protocol takes a BaseTransport; uvicorn's h11 protocol is always given
            # (and types) a stream Transport
            super().connection_made(cast(asyncio.Transport, transport))
            without_delay(transport)
            self._wait_for_head()

        def handle_events(self) -> None:
            super().handle_events()
            if self.cycle is not None and self.cycle is not self._served:
                self._settled()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if not self.transport.is_closing():
                self._wait_for_head()  # kept alive: the next request's head has the same limit

        def connection_lost(self, exc: Exception | None) -> None:
            self._settled()
            super().connection_lost(exc)

    return GuardedH11Protocol


def without_delay(transport: asyncio.BaseTransport) -> None:
    """Send each response as soon as it is written (TCP_NODELAY). asyncio sets it only on the
    sockets of a listening socket made with proto IPPROTO_TCP; one made with proto 0 (the
    default of socket.socket(), the service's own and a test's) left Nagle's algorithm on: a
    response's last small segment then waited for the client's delayed ACK, 40 ms on every
    request of a kept-alive connection after its first."""
    sock = transport.get_extra_info("socket")
    if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


class BodyTimeout:
    """ASGI middleware: each body chunk of a request must come within `timeout_s`; else the
    app sees the client as gone. Once the body is complete, `receive` is passed through (an
    event stream waits on it for the disconnect)."""

    def __init__(self, app: Any, timeout_s: float):
        self.app, self.timeout_s = app, timeout_s

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        complete = False

        async def timed_receive() -> dict:
            nonlocal complete
            if complete:
                return await receive()
            try:
                message = await asyncio.wait_for(receive(), self.timeout_s)
            except TimeoutError:
                complete = True
                return {"type": "http.disconnect"}
            if message["type"] != "http.request" or not message.get("more_body", False):
                complete = True
            return message

        await self.app(scope, timed_receive, send)
