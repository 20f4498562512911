"""The drift alarm's rule on histories written out (service/history.py)."""

from service.history import HistoryEntry, drift_alarm


def entry(job: int, ap: float | None, version: int | None = None) -> HistoryEntry:
    return HistoryEntry(job=job, kind="procedure" if version else "performance", state="done",
                        created=float(job), software="screwcal 0", poses={}, ap_mm=ap,
                        model_version=version)


def test_the_alarm_compares_the_newest_ap_with_what_the_newest_model_reached():
    entries = [entry(1, 0.3, version=1), entry(2, 0.35), entry(3, 0.9)]
    alarm = drift_alarm(entries, threshold_mm=0.5)
    assert alarm is not None and (alarm.baseline_ap_mm, alarm.latest_job) == (0.3, 3)
    assert drift_alarm(entries, threshold_mm=0.7) is None
    assert drift_alarm(entries[:2], threshold_mm=0.01) is not None  # 0.05 worse than 0.01
    # a newer model resets the baseline: the drift before it no longer counts
    assert drift_alarm([*entries, entry(4, 0.2, version=2)], threshold_mm=0.5) is None


def test_a_calibration_alone_takes_the_first_ap_after_it_as_its_baseline():
    calibration = entry(1, None, version=1)
    assert drift_alarm([calibration], 0.5) is None
    assert drift_alarm([calibration, entry(2, 0.4)], 0.5) is None  # the baseline itself
    alarm = drift_alarm([calibration, entry(2, 0.4), entry(3, 1.0)], 0.5)
    assert alarm is not None and alarm.baseline_ap_mm == 0.4 and "model 1" in alarm.message
    # no model yet: nothing to compare with
    assert drift_alarm([entry(1, 0.3), entry(2, 5.0)], 0.5) is None
