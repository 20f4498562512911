"""The C heap keeps the identification's freed temporaries (heap.py, issue 29) where the process's
door asks for it (screwcal/runtime/policy.py): an identification repeated in such a process
page-faults far less memory in."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest

from screwcal.runtime import heap

_REPEAT = """
import resource, sys
import numpy as np
from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.kinematics.robots import irb1600
from screwcal.studies.position_only import random_truth
from screwcal.studies.simulated_measurements import simulate_measurements
if sys.argv[1] == "on":
    from screwcal.runtime.policy import for_worker
    for_worker()  # the door of a one-threaded program (identify itself leaves the heap)
rng = np.random.default_rng(3)
data = simulate_measurements(random_truth(rng, on_axis=False),
                              random_configurations(600, rng), rng)
identify(irb1600(), data)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(2):
    identify(irb1600(), data)
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""

glibc = pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
                           reason="glibc's malloc thresholds")


def _faults(mode: str) -> int:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    out = subprocess.run([sys.executable, "-c", _REPEAT, mode], capture_output=True, text=True,
                         env=env, check=True)
    return int(out.stdout.split()[-1])


@glibc
def test_repeated_identification_reuses_the_heap():
    kept, fresh = _faults("on"), _faults("off")
    assert kept < 0.5 * fresh, (kept, fresh)


@glibc
def test_a_users_malloc_setting_is_left_alone(monkeypatch):
    monkeypatch.setattr(heap, "_done", {})
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "131072")
    assert heap.keep_freed_memory() is False
    monkeypatch.setattr(heap, "_done", {})
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_")
    assert heap.keep_freed_memory() is True
