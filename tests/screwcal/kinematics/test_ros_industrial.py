"""The library held to ROS-Industrial's robot descriptions, and third-party URDFs read in
(issue 39).

ROSI below holds, per library robot, the numbers of the corresponding ROS-Industrial support
package's URDF (expanded from its xacro; no file copied): each revolute joint's origin (xyz m,
rpy rad) and axis, the fixed joints from the last link to tool0, and where the library's frame
sits in `base_link`. The chain is composed here with plain numpy, independently of screwcal's
reader. The LR Mate 200iD's J6 turned about +x in the library until this test (ROS-I: -x since
2016, fanuc_experimental issue 16).

`test_third_party_urdf_*` run on the expanded URDFs themselves when SCREWCAL_THIRD_PARTY_URDFS
names a folder holding them (`<stem>.urdf`, stems in THIRD_PARTY), and skip otherwise.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from screwcal.kinematics.forward import flange_kinematics, forward_kinematics
from screwcal.kinematics.robots import LIBRARY
from screwcal.kinematics.urdf import model_from_urdf, urdf_from_model

PI, HALF = np.pi, np.pi / 2
Origin = tuple[tuple[float, float, float], tuple[float, float, float]]
_ABB_TOOL0: list[Origin] = [((0, 0, 0), (0, HALF, 0))]  # link_6 -> flange -> tool0
_FANUC_TOOL0: list[Origin] = [((0, 0, 0), (PI, -HALF, 0))]
_UR_TOOL0: list[Origin] = [((0, 0, 0), (0, -HALF, -HALF)), ((0, 0, 0), (HALF, 0, HALF))]
_Z0 = (0.0, 0.0, 0.0)
_X, _Y, _Z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
_NX, _NY, _NZ = (-1, 0, 0), (0, -1, 0), (0, 0, -1)


def _abb(origins, axes=(_Z, _Y, _Y, _X, _Y, _X), tool0=_ABB_TOOL0):
    return [((xyz, _Z0), axis) for xyz, axis in zip(origins, axes, strict=True)], tool0


def _kuka(origins, flange=(0.0, 0.0, 0.0)):
    return _abb(origins, (_NZ, _Y, _Y, _NX, _Y, _NX), [(flange, _Z0), *_ABB_TOOL0])


def _fanuc(origins):
    return _abb(origins, (_Z, _Y, _NY, _NX, _NY, _NX), _FANUC_TOOL0)


def _ur(d1, a2, a3, d4, d5, d6):
    r = 1.570796327  # as ur_description's xacro writes it
    joints = [(((0, 0, 0), (0, 0, PI)), None),  # base_link -> base_link_inertia (fixed)
              (((0, 0, d1), _Z0), _Z), (((0, 0, 0), (r, 0, 0)), _Z), (((a2, 0, 0), _Z0), _Z),
              (((a3, 0, d4), _Z0), _Z), (((0, -d5, 0), (r, 0, 0)), _Z),
              (((0, d6, 0), (1.570796326589793, PI, PI)), _Z)]
    return joints, _UR_TOOL0


# name: (joints [(origin, axis; None: fixed)], link_6 -> tool0 [origin], library frame in
# base_link)
ROSI = {
    "irb120": (*_abb([(0, 0, 0), (0, 0, 0.29), (0, 0, 0.27), (0, 0, 0.07), (0.302, 0, 0),
                      (0.072, 0, 0)]), ((0, 0, 0), _Z0)),
    "irb1200": (*_abb([(0, 0, 0.3991), (0, 0, 0), (0, 0, 0.35), (0, 0, 0.042), (0.351, 0, 0),
                       (0.082, 0, 0)]), ((0, 0, 0), _Z0)),
    "irb1600": (*_abb([(0, 0, 0), (0.15, 0, 0.4865), (0, 0, 0.475), (0.3, 0, 0), (0.3, 0, 0),
                       (0.065, 0, 0)]), ((0, 0, 0), _Z0)),
    "irb2600": (*_abb([(0, 0, 0.445), (0.15, 0, 0), (0, 0, 0.7), (0, 0, 0.115), (0.795, 0, 0),
                       (0.085, 0, 0)]), ((0, 0, 0), _Z0)),
    "irb4600": (*_abb([(0, 0, 0.495), (0.175, 0, 0), (0, 0, 0.9), (0, 0, 0.175), (0.96, 0, 0),
                       (0.135, 0, 0)]), ((0, 0, 0), _Z0)),
    "irb6700": (*_abb([(0, 0, 0.78), (0.32, 0, 0), (0, 0, 1.125), (0, 0, 0.2), (1.1425, 0, 0),
                       (0.2, 0, 0)]), ((0, 0, 0), _Z0)),
    "kr6-r900": (*_kuka([(0, 0, 0.4), (0.025, 0, 0), (0.455, 0, 0), (0, 0, 0.035),
                         (0.42, 0, 0), (0.08, 0, 0)]), ((0, 0, 0), _Z0)),
    "kr10-r900": (*_kuka([(0, 0, 0.4), (0.025, 0, 0), (0.455, 0, 0), (0, 0, 0.035),
                          (0.42, 0, 0), (0.08, 0, 0)]), ((0, 0, 0), _Z0)),  # the KR 6's arm
    "kr16": (*_kuka([(0, 0, 0.675), (0.26, 0, 0), (0.68, 0, 0), (0.67, 0, -0.035), (0, 0, 0),
                     (0, 0, 0)], flange=(0.158, 0, 0)), ((0, 0, 0), _Z0)),
    "lrmate200id": (*_fanuc([(0, 0, 0.33), (0.05, 0, 0), (0, 0, 0.33), (0, 0, 0.035),
                             (0.335, 0, 0), (0.08, 0, 0)]), ((0, 0, 0), _Z0)),
    "m20ia": (*_fanuc([(0, 0, 0.525), (0.15, 0, 0), (0, 0, 0.79), (0, 0, 0.25), (0.835, 0, 0),
                       (0.1, 0, 0)]), ((0, 0, 0), _Z0)),
    # UR: the library is in the controller's base frame, URDF `base`: Rz(pi) in base_link
    "ur5e": (*_ur(0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996), ((0, 0, 0), (0, 0, PI))),
    "ur10e": (*_ur(0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),
              ((0, 0, 0), (0, 0, PI))),
}


def _T(origin: Origin) -> np.ndarray:
    (x, y, z), (r, p, yaw) = origin
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(yaw), np.sin(yaw)
    T = np.eye(4)
    T[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                 [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                 [-sp, cp * sr, cp * cr]]
    T[:3, 3] = [1000.0 * x, 1000.0 * y, 1000.0 * z]
    return T


# ROS-I's `base` link (the controller's frame) in base_link: FANUC's World in J2's plane, UR's
# base turned 180 deg; ABB's and KUKA's files place it on base_link
ROSI_BASE = {"lrmate200id": ((0, 0, 0.33), _Z0), "m20ia": ((0, 0, 0.525), _Z0),
             "ur5e": ((0, 0, 0), (0, 0, PI)), "ur10e": ((0, 0, 0), (0, 0, PI))}


def _rosi_at_zero(name: str, link: str | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint directions, points on the axes and tool0, all at zero, in the library's frame
    (or in ROS-I's `link`: base_link or base)."""
    joints, tool0, frame = ROSI[name]
    if link is not None:
        frame = ROSI_BASE.get(name, ((0, 0, 0), _Z0)) if link == "base" else ((0, 0, 0), _Z0)
    A = np.linalg.inv(_T(frame))
    dirs, points = [], []
    for origin, axis in joints:
        A = A @ _T(origin)
        if axis is None:
            continue
        dirs.append(A[:3, :3] @ np.array(axis, float))
        points.append(A[:3, 3].copy())
    for origin in tool0:
        A = A @ _T(origin)
    return np.array(dirs), np.array(points), A


