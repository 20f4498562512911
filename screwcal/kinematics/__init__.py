"""Kinematics: screws and rigid motions (`se3`), poses in mm/deg (`pose`), the serial model
(`model`), forward kinematics and Jacobians (`forward`), DH conversions (`dh`), inverse kinematics
(`ik`, its solutions in `ik_solutions`, the closed form in `wrist_partitioned`), the built-in
robots (`robots`), model files (`modelfile`) and their schema (`modelschema`).

May import: numpy, scipy, pydantic, and of ours only `screwcal.errors` and this package. It
knows nothing of calibration, performance testing, studies or the command line.
"""

from screwcal._lazy import lazy_exports

_EXPORTS = {
    "Array": "se3",
    "BUILTIN_MODELS": "robots",
    "COMPLIANCE_UNIT": "compliance",
    "DHRow": "dh",
    "DHTable": "dh",
    "IKSolutions": "ik_solutions",
    "LumpedMass": "compliance",
    "Payload": "compliance",
    "SerialModel": "model",
    "builtin_model": "robots",
    "closed_form_ik": "ik",
    "confdata": "confdata",
    "dh_from_model": "dh",
    "euler_zyx_deg_from_rotation": "pose",
    "exp_twist": "se3",
    "flange_kinematics": "forward",
    "forward_kinematics": "forward",
    "invert_transform": "se3",
    "irb120": "robots",
    "irb1600": "robots",
    "load_model": "modelfile",
    "model_document": "modelfile",
    "model_from_dh": "dh",
    "numerical_ik": "ik",
    "parse_model": "modelfile",
    "point_jacobian": "forward",
    "pose_from_transform": "pose",
    "quaternion_wxyz_from_rotation": "se3",
    "resolve_model": "modelfile",
    "rotation_angle_deg": "pose",
    "rotation_from_euler_zyx_deg": "pose",
    "rotation_from_quaternion_wxyz": "pose",
    "save_model": "modelfile",
    "solution_for_confdata": "confdata",
    "spatial_jacobian": "forward",
    "transform_from_pose": "pose",
    "transform_points": "se3",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
