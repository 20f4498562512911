"""Studies: simulated calibrations measured as the thesis measured them (`study` runs them and
writes their reports; `registry` lists them with the thesis's figures; the 6R and planar cases in
`samples_6r` and `samples_planar`; their conclusions in `conclusions`; the metrics in
`thesis_metrics`; Appendix D's distance-only calibration in `distance_only` and Chapter 5's
experiment in `chapter5`), the Cramer-Rao efficiency study (`montecarlo`), the simulated
calibration behind `screwcal simulate` (`simulated_calibration`), simulated measurements
(`simulated_measurements`), the real laser-tracker data set (`tracker_dataset`,
`tracker_study`) and the residual model over joint space against the physical model
(`residual_model`).

Sits on top: may import kinematics, rapid, calibration and performance; never `protocol`,
`service` or `simulators`.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "DemoResult": "simulated_calibration",
    "STUDIES": "registry",
    "TrackerData": "tracker_dataset",
    "efficiency_study": "montecarlo",
    "format_report": "simulated_calibration",
    "locate_dataset": "tracker_dataset",
    "read_tracker_dataset": "tracker_dataset",
    "run_demo": "simulated_calibration",
    "run_samples": "study",
    "run_study": "study",
    "simulate_measurements": "simulated_measurements",
    "study_table": "study",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