def test_every_library_robot_has_its_ros_industrial_numbers():
    assert set(ROSI) == set(LIBRARY)


@pytest.mark.parametrize("name", sorted(ROSI))
def test_library_robot_turns_and_stands_as_ros_industrial_describes_it(name):
    """Same joint directions (sign included), the same axis lines, the same tool0 at zero."""
    model = LIBRARY[name].model()
    dirs, points, tool0 = _rosi_at_zero(name)
    np.testing.assert_allclose(model.axis_dirs, dirs, atol=1e-9)
    for w, p, q in zip(model.axis_dirs, model.axis_points_mm, points, strict=True):
        assert np.linalg.norm(np.cross(p - q, w)) < 1e-6  # q on the library's axis line
    np.testing.assert_allclose(model.home_flange[:3, 3], tool0[:3, 3], atol=1e-6)
    np.testing.assert_allclose(model.home_flange[:3, :3], tool0[:3, :3], atol=1e-9)


@pytest.mark.parametrize("link", ["base_link", "base"])
@pytest.mark.parametrize("name", sorted(ROSI))
def test_library_robot_in_each_frame_a_controller_or_ros_reports_in(name, link):
    """`robot import NAME --base-link base|base_link`: the robot written in ROS-I's frame of
    that name (FANUC's World 330 / 525 mm above base_link, UR's base turned 180 deg)."""
    entry = LIBRARY[name]
    model = entry.model_in(link)
    dirs, points, tool0 = _rosi_at_zero(name, link)
    np.testing.assert_allclose(model.axis_dirs, dirs, atol=1e-9)
    for w, p, q in zip(model.axis_dirs, model.axis_points_mm, points, strict=True):
        assert np.linalg.norm(np.cross(p - q, w)) < 1e-6
    np.testing.assert_allclose(model.home_flange, tool0, atol=1e-6)
    q = np.random.default_rng(5).uniform(-1, 1, (50, 6))  # the robot itself has not moved
    nominal = entry.model()
    np.testing.assert_allclose(forward_kinematics(model, q), forward_kinematics(nominal, q),
                               atol=1e-9)


