"""One BLAS thread where the process's doors ask for it (screwcal/runtime/policy.py), and what was
there given back; an identification itself leaves the threads to its caller."""

import os
import subprocess
import sys

import numpy as np
import pytest
from threadpoolctl import ThreadpoolController

import screwcal.calibration.solvers as solvers_module
from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import random_configurations
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.robots import irb1600
from screwcal.runtime.blas_threads import hold_one_blas_thread, one_blas_thread
from screwcal.runtime.policy import for_worker
from screwcal.studies.simulated_measurements import simulate_measurements


def blas_threads():
    return sorted({p["num_threads"] for p in ThreadpoolController().info()
                   if p["user_api"] == "blas"})


@pytest.fixture
def two_threads():
    """Every BLAS at two threads for the test (the machines here may have two cores)."""
    controller = ThreadpoolController()
    with controller.limit(limits=2, user_api="blas"):
        if blas_threads() != [2]:
            pytest.skip(f"this machine's BLAS cannot run two threads: {blas_threads()}")
        yield


def test_one_thread_inside_restored_after(two_threads):
    with one_blas_thread():
        assert blas_threads() == [1]
        with one_blas_thread():  # nested: still one, and the inner exit does not restore
            pass
        assert blas_threads() == [1]
    assert blas_threads() == [2]


def test_concurrent_users_restore_when_the_last_leaves(two_threads):
    """The job service identifies in worker threads: one that finishes first must not give
    the others their threads back. Modelled in one thread (first in, first out), since
    OpenBLAS reports its count to the thread that set it last, though it holds for all."""
    first, second = one_blas_thread(), one_blas_thread()
    first.__enter__()
    second.__enter__()
    first.__exit__(None, None, None)
    assert blas_threads() == [1]
    second.__exit__(None, None, None)
    assert blas_threads() == [2]


def test_identify_solves_with_the_callers_threads(two_threads, monkeypatch, rng):
    """identify sets no BLAS limit of its own: the least-squares solve inside it runs with the
    threads its caller chose (the process's door chooses one: screwcal/runtime/policy.py)."""
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    data = simulate_measurements(truth, random_configurations(30, rng), rng)
    seen = []
    solve = solvers_module.levenberg_marquardt

    def watched(*args, **kwargs):
        seen.append(blas_threads())
        return solve(*args, **kwargs)

    monkeypatch.setattr(solvers_module, "levenberg_marquardt", watched)
    result = identify(irb1600(), data, kind="thesis", frames="known")
    assert seen and all(s == [2] for s in seen)
    assert blas_threads() == [2]
    assert np.isfinite(result.residuals_after).all()


def test_a_hold_is_not_given_back_by_identifications_inside(two_threads):
    """The job service holds one thread for its life; identifications in its worker threads
    enter and leave one_blas_thread without restoring the default pools for the others."""
    with hold_one_blas_thread():
        with one_blas_thread():
            pass
        assert blas_threads() == [1]
    assert blas_threads() == [2]


def _worker_blas_threads():
    return blas_threads()


def test_study_workers_run_one_thread(two_threads):
    """A study's worker processes (studies/study.py: runtime.policy.for_worker as their
    initialiser) pin one BLAS thread for their life."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, initializer=for_worker) as pool:
        assert pool.submit(_worker_blas_threads).result() == [1]


def _blas_threads_of_a_command_line(env: dict[str, str]) -> int:
    """The BLAS threads numpy runs with in a fresh process that starts as `screwcal` does."""
    code = ("from screwcal.runtime.blas_threads import one_blas_thread_for_this_program as f\n"
            "f()\nimport numpy\nfrom threadpoolctl import threadpool_info\n"
            "print(max(i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'))")
    clean = {k: v for k, v in os.environ.items() if k not in
             ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    done = subprocess.run([sys.executable, "-c", code], env={**clean, **env},
                          capture_output=True, text=True, check=True)
    return int(done.stdout)


def test_the_command_line_runs_one_blas_thread_unless_the_user_set_one():
    if (os.cpu_count() or 1) < 2:
        pytest.skip("one core: every BLAS runs one thread anyway")
    assert _blas_threads_of_a_command_line({}) == 1
    assert _blas_threads_of_a_command_line({"OPENBLAS_NUM_THREADS": "2"}) == 2
    assert _blas_threads_of_a_command_line({"OMP_NUM_THREADS": "2"}) == 2


def test_the_command_line_limit_comes_too_late_once_numpy_is_loaded():
    from screwcal.runtime.blas_threads import one_blas_thread_for_this_program

    assert "numpy" in sys.modules  # this module imported it
    before = os.environ.get("OPENBLAS_NUM_THREADS")
    assert one_blas_thread_for_this_program() is False
    assert os.environ.get("OPENBLAS_NUM_THREADS") == before
