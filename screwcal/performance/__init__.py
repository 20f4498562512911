"""Performance testing: ISO 9283 pose accuracy and repeatability (`iso9283`), ISO 12780-1
straightness (`straightness`), the test cube and its pose list (`testcube`), the performance file
and report (`evaluate`), plots (`plots`).

May import: `screwcal.kinematics`, `screwcal.errors`, `screwcal.tables`; never calibration,
studies, commands, nor `protocol`, `service` or `simulators`.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "ATTAINED_ORIENTATION": "evaluate",
    "ATTAINED_POSITION": "evaluate",
    "ArmSphere": "testcube",
    "CMD": "evaluate",
    "CYCLE_ORDER": "testcube",
    "DIAGONAL_FRACTION": "testcube",
    "FLANGE_DOWN_DEG": "testcube",
    "InfeasibleCubeError": "testcube",
    "POSE_LIST_COLUMNS": "testcube",
    "PerformanceData": "evaluate",
    "PointData": "evaluate",
    "PoseMetrics": "iso9283",
    "PosePlan": "testcube",
    "Straightness": "straightness",
    "TestCube": "testcube",
    "accuracy_per_point": "plots",
    "attained_vs_commanded": "plots",
    "build_report": "evaluate",
    "calibration_residuals": "plots",
    "find_test_cube": "testcube",
    "performance_pose_list": "testcube",
    "point_metrics": "evaluate",
    "pose_metrics": "iso9283",
    "read_path_csv": "evaluate",
    "read_performance_csv": "evaluate",
    "straightness": "straightness",
    "straightness_along_path": "plots",
    "summarise": "evaluate",
    "test_cube": "plots",
    "wrap_deg": "iso9283",
    "write_pose_list": "testcube",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
