"""Joint readings that lag the motion (issue 11): estimated from the residuals, corrected."""

import numpy as np

from screwcal.calibration.identify import identify
from screwcal.calibration.lag import correct_lag, previous_move
from screwcal.calibration.measurements import MeasurementSet, previous_rows
from screwcal.calibration.posesets import random_configurations
from screwcal.kinematics.robots import irb120
from screwcal.studies.simulated_measurements import simulate_measurements

LAG = np.array([3e-4, 2e-4, 1e-4, 0.0, 0.0, 0.0])  # the tracker IRB 120's order


def lagging_data(lag: np.ndarray, n: int = 300, seed: int = 0) -> MeasurementSet:
    """A sequence of poses measured where the arm is, with readings that still carry `lag` of
    the move that brought it there."""
    rng = np.random.default_rng(seed)
    q_true = random_configurations(n, rng)
    measured = simulate_measurements(irb120(), q_true, rng, joint_noise_deg=0.0)
    previous = previous_rows(q_true)
    read = q_true - lag * np.nan_to_num(q_true - previous)
    return MeasurementSet(read, measured.positions_mm, measured.rotations,
                          q_previous=previous_rows(read))


def test_measurements_keep_the_previous_readings_through_take():
    data = lagging_data(LAG, n=10)
    part = data.take([3, 7])
    np.testing.assert_array_equal(part.q_previous, data.q[[2, 6]])
    assert np.isnan(data.q_previous[0]).all() and previous_move(data)[0].tolist() == [0.0] * 6


def test_auto_estimates_the_lag_and_corrects_the_readings():
    data = lagging_data(LAG)
    plain = identify(irb120(), data, kind="full", frames="known")
    fixed = identify(irb120(), data, kind="full", frames="known", lag="auto")
    assert plain.diagnostics.lag.warning  # the diagnostics see it...
    assert fixed.reading_lag is not None and "corrected" in fixed.lag_note  # ...auto fixes it
    np.testing.assert_allclose(fixed.reading_lag[:3], LAG[:3], rtol=0.35, atol=2e-5)
    assert fixed.residuals_after.mean() < 0.5 * plain.residuals_after.mean()
    again = correct_lag(data, fixed.reading_lag)  # what the fit used
    assert np.abs(again.q - data.q).max() > 0


def test_auto_leaves_readings_that_do_not_lag_alone():
    data = lagging_data(np.zeros(6))
    r = identify(irb120(), data, kind="full", frames="known", lag="auto")
    assert r.reading_lag is None and "do not lag" in r.lag_note
    unordered = MeasurementSet(data.q, data.positions_mm, data.rotations)
    r = identify(irb120(), unordered, kind="full", frames="known", lag="auto")
    assert "which pose came before" in r.lag_note


def test_a_subset_keeps_plain_line_numbers_for_the_result_file():
    import json

    data = MeasurementSet(np.zeros((4, 6)), np.zeros((4, 3)), lines=(2, 3, 4, 5))
    lines = data.take([1, 3]).lines
    assert lines == (3, 5) and all(type(v) is int for v in lines)
    json.dumps({"lines": lines})  # numpy ints here crashed `calibrate` once poses were rejected
