"""Calibration: measurements, error models (`errors_model`, `virtual_joints`), identification
(`identify`, `identifiability`, `alignment`), the measuring flange (`flange`), base alignment by
hand (`base_alignment`), the correction of the robot (`correction`), pose sets and their design
(`posesets`, `design`).

May import: `screwcal.kinematics`, `screwcal.errors`, `screwcal.tables`; never performance,
studies, commands, nor `protocol`, `service` or `simulators`.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "AlignmentError": "base_alignment",
    "CUBES_MM": "posesets",
    "CUBE_EDGE_MM": "posesets",
    "CalibrationResult": "identify",
    "Circle": "base_alignment",
    "Compensation": "correction",
    "CorrectionRefusedError": "correction",
    "DEFAULT_HOLES_IN_FLANGE_MM": "flange",
    "Design": "design",
    "ErrorModel": "errors_model",
    "FlangeError": "flange",
    "Frames": "identify",
    "IdentificationError": "identify",
    "JointCorrection": "correction",
    "MAX_STD_ERROR_DEG": "correction",
    "MIN_ANGLE_DEG": "flange",
    "MIN_SEPARATION_MM": "flange",
    "MeasurementSet": "measurements",
    "MeasuringFlange": "flange",
    "ModelKind": "errors_model",
    "NoiseModel": "identify",
    "PLANAR_SETS_DEG": "posesets",
    "PLAUSIBLE_OFFSET_DEG": "correction",
    "Param": "errors_model",
    "RANK_TOL": "identifiability",
    "Residual": "identifiability",
    "SWEEP_COLUMNS": "base_alignment",
    "THESIS_JOINT_OFFSETS": "errors_model",
    "THESIS_LINK_OFFSETS": "errors_model",
    "THESIS_TABLE11": "virtual_joints",
    "WORKING_REGION_DEG": "posesets",
    "align_frames": "alignment",
    "apply_virtual_joints": "virtual_joints",
    "base_from_sweeps": "base_alignment",
    "candidate_params": "errors_model",
    "check_holes": "flange",
    "compensate": "correction",
    "cube_set": "posesets",
    "d_optimal": "design",
    "explain_removed": "identifiability",
    "fit_circle": "base_alignment",
    "forward_batch": "errors_model",
    "frame_from_holes": "flange",
    "hole_distances": "flange",
    "identify": "identify",
    "joint_correction": "correction",
    "log_det": "design",
    "pairs": "identifiability",
    "parse_name": "virtual_joints",
    "quadrant_variants": "posesets",
    "random_configurations": "posesets",
    "random_set": "posesets",
    "read_measurements_csv": "measurements",
    "read_sweeps_csv": "base_alignment",
    "select_identifiable": "identifiability",
    "structural_rank": "identifiability",
    "svd": "identifiability",
    "whitened_blocks": "design",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
