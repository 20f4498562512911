"""One BLAS thread while screwcal solves its many small dense problems.

numpy's and scipy's wheels each carry their own OpenBLAS, and each library keeps worker threads
that spin for a while after every call. Identification alternates the two (numpy's per-pose
6x6 inverses, scipy's SVD, QR and pseudo-inverses) on matrices far too small for threads to
pay (a few hundred to a few thousand rows by at most ~60 columns), so on a machine with few
cores the two spinning pools and the caller compete for the cores: measured on 2 cores, a
(40, 6, 6) inverse right after a scipy decomposition took 40-110 ms instead of 0.1 ms, and one
identification of 40 poses 85 ms instead of 24 ms (`benchmarks/calibration.py`).

The limit is process-wide (OpenBLAS keeps one thread count per library, not per thread), so
it is held by whoever owns the process's threads, at the process's door
(`screwcal.runtime.policy` decides which door holds which; no library call sets it):

- `hold_one_blas_thread()`: for a process that runs screwcal in several threads (the job
  service, for its whole lifespan). Every BLAS is at one thread from its start to its end.
  Setting and restoring the limit around each identification instead gave the other worker
  threads (FK, evaluation, scipy in other jobs) the default pools back whenever no
  identification happened to run: twenty jobs at once beside two CPU-bound processes took
  7-26 s instead of 4 s (issue 29).
- `pin_one_blas_thread()`: the same for the rest of a worker process's life (study workers).
- `one_blas_thread()`: around a piece of work, by a program that owns its process and did not
  start with one BLAS thread; within a hold it changes nothing.
- `one_blas_thread_for_this_program()`: the `screwcal` command line, before numpy loads. The
  command's batched small products (10,000 robtargets' chains of 4x4 screws) ran 4-6x slower
  on 2 busy cores with OpenBLAS's default pool, and a limit through threadpoolctl would cover
  scipy only by importing it first (0.5-1 s, where most commands never load scipy). So the
  command line asks OpenBLAS itself, through its environment variable, which numpy's and
  scipy's copies read whenever they load (the processes the command starts inherit it: they
  hold one thread anyway). A thread count the user has set (OPENBLAS_NUM_THREADS,
  GOTO_NUM_THREADS, OMP_NUM_THREADS) is left as it is.

The limits are set through the libraries' own setters (threadpoolctl, which sees only the
libraries loaded when it is first used: the holds load numpy's and scipy's first). The user's
own settings (OPENBLAS_NUM_THREADS, ...) outside them are left alone.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["hold_one_blas_thread", "one_blas_thread", "one_blas_thread_for_this_program",
           "pin_one_blas_thread"]

# OpenBLAS's thread counts, in the order it reads them
_USER_THREAD_SETTINGS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")

_lock = threading.Lock()
_state: dict[str, Any] = {"controller": None, "users": 0, "limiter": None}


def _enter() -> None:
    with _lock:
        if _state["users"] == 0:
            if _state["controller"] is None:
                from threadpoolctl import ThreadpoolController  # scans the loaded libraries

                _state["controller"] = ThreadpoolController()
            _state["limiter"] = _state["controller"].limit(limits=1, user_api="blas")
        _state["users"] += 1


def _leave() -> None:
    with _lock:
        _state["users"] -= 1
        if _state["users"] == 0:
            _state["limiter"].restore_original_limits()
            _state["limiter"] = None


def _load_blas() -> None:
    """numpy's and scipy's OpenBLAS in the process, so that the limit covers both."""
    import numpy.linalg  # noqa: F401
    import scipy.linalg  # noqa: F401

    with _lock:
        if _state["users"] == 0:
            _state["controller"] = None  # scan again: a library may have loaded since


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within: every BLAS library loaded in the process runs one thread."""
    _enter()
    try:
        yield
    finally:
        _leave()


@contextmanager
def hold_one_blas_thread() -> Iterator[None]:
    """Within: numpy's and scipy's BLAS run one thread, whatever other threads enter and leave."""
    _load_blas()
    with one_blas_thread():
        yield


def pin_one_blas_thread() -> None:
    """numpy's and scipy's BLAS at one thread for the rest of this process's life."""
    _load_blas()
    _enter()


def one_blas_thread_for_this_program() -> bool:
    """OpenBLAS at one thread for this process and those it starts, unless the user has set a
    thread count; only before numpy loads (afterwards the libraries have read theirs). Whether
    the limit was set."""
    if "numpy" in sys.modules or any(os.environ.get(v) for v in _USER_THREAD_SETTINGS):
        return False
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    return True
