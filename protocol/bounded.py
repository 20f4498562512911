"""The one queue type for whatever a peer can fill: a bound on every buffer of the link.

`Mailbox` is an `asyncio.Queue` with a fixed limit and two ways in:

- `await put(item)` waits while it is full (back-pressure: a reader that stops reading leaves
  the rest in the peer's TCP window, so a flood costs the receiver nothing);
- `offer(item)` never waits and says False when full: the caller drops the peer that floods.

`force(item)` makes room for a last word (the "link lost" marker) by dropping the oldest item.
"""

from __future__ import annotations

import asyncio
from typing import TypeVar

T = TypeVar("T")


class Mailbox(asyncio.Queue[T]):
    def __init__(self, limit: int):
        if limit < 1:
            raise ValueError(f"a mailbox holds at least one item, not {limit}")
        super().__init__(maxsize=limit)

    def offer(self, item: T) -> bool:
        """Queue `item` now if there is room; False (nothing queued) when full."""
        try:
            self.put_nowait(item)
        except asyncio.QueueFull:
            return False
        return True

    def force(self, item: T) -> None:
        """Queue `item` now, dropping the oldest item when full."""
        if self.full():
            self.get_nowait()
        self.put_nowait(item)
