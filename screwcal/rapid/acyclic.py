"""Large trees built without the cyclic garbage collector's passes over them.

A module of 10,000 robtargets is read into a few hundred thousand small objects (AST nodes,
their tuples, the filter's tokens), none of which refers back to another: reference counting
frees them all. While they are built, CPython's cyclic collector runs every 700 allocations
and, as the objects age, goes through the whole growing tree again and again: 0.4-0.5 s of
the 2.5 s `compensate --rapid` took on such a module, for no cycle to find. The collector is
paused while such a tree is built and resumed (if it ran) when it is done.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["cycle_collection_paused"]


@contextmanager
def cycle_collection_paused() -> Iterator[None]:
    """Within: no cyclic garbage collection (reference counting still frees what is dropped).
    Nested uses and a collector the caller has disabled are left as they were."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
