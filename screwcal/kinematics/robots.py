"""Built-in nominal models, as ABB's product specifications give them (IRB 1600-6/1.2, IRB 120).

Both are ABB 6R arms: joint 1 about +z, joints 2 and 3 about +y, a spherical wrist x-y-x, and the
flange (tool0) at home with orientation Ry(+90 deg).
"""

from __future__ import annotations

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import ROBOT_MASSES
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import transform_from_pose

_X, _Y, _Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def irb1600() -> SerialModel:
    """ABB IRB 1600 (1.2 m reach). Home flange (815, 0, 961.5) mm, Ry(+90 deg)."""
    return SerialModel(
        name="irb1600",
        joint_types=("R",) * 6,
        axis_dirs=np.array([_Z, _Y, _Y, _X, _Y, _X]),
        axis_points_mm=np.array([[0, 0, 0], [150, 0, 486.5], [150, 0, 961.5],
                                 [0, 0, 961.5], [750, 0, 961.5], [0, 0, 961.5]], dtype=float),
        home_flange=transform_from_pose([815.0, 0.0, 961.5, 0.0, 90.0, 0.0]),
        limits=np.radians([[-180, 180], [-90, 150], [-245, 65],
                           [-200, 200], [-115, 115], [-400, 400]]),
        masses=ROBOT_MASSES["irb1600"],
    )


def irb120() -> SerialModel:
    """ABB IRB 120. Home flange (374, 0, 630) mm, Ry(+90 deg)."""
    return SerialModel(
        name="irb120",
        joint_types=("R",) * 6,
        axis_dirs=np.array([_Z, _Y, _Y, _X, _Y, _X]),
        axis_points_mm=np.array([[0, 0, 0], [0, 0, 290], [0, 0, 560],
                                 [0, 0, 630], [302, 0, 630], [0, 0, 630]], dtype=float),
        home_flange=transform_from_pose([374.0, 0.0, 630.0, 0.0, 90.0, 0.0]),
        limits=np.radians([[-165, 165], [-110, 110], [-110, 70],
                           [-160, 160], [-120, 120], [-400, 400]]),
        masses=ROBOT_MASSES["irb120"],
    )


BUILTIN_MODELS = {"irb1600": irb1600, "irb120": irb120}


def builtin_model(name: str) -> SerialModel:
    """A built-in nominal model by name."""
    try:
        return BUILTIN_MODELS[name]()
    except KeyError:
        raise ModelError(f"unknown built-in robot '{name}'; choose one of "
                         f"{', '.join(sorted(BUILTIN_MODELS))} or give a model file") from None
