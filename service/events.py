"""Per-job progress events, kept in memory for server-sent events (the store keeps the facts)."""

from __future__ import annotations

import asyncio
import time
from typing import Any


class JobEvents:
    def __init__(self) -> None:
        self.items: list[dict[str, Any]] = []
        self._changed = asyncio.Condition()

    async def publish(self, kind: str, **data: Any) -> None:
        self.items.append({"seq": len(self.items), "time": time.time(), "kind": kind, **data})
        async with self._changed:
            self._changed.notify_all()

    async def wait_beyond(self, index: int, timeout_s: float) -> bool:
        """True when an event with position `index` exists (waits up to the time limit)."""
        async with self._changed:
            try:
                await asyncio.wait_for(
                    self._changed.wait_for(lambda: len(self.items) > index), timeout_s)
            except TimeoutError:
                return False
        return True


class EventBus:
    """The jobs' events of this service run. `boot` tells this run's event ids from those of a
    run before a restart (whose events are gone; the store keeps the facts)."""

    def __init__(self) -> None:
        self._jobs: dict[int, JobEvents] = {}
        self.boot = f"{time.time_ns():x}"

    def of(self, job_id: int) -> JobEvents:
        return self._jobs.setdefault(job_id, JobEvents())
