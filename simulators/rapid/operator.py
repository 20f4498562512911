"""What a person at the controller sees and does: the FlexPendant's operator window (TPWrite,
TPErase, TPReadFK) and the controller's event log (errors, warnings, ErrWrite).

Tests drive the pendant: `press(key)` answers the prompt on screen, or `auto` answers every
prompt as it appears (an operator who always presses the same key, after doing what it asks).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Event:
    kind: str  # "error", "warning", "info"
    title: str
    text: str
    at: float = field(default_factory=time.monotonic)

    def __str__(self) -> str:
        return f"{self.kind}: {self.title}: {self.text}" if self.text else \
            f"{self.kind}: {self.title}"


class EventLog:
    """The controller's event log, newest last; `printer` (the emulator's --verbose) sees each
    entry as it is written."""

    def __init__(self, printer: Callable[[Event], None] | None = None):
        self.entries: list[Event] = []
        self.printer = printer
        self._lock = threading.Lock()

    def write(self, kind: str, title: str, text: str = "") -> Event:
        event = Event(kind, title, text)
        with self._lock:
            self.entries.append(event)
        if self.printer is not None:
            self.printer(event)
        return event

    def remove(self, event: Event) -> None:
        with self._lock:
            if event in self.entries:
                self.entries.remove(event)

    def count(self, kind: str | None = None, containing: str = "") -> int:
        with self._lock:
            return sum(1 for e in self.entries if (kind is None or e.kind == kind)
                       and containing in str(e))

    def __iter__(self):
        with self._lock:
            return iter(list(self.entries))


@dataclass(frozen=True)
class Prompt:
    text: str
    keys: tuple[str, ...]  # FK1..FK5 labels ("" for an empty key)
    screen: tuple[str, ...]  # the operator window's lines when it was shown


class Pendant:
    """The FlexPendant's operator window."""

    def __init__(self) -> None:
        self.lines: list[str] = []  # the operator window, as TPWrite wrote it
        self.history: list[str] = []  # every line ever written
        self.prompt: Prompt | None = None
        self.prompts: list[Prompt] = []
        self.auto: Callable[[Prompt], int | None] | None = None
        self._answer: int | None = None
        self._cond = threading.Condition()

    def write(self, text: str) -> None:
        with self._cond:
            self.lines.append(text)
            self.history.append(text)

    def erase(self) -> None:
        with self._cond:
            self.lines.clear()

    def press(self, key: int) -> None:
        """The operator presses function key `key` (1..5) of the prompt on screen."""
        with self._cond:
            if self.prompt is None:
                raise RuntimeError("no TPReadFK prompt on the pendant")
            if not 1 <= key <= 5 or not self.prompt.keys[key - 1]:
                raise ValueError(f"key {key} is not offered: {self.prompt.keys}")
            self._answer = key
            self._cond.notify_all()

    def wait_prompt(self, timeout: float = 5.0) -> Prompt:
        """For tests: the prompt once one is shown."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while self.prompt is None:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError("no prompt on the pendant")
                self._cond.wait(left)
            return self.prompt

    def ask(self, text: str, keys: tuple[str, ...], max_time: float | None,
            stopped: Callable[[], bool]) -> int | None:
        """Show a prompt until a key is pressed (its number), `max_time` passes (None), or the
        program stops (None)."""
        with self._cond:
            self.prompt = Prompt(text, keys, tuple(self.lines))
            self.prompts.append(self.prompt)
            self._answer = None
            self._cond.notify_all()
        if self.auto is not None:
            key = self.auto(self.prompt)
            if key is not None:
                with self._cond:
                    self._answer = key
        deadline = None if max_time is None else time.monotonic() + max_time
        try:
            with self._cond:
                while self._answer is None:
                    if stopped():
                        return None
                    left = 0.05 if deadline is None else min(0.05, deadline - time.monotonic())
                    if left <= 0:
                        return None
                    self._cond.wait(left)
                return self._answer
        finally:
            with self._cond:
                self.prompt = None
