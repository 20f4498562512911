"""Performance testing: ISO 9283 pose accuracy and repeatability (`iso9283`) and drift of pose
characteristics (`drift`), ISO 12780-1 straightness (`straightness`), the test cube and its pose
list (`testcube`), the performance file and report (`evaluate`), plots (`plots`).

May import: `screwcal.kinematics`, `screwcal.errors`, `screwcal.tables`; never calibration,
studies, commands, nor `protocol`, `service` or `simulators`.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "ArmSphere": "testcube",
    "DriftSeries": "drift",
    "PerformanceData": "evaluate",
    "PoseMetrics": "iso9283",
    "PosePlan": "testcube",
    "Straightness": "straightness",
    "TestCube": "testcube",
    "build_report": "evaluate",
    "drift_series": "drift",
    "find_test_cube": "testcube",
    "performance_pose_list": "testcube",
    "pose_metrics": "iso9283",
    "read_path_csv": "evaluate",
    "read_performance_csv": "evaluate",
    "straightness": "straightness",
    "summarise": "evaluate",
    "write_pose_list": "testcube",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
