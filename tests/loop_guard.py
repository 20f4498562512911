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

from service.database import Database
from service.store import Store

# the modules that are the store itself: what they call inside is part of one store call
_STORE_MODULES = ("service.store", "service.database")


def on_loop_thread() -> bool:
    """True on a thread whose event loop is running (the loop that serves every request)."""
    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return False
    return True


def _a_tests_own(frame: Any) -> bool:
    """True when the service's code was called by a test directly (setting data up), not by
    the service's request handling or runners: the first caller outside `service` is a test."""
    while frame is not None and frame.f_globals.get("__name__", "").startswith("service."):
        frame = frame.f_back
    return frame is not None and frame.f_globals.get("__name__", "").startswith("tests.")


def public_methods(cls: type) -> list[str]:
    return [name for name, member in inspect.getmembers(cls, inspect.isfunction)
            if not name.startswith("_")]


def guarded(owner: str, method: Callable[..., Any], seen: list[str]) -> Callable[..., Any]:
    @functools.wraps(method)
    def call(*args: Any, **kwargs: Any) -> Any:
        caller = sys._getframe(1)
        module = caller.f_globals.get("__name__", "")
        if module.startswith("service.") and module not in _STORE_MODULES and \
                on_loop_thread() and not _a_tests_own(caller):
            seen.append(f"{owner}.{method.__name__} from {module}:{caller.f_lineno} "
                        f"({caller.f_code.co_name})")
        return method(*args, **kwargs)
    return call


def guard_store(monkeypatch: Any) -> list[str]:
    """Wrap every public method of Store, and the database's own (which the audit trail and
    others use beside the store), for this test; the calls made on the loop's thread."""
    seen: list[str] = []
    for cls, names in ((Store, public_methods(Store)), (Database, ("rows", "row", "tx"))):
        for name in names:
            monkeypatch.setattr(cls, name, guarded(cls.__name__, getattr(cls, name), seen))
    return seen
