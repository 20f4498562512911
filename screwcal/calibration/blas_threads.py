"""One BLAS thread while screwcal solves its many small dense problems.

numpy's and scipy's wheels each carry their own OpenBLAS, and each library keeps worker threads
that spin for a while after every call. Identification alternates the two (numpy's per-pose
6x6 inverses, scipy's SVD, QR and pseudo-inverses) on matrices far too small for threads to
pay (a few hundred to a few thousand rows by at most ~60 columns), so on a machine with few
cores the two spinning pools and the caller compete for the cores: measured on 2 cores, a
(40, 6, 6) inverse right after a scipy decomposition took 40-110 ms instead of 0.1 ms, and one
identification of 40 poses 85 ms instead of 24 ms (`benchmarks/calibration.py`).

`one_blas_thread()` sets every loaded BLAS to one thread through the libraries' own setters
(threadpoolctl) and puts back what was there when the last concurrent user leaves (the job
service identifies in worker threads). The user's own settings (OPENBLAS_NUM_THREADS, ...)
outside it are left alone.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["one_blas_thread"]

_lock = threading.Lock()
_state: dict[str, Any] = {"controller": None, "users": 0, "limiter": None}


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within: every BLAS library loaded in the process runs one thread."""
    with _lock:
        if _state["users"] == 0:
            if _state["controller"] is None:
                from threadpoolctl import ThreadpoolController  # scans the loaded libraries

                _state["controller"] = ThreadpoolController()
            _state["limiter"] = _state["controller"].limit(limits=1, user_api="blas")
        _state["users"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["users"] -= 1
            if _state["users"] == 0:
                _state["limiter"].restore_original_limits()
                _state["limiter"] = None
