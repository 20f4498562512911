"""The process's settings are its doors' (screwcal/runtime/policy.py): a plain caller of
`identify()`, `parse_module()` and the RAPID filter finds the BLAS threads, the C heap's
thresholds and the garbage collector as it left them, before, during (from another thread) and
after; the doors (the command line, a worker) set theirs."""

from __future__ import annotations

import functools
import gc
import json
import os
import platform
import subprocess
import sys
import threading

import pytest

from screwcal.calibration.rapid_source import read_rapid_module
from screwcal.rapid import parse_module

# What a plain program sees of the process, printed as JSON: BLAS threads per library, the
# collector's switch and thresholds, and (glibc) whether a block of 8 MB is served from its
# own mapping (glibc's default for large blocks) or from the heap (the door's thresholds).
_PROBE = r"""
import ctypes, gc, json, sys

def blas():
    from threadpoolctl import threadpool_info
    return sorted((i["filepath"], i["num_threads"]) for i in threadpool_info()
                  if i["user_api"] == "blas")

def collector():
    return [gc.isenabled(), list(gc.get_threshold())]

class Info(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks",
                "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

def large_block_mapped():
    libc = ctypes.CDLL(None)
    libc.mallinfo2.restype = Info
    libc.malloc.restype, libc.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    before = libc.mallinfo2().hblks
    block = libc.malloc(8 * 2 ** 20)
    mapped = libc.mallinfo2().hblks > before
    libc.free(block)
    return mapped
"""

_PLAIN_CALLER = _PROBE + r"""
import numpy as np
import scipy.linalg
from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.rapid_filter import filter_rapid
from screwcal.calibration.rapid_source import read_rapid_module
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.robots import irb1600
from screwcal.studies.simulated_measurements import simulate_measurements

if sys.argv[1] == "door":
    from screwcal.runtime.policy import for_worker
    for_worker()
before = {"blas": blas(), "collector": collector()}
rng = np.random.default_rng(5)
truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
identify(irb1600(), simulate_measurements(truth, random_configurations(30, rng), rng),
         compliance="auto", lag="auto")
module = read_rapid_module("p.mod", sys.stdin.read())
filter_rapid(module, truth, irb1600())
after = {"blas": blas(), "collector": collector()}
print(json.dumps({"before": before, "after": after, "mapped": large_block_mapped()}))
"""


def robtargets_module(n: int) -> str:
    """A module of `n` robtargets (reachable by the IRB 1600) and a move to each."""
    lines = ["MODULE Many"]
    lines += [f"    CONST robtarget p{k}:=[[{800 + k % 200},{k % 300 - 150},{900 + k % 100}],"
              "[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];" for k in range(n)]
    lines += ["    PROC main()", *(f"        MoveL p{k}, v100, fine, tool0;" for k in range(n)),
              "    ENDPROC", "ENDMODULE"]
    return "\n".join(lines) + "\n"


@functools.cache  # one process per mode for the three tests below (their xdist_group)
def _plain_caller(mode: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k not in
           ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-c", _PLAIN_CALLER, mode], env=env,
                          input=robtargets_module(50), capture_output=True, text=True,
                          check=True)
    return dict(json.loads(done.stdout.splitlines()[-1]))


glibc = pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc",
                           reason="glibc's malloc thresholds")
plain_callers = pytest.mark.xdist_group("policy: what a plain caller's process sees")


@plain_callers
def test_a_plain_caller_finds_the_process_as_it_left_it():
    seen = _plain_caller("plain")
    assert seen["after"] == seen["before"]
    assert seen["before"]["collector"] == [True, [700, 10, 10]]
    if (os.cpu_count() or 1) > 1:  # the libraries' own default: a thread per core
        assert all(n > 1 for _, n in seen["after"]["blas"]), seen


@plain_callers
@glibc
def test_the_heap_thresholds_are_the_doors_not_the_identifications():
    assert _plain_caller("plain")["mapped"] is True  # glibc's default: untouched
    assert _plain_caller("door")["mapped"] is False  # the worker's door kept it


@plain_callers
def test_a_worker_door_runs_one_blas_thread_and_leaves_the_collector():
    seen = _plain_caller("door")
    assert {n for _, n in seen["before"]["blas"]} == {1}
    assert seen["after"] == seen["before"]
    assert seen["before"]["collector"] == [True, [700, 10, 10]]


def test_another_thread_never_sees_the_collector_off_while_a_module_is_parsed():
    """The service parses RAPID in worker threads beside others: the collector is the whole
    process's, and parsing no longer switches it off (47 of 53 samples saw it off)."""
    text = robtargets_module(3000)
    seen: list[bool] = []
    parsing = threading.Event()
    done = threading.Event()

    def watch() -> None:
        parsing.wait()
        while not done.is_set():
            seen.append(gc.isenabled())
            done.wait(0.001)

    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        parsing.set()
        for _ in range(3):
            parse_module(text, "many.mod")
            read_rapid_module("many.mod", text)
    finally:
        done.set()
        watcher.join()
    assert len(seen) > 10 and all(seen), f"{seen.count(False)} of {len(seen)} saw it off"


_COMMAND_LINE = _PROBE + r"""
from screwcal.runtime.policy import for_command_line
for_command_line()
import numpy, scipy.linalg
print(json.dumps({"blas": blas(), "collector": collector()}))
"""


def _command_line_door(gc_off: bool) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in
           ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    code = ("import gc\ngc.set_threshold(0)\n" if gc_off else "") + _COMMAND_LINE
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, check=True)
    return dict(json.loads(done.stdout))


def test_the_command_line_door_sets_one_blas_thread_and_the_collectors_pace():
    from screwcal.runtime.policy import COLLECT_EVERY

    seen = _command_line_door(gc_off=False)
    assert {n for _, n in seen["blas"]} == {1}
    assert seen["collector"] == [True, [COLLECT_EVERY, 10, 10]]
    assert _command_line_door(gc_off=True)["collector"][1][0] == 0  # the user's choice stands


def test_collection_paused_resumes_and_leaves_a_disabled_collector():
    from screwcal.runtime.policy import collection_paused

    with collection_paused():
        assert not gc.isenabled()
        with collection_paused():
            pass
        assert not gc.isenabled()
    assert gc.isenabled()
    gc.disable()
    try:
        with collection_paused():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()
