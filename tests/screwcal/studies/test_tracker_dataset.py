import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from screwcal.calibration.diagnostics import JointLag
from screwcal.calibration.identify import identify
from screwcal.errors import DataFileError
from screwcal.kinematics.robots import irb120
from screwcal.studies import small_sets
from screwcal.studies.tracker_dataset import (
    DatasetMissingError,
    locate_dataset,
    read_tracker_dataset,
)
from screwcal.studies.tracker_study import run_study
from tests.conftest import TRACKER_DATA, needs_tracker_data

DATA = TRACKER_DATA
needs_data = needs_tracker_data


def test_missing_data_set_says_where_to_get_it(tmp_path, monkeypatch):
    monkeypatch.delenv("SCREWCAL_DATA_DIR", raising=False)
    with pytest.raises(DatasetMissingError, match=r"SCREWCAL_DATA_DIR.*icelinker"):
        locate_dataset()
    with pytest.raises(DatasetMissingError, match=rf"{re.escape(str(tmp_path))}.*icelinker"):
        locate_dataset(tmp_path)


@needs_data
def test_data_set_found_by_folder_or_its_parent(monkeypatch):
    assert locate_dataset(DATA) == DATA
    monkeypatch.setenv("SCREWCAL_DATA_DIR", str(DATA.parent))
    assert locate_dataset() == DATA


def _copy(tmp_path: Path) -> Path:
    folder = tmp_path / "set"
    shutil.copytree(DATA, folder)
    return folder


@needs_data
def test_import_flags_the_bad_base_rows_and_says_so():
    d = read_tracker_dataset(DATA)
    assert len(d.q_deg) == 1000
    # 2 rows of base reflector 2 and 16 of base reflector 3 are metres off (README).
    assert len(d.rejected) == 18
    assert {251, 708} <= set(d.rejected)
    assert all("base reflector" in why for why in d.rejected.values())
    assert "row 252: base reflector 2" in d.report()
    m = d.measurements()
    assert len(m) == 982 and "252" not in m.ids and m.full_pose
    # The reflector frame's origin is reflector 1 (as read, or moved back by the tracker's
    # drift, which the base reflectors measure: some hundredths of a mm).
    np.testing.assert_allclose(d.measurements(drift="none").positions_mm[0], d.smr_mm[0, 0])
    np.testing.assert_allclose(m.positions_mm[0], d.smr_mm[0, 0], atol=0.05)
    assert 0.0 < np.abs(m.positions_mm[0] - d.smr_mm[0, 0]).max()
    assert 0.02 < d.base_drift_mm() < 0.2


@needs_data
def test_import_refuses_broken_files_and_flags_a_moved_reflector(tmp_path):
    folder = _copy(tmp_path)
    smr = np.loadtxt(folder / "measured_SMR_2.txt")
    smr[10] += [0.0, 0.5, 0.0]  # the tool triangle is no longer rigid in row 11
    np.savetxt(folder / "measured_SMR_2.txt", smr)
    assert "tool reflector spacing" in read_tracker_dataset(folder).rejected[10]
    (folder / "measured_SMR_3.txt").write_text("1 2\n")
    with pytest.raises(DataFileError, match=r"measured_SMR_3\.txt: 2 columns where 3"):
        read_tracker_dataset(folder)
    (folder / "measured_joints.txt").unlink()
    with pytest.raises(DataFileError, match=r"measured_joints\.txt: file not found"):
        read_tracker_dataset(folder)


@pytest.fixture(scope="module")
def measured_study() -> dict:
    """The study of the data set as read (the read-back joints), seed 0: the two slow tests
    below read it, in one worker (their xdist_group), so it is run once."""
    return run_study(read_tracker_dataset(DATA, joints="measured"), seed=0)


