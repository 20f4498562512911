"""Every change, every action and every refused attempt into the audit trail, once the response
is known: who (the request's principal, else `anonymous`), from where, what (method and route),
on what (the route's ids) and the outcome (the status). Reads that succeed are not recorded."""

from __future__ import annotations

import asyncio
import sys
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.audit import Event
from service.errors import StoreError, StoreLostError

_READS = ("GET", "HEAD", "OPTIONS")


class AuditMiddleware:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        status: dict[str, int] = {}

        async def sending(message: Message) -> None:
            if message["type"] == "http.response.start":
                status["code"] = message["status"]
            await send(message)

        try:
            await self.app(scope, receive, sending)
        finally:
            await self._record(scope, status.get("code", 500))

    async def _record(self, scope: Scope, code: int) -> None:
        method = scope["method"]
        if method in _READS and code not in (401, 403):
            return
        app: Any = scope["app"]
        trail = getattr(app.state, "audit", None)
        if trail is None:
            return
        route = scope.get("route")
        principal = scope.get("state", {}).get("principal")
        client = scope.get("client")
        params = scope.get("path_params") or {}
        event = Event(actor=principal.name if principal is not None else "anonymous",
                      source=client[0] if client else "unknown",
                      action=f"{method} {getattr(route, 'path', scope['path'])}",
                      target=", ".join(f"{k} {v}" for k, v in params.items()),
                      outcome=str(code) + (" refused" if code in (401, 403, 429) else ""))
        try:
            await asyncio.to_thread(trail.append, event)
        except StoreError as err:  # the response has gone: say it here, never raise past it
            if isinstance(err, StoreLostError):
                app.state.manager.fatal(str(err))  # the service stops (service/manager.py)
            print(f"screwcal service: audit event not recorded ({event.action} by "
                  f"{event.actor}: {event.outcome}): {err}", file=sys.stderr)
