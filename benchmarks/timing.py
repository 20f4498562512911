"""Shared by the benchmark scripts: median-of-N timing with its spread (never the best run).

BLAS threads are left as a user gets them (the benchmarks once pinned them to one core, which
hid that numpy's and scipy's two thread pools made identification 3.5x slower on 2 cores:
`screwcal.runtime.blas_threads`). Set OPENBLAS_NUM_THREADS yourself to compare.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Spread:
    """Seconds: the median of the runs, the fastest, the slowest, and how many."""

    median: float
    low: float
    high: float
    runs: int

    def ms(self) -> str:
        return f"{self.median * 1e3:9.1f} ms ({self.low * 1e3:.1f}-{self.high * 1e3:.1f})"


def median_of(repeat: int, fn: Callable[[], object]) -> Spread:
    """The median, min and max of `repeat` runs after one warm-up (imports, caches)."""
    if repeat < 3:
        raise ValueError(f"repeat = {repeat}: a median with a spread needs at least 3 runs")
    times = _timed_runs(repeat, fn)
    return Spread(statistics.median(times), min(times), max(times), repeat)


def _timed_runs(repeat: int, fn: Callable[[], object]) -> list[float]:
    """Seconds of each of `repeat` runs of `fn`, after one warm-up run (imports, caches)."""
    fn()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times


def interleaved(rounds: int, fns: Sequence[Callable[[], object]],
                clock: Callable[[], float] = time.perf_counter) -> list[Spread]:
    """Per function, the median, min and max of `rounds` runs, the functions run in turn in
    every round after one warm-up each (what else the host runs weighs on all of them alike);
    at least 5 rounds (issue 29). `clock`: wall time, or `time.process_time` (the CPU time of
    the process: what a busy host's other work does not add)."""
    if rounds < 5:
        raise ValueError(f"rounds = {rounds}: interleaved medians need at least 5 rounds")
    for fn in fns:
        fn()
    times: list[list[float]] = [[] for _ in fns]
    for _ in range(rounds):
        for fn, out in zip(fns, times, strict=True):
            start = clock()
            fn()
            out.append(clock() - start)
    return [Spread(statistics.median(t), min(t), max(t), rounds) for t in times]


def cpu_seconds(cmd: list[str]) -> float:
    """Run cmd as a process; the user and system CPU seconds it used (on a busy host, the
    figure that does not wait for the other processes)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, capture_output=True, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
