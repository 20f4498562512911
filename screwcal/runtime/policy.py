"""Process-wide settings, decided once by the program that owns the process: its doors.

Three things screwcal runs faster with belong to the whole process, not to a library call:

- the BLAS libraries' threads (numpy's and scipy's OpenBLAS): one thread, because screwcal
  solves many small dense problems on which threads only compete (`blas_threads`:
  85 ms instead of 24 ms for one identification of 40 poses on 2 cores);
- the C heap's thresholds (glibc's `mallopt`): freed temporaries kept for the next ones
  instead of page-faulted in again (`heap`: a sixth of an identification of 1000
  poses);
- the cyclic garbage collector: a RAPID module of 10,000 robtargets is a few hundred thousand
  small objects with no cycle, which the collector's default pace goes through again and
  again while they are built (0.4-0.5 s of the 2.5 s `compensate --rapid` took).

A library call that set them would change them for every other thread and for the rest of
the caller's life (a notebook's allocator, the service's other jobs seeing the collector off
while one parses). So `identify()`, `parse_module()` and the RAPID filter leave them as they
find them, and each door applies the policy for its kind of process:

- `for_command_line()`: the `screwcal` command, first thing in `main`, before numpy loads:
  one OpenBLAS thread through its environment variable (the processes the command starts
  inherit it), the heap kept, the collector's first generation at `COLLECT_EVERY` allocations
  instead of 700 (fewer passes over the large trees the commands build; cycles are still
  collected, by every thread alike);
- `collection_paused()`: within a single-threaded door, around building and using one large
  acyclic tree (`screwcal compensate --rapid` around reading and filtering the module);
- `held_for_service()`: the job service's lifespan: one BLAS thread held from its start to its
  end whatever its worker threads do, the heap kept;
- `for_worker()`: a worker process's initialiser (a study's process pool, its Dask tasks), and
  any program that calls screwcal as a library in one thread (a benchmark, a notebook, the
  test session): one BLAS thread for the rest of the process's life, the heap kept.

A setting the user has made (OPENBLAS_NUM_THREADS and friends, glibc's MALLOC_*_ variables) is
left as it is; a threshold of the collector set before the door is raised, never lowered.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from screwcal.runtime.blas_threads import (
    hold_one_blas_thread,
    one_blas_thread_for_this_program,
    pin_one_blas_thread,
)
from screwcal.runtime.heap import keep_freed_memory

__all__ = ["COLLECT_EVERY", "collection_paused", "for_command_line", "for_worker",
           "held_for_service"]

COLLECT_EVERY = 50_000  # allocations between the collector's first-generation passes (CLI)

_lock = threading.Lock()
_pinned: list[bool] = []  # for_worker has run in this process


def for_command_line() -> None:
    """The `screwcal` command's policy (the module docstring); call it before numpy loads."""
    one_blas_thread_for_this_program()
    keep_freed_memory()
    first, *older = gc.get_threshold()
    if 0 < first < COLLECT_EVERY:  # (0: the collector is off, as someone asked)
        gc.set_threshold(COLLECT_EVERY, *older)


@contextmanager
def held_for_service() -> Iterator[None]:
    """Within: the job service's policy (one BLAS thread for every thread, the heap kept)."""
    keep_freed_memory()
    with hold_one_blas_thread():
        yield


def for_worker() -> None:
    """A worker process's (or a one-threaded library user's) policy, for the rest of its
    life: one BLAS thread, the heap kept. Applying it again changes nothing."""
    keep_freed_memory()
    with _lock:
        if not _pinned:
            pin_one_blas_thread()
            _pinned.append(True)


@contextmanager
def collection_paused() -> Iterator[None]:
    """Within: no cyclic garbage collection (reference counting still frees what is dropped),
    for a single-threaded door building one large acyclic tree (the collector is the whole
    process's: another thread would see it off). Nested uses and a collector the caller has
    disabled are left as they were."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