@needs_data
@pytest.mark.slow
@pytest.mark.xdist_group("tracker study, measured joints")
def test_real_robot_held_out_accuracy(measured_study):
    """Calibrate on a random half, validate on the other (README of the data set)."""
    s = measured_study
    frames, thesis, full = (s["models"][k]["mean"] for k in ("frames", "thesis", "full"))
    assert 0.70 < frames < 0.85  # the uncalibrated robot: about 0.75 mm
    assert full <= 0.45  # issue 3's target for the full model
    assert full < thesis < frames
    assert all(m["converged"] for m in s["models"].values())
    assert s["models"]["full"]["rank"] == 30


@needs_data
@pytest.mark.slow
@pytest.mark.xdist_group("tracker study, measured joints")
def test_commanded_joints_predict_better_and_the_lag_is_reported(measured_study):
    """The read-back joints lag the motion: joint 1's residual follows its previous move with
    them, not with the commanded joints, which predict held-out poses better (about 0.19
    against 0.45 mm)."""
    measured = read_tracker_dataset(DATA, joints="measured")
    commanded = read_tracker_dataset(DATA, joints="commanded")
    assert np.abs(measured.q_deg - commanded.q_deg).max() > 0.1
    both = {"measured": measured_study["models"],
            "commanded": run_study(commanded, seed=0)["models"]}
    s_measured, s_commanded = both["measured"]["full"], both["commanded"]["full"]
    assert s_commanded["mean"] < 0.2 < 0.4 < s_measured["mean"] <= 0.45
    # gravity bends joints 2 and 3: with their compliance identified (auto keeps it; with the
    # commanded joints, per arm mass) both joint files predict better (issue 11: commanded
    # 0.178 -> 0.095, measured 0.443 -> 0.386 mm, tracker drift corrected)
    for models in both.values():
        bent = models["full+c"]
        assert {n[:3] for n, _, _ in bent["compliance"]} == {"J2c", "J3c"}
        assert max(abs(v) / sd for _, v, sd in bent["compliance"]) > 5
        assert bent["mean"] < 0.9 * models["full"]["mean"]
    assert "per joint and arm mass" in both["commanded"]["full+c"]["compliance_note"]
    assert both["commanded"]["full+c"]["mean"] <= 0.10  # issue 11's target
    assert both["measured"]["full+c"]["mean"] < 0.40
    # the read-back joints lag the motion: estimated and corrected (0.388 -> 0.278 mm; issue
    # 11's target 0.37), while the commanded ones are left as they are
    assert both["measured"]["full+c+lag"]["mean"] < 0.30
    assert "corrected" in both["measured"]["full+c+lag"]["lag_note"]

    def lag_of_joint_1(dataset) -> JointLag:
        r = identify(irb120(), dataset.measurements(), kind="full")  # in acquisition order
        assert r.diagnostics is not None
        return r.diagnostics.lag.per_joint[0]

    assert lag_of_joint_1(measured).flagged
    assert not lag_of_joint_1(commanded).flagged


@needs_data
def test_small_real_subsets_predict_better_with_the_learned_prior_scale():
    """Issue 26, point 6, on the real robot (`python -m screwcal.studies.small_sets`): 36-pose
    subsets of the tracker set, position only, 3-fold cross-validation (fits on 24 poses). The
    learned prior scale (identify's default on such a set) predicts the held-out poses better
    than the plausible ranges' scale (three subsets: 0.518 against 0.559 mm; twelve: 0.495
    against 0.524, and 0.909x a plain full calibration's 0.545), and a fit of 600 other poses
    better still (the floor)."""
    data = read_tracker_dataset(DATA).measurements(full_pose=False)
    results = small_sets.run(data, subsets=3)
    mean = {name: float(np.mean(v)) for name, v in results.items()}
    assert mean["learned scale"] < 0.95 * mean["plausible scale"] < mean["plain"], mean
    assert mean[small_sets.FLOOR] < mean["learned scale"], mean
    assert "share of plain" in small_sets.format_table(results, 36)