def test_lr_mate_turns_j6_as_the_m20ia_does():
    """fanuc_experimental issue 16 (2016): every 6-axis LR Mate's J6 turns about -x."""
    assert LIBRARY["lrmate200id"].model().axis_dirs[5].tolist() == [-1, 0, 0]
    q = np.radians([[0, 0, 0, 0, 0, 90]])
    T = flange_kinematics(LIBRARY["lrmate200id"].model(), q)[0]
    np.testing.assert_allclose(T[:3, 0], [0, 1, 0], atol=1e-12)  # x (up at zero) turns to +y


# The third-party URDFs: stem -> the library robot ROS-I's file describes (None: not in it)
THIRD_PARTY = {
    "irb120": "irb120", "irb1200": "irb1200", "irb1600": "irb1600", "irb2400": None,
    "irb2600": "irb2600", "irb4600": "irb4600", "irb6640": None, "irb6700": "irb6700",
    "kr6r900sixx": "kr6-r900", "kr10r900_2": None, "kr10r1100sixx": None, "kr16_2": "kr16",
    "kr210l150": None, "lbr_iiwa_14_r820": None, "lrmate200id": "lrmate200id", "m10ia": None,
    "m20ia": "m20ia", "ur5e": "ur5e", "ur10e": "ur10e",
}
_FOLDER = os.environ.get("SCREWCAL_THIRD_PARTY_URDFS", "")


def _third_party(stem: str) -> Path:
    path = Path(_FOLDER) / f"{stem}.urdf"
    if not _FOLDER or not path.is_file():
        pytest.skip(f"{stem}.urdf not in SCREWCAL_THIRD_PARTY_URDFS ({_FOLDER or 'unset'})")
    return path


def _rotation_deg(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return np.degrees(Rotation.from_matrix(np.swapaxes(A, -1, -2) @ B).magnitude())


@pytest.mark.parametrize("stem", sorted(THIRD_PARTY))
def test_third_party_urdf_imports_to_the_fk_of_a_urdf_library(stem, rng):
    """tool0 (else flange) in base_link: within 1e-5 mm and 1e-5 deg of yourdfpy's over 50
    configurations inside the limits; exported and read back within 1e-5 mm too, with the
    file's joint names, efforts and speeds."""
    yourdfpy = pytest.importorskip("yourdfpy")
    path = _third_party(stem)
    model, _ = model_from_urdf(path.read_text(encoding="utf-8"), str(path))
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False,
                              load_collision_meshes=False)
    tip = "tool0" if "tool0" in urdf.link_map else "flange"
    q = rng.uniform(model.limits[:, 0], model.limits[:, 1], (50, model.n_joints))
    ours = flange_kinematics(model, q)
    for k in range(len(q)):
        urdf.update_cfg(dict(zip(urdf.actuated_joint_names, q[k], strict=True)))
        T = urdf.get_transform(tip, "base_link")
        assert np.abs(T[:3, 3] * 1000.0 - ours[k, :3, 3]).max() < 1e-5
        assert _rotation_deg(T[:3, :3], ours[k, :3, :3]) < 1e-5
    back, _ = model_from_urdf(urdf_from_model(model), "export")
    assert [r.name for r in back.ratings] == urdf.actuated_joint_names  # names kept
    assert [(r.effort, r.velocity) for r in back.ratings] == \
        [(r.effort, r.velocity) for r in model.ratings]
    again = flange_kinematics(back, q)
    assert np.abs(again[:, :3, 3] - ours[:, :3, 3]).max() < 1e-5
    assert _rotation_deg(again[:, :3, :3], ours[:, :3, :3]).max() < 1e-5


