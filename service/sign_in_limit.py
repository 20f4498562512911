"""Failed sign-ins limited per source and per user at that source, never per user alone: a
thousand wrong passwords from one address close that address for a while, and the operator signs
in from another at once. Kept in the service's memory (one service's count; a wrong password
still costs an argon2 verification, about 50 ms, which the per-source limit bounds)."""

from __future__ import annotations

import threading
import time
from collections import defaultdict, deque

MAX_FAILURES = 10  # within WINDOW_S, then refused until the oldest ages out
WINDOW_S = 60.0


class SignInLimit:
    def __init__(self, max_failures: int = MAX_FAILURES, window_s: float = WINDOW_S) -> None:
        self.max, self.window = max_failures, window_s
        self._failures: dict[tuple[str, str], deque[float]] = defaultdict(deque)
        self._lock = threading.Lock()

    def _recent(self, key: tuple[str, str], now: float) -> deque[float]:
        q = self._failures[key]
        while q and q[0] < now - self.window:
            q.popleft()
        return q

    def retry_after(self, source: str, user: str) -> float:
        """Seconds until this source (or this user from this source) may try again; 0: now."""
        now = time.monotonic()
        with self._lock:
            waits = [q[0] + self.window - now for key in ((source, ""), (source, user))
                     if len(q := self._recent(key, now)) >= self.max]
        return max(waits, default=0.0)

    def failed(self, source: str, user: str) -> None:
        now = time.monotonic()
        with self._lock:
            for key in ((source, ""), (source, user)):
                self._recent(key, now).append(now)
