"""The event loop never waits on the store: a guard that notes every call of the store's public
methods made by the service's code on a thread that runs an event loop (ARCHITECTURE.md: "its
event loop never waits on the store"). Calls from tests themselves (setting a database up) and
from worker threads (asyncio.to_thread, a sync route's thread pool) pass."""

from __future__ import annotations

import asyncio
import functools
import inspect
import sys
from collections.abc import Callable
from typing import Any

from service.store import Store


def on_loop_thread() -> bool:
    """True on a thread whose event loop is running (the loop that serves every request)."""
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return False
    return True


def public_methods(cls: type) -> list[str]:
    return [name for name, member in inspect.getmembers(cls, inspect.isfunction)
            if not name.startswith("_")]


def guarded(method: Callable[..., Any], seen: list[str]) -> Callable[..., Any]:
    @functools.wraps(method)
    def call(*args: Any, **kwargs: Any) -> Any:
        caller = sys._getframe(1)
        module = caller.f_globals.get("__name__", "")
        if module.startswith("service.") and module != "service.store" and on_loop_thread():
            seen.append(f"Store.{method.__name__} from {module}:{caller.f_lineno} "
                        f"({caller.f_code.co_name})")
        return method(*args, **kwargs)
    return call


def guard_store(monkeypatch: Any) -> list[str]:
    """Wrap every public method of Store for this test; the calls made on the loop's thread."""
    seen: list[str] = []
    for name in public_methods(Store):
        monkeypatch.setattr(Store, name, guarded(getattr(Store, name), seen))
    return seen
