"""Calibration: measurements, error models (`error_parameters`, `virtual_joints`), identification
(`identify` over its parts: `identify_settings`, `residual_problem`, `noise_levels`, `solvers`,
`single_fit`, `identify_result`; with `identifiability` and `initial_frames`), the measuring
flange (`flange`), base alignment by hand (`base_alignment`), the correction of the robot
(`correction`), pose sets and their design (`posesets`, `design`). Its errors are in
`screwcal.errors`.

May import: `screwcal.kinematics`, `screwcal.rapid` (the RAPID parser), `screwcal.programs`
(the readers of other makers' programs), `screwcal.errors`,
`screwcal.tables`; never performance, studies, commands, nor `protocol`, `service` or `simulators`.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "BacklashEstimate": "backlash",
    "CalibrationResult": "identify_result",
    "Compensation": "correction",
    "Design": "design",
    "ErrorModel": "error_parameters",
    "FilterReport": "rapid_filter",
    "JointCorrection": "correction",
    "MeasurementSet": "measurements",
    "MeasuringFlange": "flange",
    "ModelKind": "error_parameters",
    "NoiseModel": "identify_settings",
    "Param": "error_parameters",
    "PlausibleRanges": "plausible",
    "THESIS_TABLE11": "virtual_joints",
    "after_zero": "correction",
    "apply_virtual_joints": "virtual_joints",
    "backlash_from_pairs": "backlash",
    "base_from_sweeps": "base_alignment",
    "candidate_params": "error_parameters",
    "compensate": "correction",
    "compensate_each": "correction",
    "correct_lag": "lag",
    "cube_set": "posesets",
    "d_optimal": "design",
    "data_warnings": "degenerate",
    "filter_rapid": "rapid_filter",
    "frame_from_holes": "flange",
    "identify": "identify",
    "joint_correction": "correction",
    "random_configurations": "posesets",
    "random_set": "posesets",
    "read_measurements_csv": "measurements",
    "read_sweeps_csv": "base_alignment",
    "result_document": "resultfile",
    "structural_rank": "identifiability",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
