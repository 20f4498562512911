import csv

import numpy as np
import pytest

from screwcal.calibration.design import d_optimal, log_det
from screwcal.calibration.posesets import cube_set, quadrant_variants
from screwcal.kinematics.robots import irb1600
from screwcal.studies.study import STUDIES, run_samples, run_study


@pytest.mark.parametrize("name", sorted(set(STUDIES) - {"solvers"}))  # solvers: below
def test_every_study_runs_and_is_reproducible_from_its_seed(name):
    def results(rows):  # run times are measured, not reproduced
        return [{k: v for k, v in r.items() if k != "seconds"} for r in rows]

    a = run_samples(name, seed=7, samples=1, workers=1)
    b = run_samples(name, seed=7, samples=1, workers=1)
    assert a and str(results(a)) == str(results(b))  # (str: a nan equals a nan)


def test_a_study_writes_csv_markdown_and_png(tmp_path):
    text = run_study("quadrants", seed=3, samples=2, workers=2, out=tmp_path)
    assert "| quadrants |" in text and "± " in text
    with (tmp_path / "quadrants.csv").open() as f:
        assert len(list(csv.DictReader(f))) == 2 * 3
    assert (tmp_path / "quadrants.png").stat().st_size > 5000


def test_the_pool_gives_the_same_samples_as_one_process():
    assert run_samples("weight", 11, 2, 1) == run_samples("weight", 11, 2, 2)


def test_pose_sets_stay_in_their_cube_and_limits():
    m = irb1600()
    for name in ("Klimchik", "C1", "C2"):
        q = cube_set(m, name, 40, seed=1)
        assert q.shape == (40, 6) and m.within_limits(q).all()
    q4 = quadrant_variants(cube_set(m, "Klimchik", 40, seed=1), 4)
    assert len(np.unique(np.round(np.degrees(q4[:, 0]) // 90))) >= 3


def test_d_optimal_design_beats_the_klimchik_style_set_on_information():
    m = irb1600()
    pool = cube_set(m, "Klimchik", 600, seed=2, spread=False)
    designed = d_optimal(m, pool, 40)
    assert designed.log_det > log_det(m, cube_set(m, "Klimchik", 40, seed=2))


def test_a_dask_cluster_gives_the_same_samples():
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster:
        on_cluster = run_samples("quadrants", 5, 2, 1, scheduler=cluster.scheduler_address)
    assert on_cluster == run_samples("quadrants", 5, 2, 1)
