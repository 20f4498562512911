"""Shared by the benchmark scripts: one core for BLAS, and best-of-N timing."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy is imported by the caller


def best_of(repeat: int, fn: Callable[[], object]) -> float:
    """The fastest of `repeat` runs after one warm-up (imports, caches), in seconds."""
    fn()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)