@pytest.mark.parametrize("stem", sorted(s for s, n in THIRD_PARTY.items() if n))
def test_third_party_urdf_matches_its_library_robot(stem):
    """The file read by screwcal, in the library's frame, against the library entry: the
    written-in numbers of ROSI above are the file's."""
    path = _third_party(stem)
    name = THIRD_PARTY[stem]
    model, notes = model_from_urdf(path.read_text(encoding="utf-8"), str(path))
    dirs, points, tool0 = _rosi_at_zero(name)
    frame = _T(ROSI[name][2])  # the library's frame in base_link
    np.testing.assert_allclose(model.axis_dirs, dirs @ frame[:3, :3].T, atol=1e-9)
    in_file = points @ frame[:3, :3].T + frame[:3, 3]
    np.testing.assert_allclose(model.axis_points_mm, in_file, atol=1e-6)  # the joint origins
    np.testing.assert_allclose(model.home_flange, frame @ tool0, atol=1e-6)
    np.testing.assert_allclose(model.limits_deg, ROSI_LIMITS_DEG[name], atol=0.06)
    in_base, _ = model_from_urdf(path.read_bytes(), str(path), base_link="base")
    np.testing.assert_allclose(in_base.home_flange, _rosi_at_zero(name, "base")[2], atol=1e-6)
    if name in ROSI_BASE:  # the import says where the controller's frame is
        assert any("--base-link base" in n for n in notes), notes


# ROS-I's joint limits (deg; its files' radians agree within 0.06 deg)
ROSI_LIMITS_DEG = {
    "irb120": [[-165, 165], [-110, 110], [-110, 70], [-160, 160], [-120, 120], [-400, 400]],
    "irb1200": [[-170, 170], [-100, 135], [-200, 70], [-270, 270], [-130, 130], [-360, 360]],
    "irb1600": [[-180, 180], [-63, 110], [-235, 55], [-200, 200], [-115, 115], [-400, 400]],
    "irb2600": [[-180, 180], [-155, 95], [-155, 75], [-400, 400], [-120, 120], [-400, 400]],
    "irb4600": [[-180, 180], [-90, 150], [-180, 75], [-400, 400], [-125, 120], [-400, 400]],
    "irb6700": [[-170, 170], [-65, 85], [-180, 70], [-300, 300], [-130, 130], [-360, 360]],
    "kr6-r900": [[-170, 170], [-190, 45], [-120, 156], [-185, 185], [-120, 120], [-350, 350]],
    "kr10-r900": [[-170, 170], [-190, 45], [-120, 156], [-185, 185], [-120, 120], [-350, 350]],
    "kr16": [[-185, 185], [-155, 35], [-130, 154], [-350, 350], [-130, 130], [-350, 350]],
    "lrmate200id": [[-170, 170], [-100, 145], [-70, 205], [-190, 190], [-125, 125],
                    [-360, 360]],
    "m20ia": [[-170, 170], [-100, 160], [-185, 273.12], [-200, 200], [-140, 140], [-270, 270]],
    "ur5e": [[-360, 360]] * 2 + [[-180, 180]] + [[-360, 360]] * 3,
    "ur10e": [[-360, 360]] * 2 + [[-180, 180]] + [[-360, 360]] * 3,
}
# where the library keeps the maker's datasheet over ROS-I's file, and why: (robot, joint)
DATASHEET_OVER_ROSI = {
    ("irb1200", 6): "ABB's axis 6 default +-400 deg; ROS-I +-360",
    ("irb1600", 2): "IRB 1600-6/1.2: axis 2 +150/-90; ROS-I's 6_12 file has the 1.45 m arm's",
    ("irb1600", 3): "IRB 1600-6/1.2: axis 3 +65/-245; ROS-I's 6_12 file has the 1.45 m arm's",
    ("irb2600", 2): "IRB 2600 axis 2 +155/-95 (forward positive); ROS-I's file has it mirrored",
    ("irb2600", 3): "IRB 2600 axis 3 +75/-180; ROS-I -155",
    ("lrmate200id", 3): "datasheet J3 range 420 deg (-140/+280, FANUC's J3 taken on the serial "
                        "angle); ROS-I's 2019 'spec' limits -70/+205",
    ("ur5e", 3): "UR's datasheet +-360 on every joint; ROS-I +-180 on the elbow",
    ("ur10e", 3): "UR's datasheet +-360 on every joint; ROS-I +-180 on the elbow",
}


@pytest.mark.parametrize("name", sorted(ROSI_LIMITS_DEG))
def test_library_limits_are_ros_industrials_or_the_datasheets_for_a_stated_reason(name):
    model = LIBRARY[name].model()
    for j, (ours, theirs) in enumerate(zip(model.limits_deg, ROSI_LIMITS_DEG[name],
                                           strict=True), 1):
        same = np.allclose(ours, theirs, atol=0.15)
        assert same != ((name, j) in DATASHEET_OVER_ROSI), (name, j, ours.tolist(), theirs)
