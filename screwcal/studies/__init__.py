"""Studies: simulated calibrations measured as the thesis measured them (`study`), the
Cramer-Rao efficiency study (`montecarlo`), the simulated calibration behind `screwcal simulate`
(`simulated_calibration`), simulated measurements (`simulate`) and the real laser-tracker data set
(`tracker_dataset`, `tracker_study`).

Sits on top: may import kinematics, calibration and performance; never `protocol`, `service` or
`simulators`.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "DATASET_NAME": "tracker_dataset",
    "DATA_DIR_ENV": "tracker_dataset",
    "DRIFT_TOL_MM": "tracker_dataset",
    "DatasetMissingError": "tracker_dataset",
    "DemoResult": "simulated_calibration",
    "EfficiencyRow": "montecarlo",
    "FLOOR_NOTE": "study",
    "HOLE_SPACING_MM": "simulate",
    "IMPOSED": "montecarlo",
    "JOINT_FILES": "tracker_dataset",
    "JOINT_NOISE_DEG": "simulate",
    "MODELS": "tracker_study",
    "NOISE": "study",
    "NOISE_MM": "simulate",
    "PLANAR_ERRORS": "study",
    "PLANAR_VALIDATION": "study",
    "RIGIDITY_TOL_MM": "tracker_dataset",
    "Row": "study",
    "STUDIES": "study",
    "Study": "study",
    "THESIS_RESIDUAL_LM": "montecarlo",
    "TrackerData": "tracker_dataset",
    "VALIDATION": "study",
    "WHERE_TO_GET": "tracker_dataset",
    "calibrate_6r": "study",
    "case_row": "study",
    "design_conclusion": "study",
    "efficiency_study": "montecarlo",
    "errors_at": "study",
    "format_report": "simulated_calibration",
    "format_study": "tracker_study",
    "format_table": "montecarlo",
    "joints_only": "study",
    "locate_dataset": "tracker_dataset",
    "orientation_noise_rad": "simulate",
    "planar_model": "study",
    "plot": "study",
    "position_errors": "tracker_study",
    "read_tracker_dataset": "tracker_dataset",
    "residual_analysis": "tracker_study",
    "run_demo": "simulated_calibration",
    "run_samples": "study",
    "run_study": "study",
    "sample_configurations": "study",
    "sample_design": "study",
    "sample_planar": "study",
    "sample_quadrants": "study",
    "sample_replications": "study",
    "sample_sets": "study",
    "sample_solvers": "study",
    "sample_weight": "study",
    "simulate_measurements": "simulate",
    "split_half": "tracker_study",
    "summarise": "study",
    "true_robot": "simulated_calibration",
    "truth_6r": "study",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
