"""Shared by the benchmark scripts: best-of-N timing.

BLAS threads are left as a user gets them (the benchmarks once pinned them to one core, which
hid that numpy's and scipy's two thread pools made identification 3.5x slower on 2 cores:
`screwcal.calibration.blas_threads`). Set OPENBLAS_NUM_THREADS yourself to compare.
"""

from __future__ import annotations

import time
from collections.abc import Callable


def best_of(repeat: int, fn: Callable[[], object]) -> float:
    """The fastest of `repeat` runs after one warm-up (imports, caches), in seconds."""
    fn()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)
