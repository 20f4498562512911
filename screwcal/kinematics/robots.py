"""The robot library: common 6R arms with their published nominal geometry, limits and masses.

Each entry is built from the figures of the maker's product specification / datasheet (lengths
of the dimension drawing, axis working ranges, the arm's mass) and names where they come from
(`source`). A test holds each one to a datasheet figure it was not built from where one exists
(the reach: the wrist centre's largest distance from axis 1), else to the home flange position.

Conventions: robot base frame as the maker draws it (z up, x forward), joint directions as the
controller counts positive (as ROS-Industrial's support packages give them); tool0 (the flange)
at home with z along base +x, x down (ABB, KUKA: Ry(+90 deg)) or up (FANUC), UR's DH frame 6 for
the UR arms.

Lumped masses (joint compliance, `compliance`): the datasheets give the arm's total mass only;
the upper arm, forearm and wrist take 16 %, 14 % and 2.4 % of it at their middles (the shares of
the IRB 1600 table), except the IRB 1600 / IRB 120 tables kept as they were. The identified
compliance absorbs the scale; only the shape of the torques matters.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.compliance import ROBOT_MASSES, LumpedMass
from screwcal.kinematics.dh import DHRow, DHTable, model_from_dh
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import transform_from_pose

_X, _Y, _Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
_NX, _NY, _NZ = (-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0)
Axes = tuple[tuple[float, float, float], ...]  # unit joint directions at home, per joint
# A drawing's six lengths (mm): base, shoulder, upper arm, forearm offset, forearm, flange.
Dims = tuple[float, float, float, float, float, float]
Limits = list[list[float]]  # per joint [min, max] deg
Pose6 = tuple[float, float, float, float, float, float]
_ORIGIN: Pose6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
ABB_AXES: Axes = (_Z, _Y, _Y, _X, _Y, _X)
KUKA_AXES: Axes = (_NZ, _Y, _Y, _NX, _Y, _NX)  # A1, A4, A6 turn clockwise seen from outside
FANUC_AXES: Axes = (_Z, _Y, _NY, _NX, _NY, _NX)  # every 6-axis arm, the LR Mate 200iD's J6 too
ABB_TOOL0 = (0.0, 90.0, 0.0)  # (rx, ry, rz) deg of tool0 at home: z out along +x, x down
FANUC_TOOL0 = (180.0, -90.0, 0.0)  # z out along +x, x up
FANUC_NOTE = ("FANUC's J3 reading is the forearm's angle to the horizontal (J2/J3 coupling): "
              "the model's q3 is the serial angle, J3 + J2; the joint files of calibrate, "
              "predict and compensate are FANUC's readings (--joint-convention)")
_MASS_SHARES = (0.16, 0.14, 0.024)  # upper arm, forearm, wrist: of the arm's total mass


@dataclass(frozen=True)
class DatasheetCheck:
    """A published figure the entry must reproduce: `reach_mm` (wrist centre's largest distance
    from axis 1) or `home_flange_mm` (tool0 position at home), within `tol_mm`."""

    what: str
    value: tuple[float, ...]
    tol_mm: float
    source: str

    def text(self) -> str:
        """In words with units: 'KR 16-2 datasheet: max. reach 1611 mm; the model's reach (the
        wrist centre's largest distance from axis 1) is 1611 mm within 8.1 mm'."""
        values = ", ".join(f"{v:g}" for v in self.value)
        if len(self.value) > 1:
            values = f"({values})"
        what = {"reach_mm": "reach (the wrist centre's largest distance from axis 1)",
                "home_flange_mm": "tool0 position at home"}.get(self.what, self.what)
        return f"{self.source}; the model's {what} is {values} mm within {self.tol_mm:.2g} mm"


@dataclass(frozen=True)
class RobotEntry:
    name: str
    title: str
    maker: str
    total_kg: float
    source: str
    check: DatasheetCheck
    build: Callable[[], SerialModel]
    note: str = ""
    # frames a controller or ROS reports in, by ROS-Industrial's link name: pose (x, y, z mm,
    # rx, ry, rz deg) in the entry's own frame, which is the first
    frames: tuple[tuple[str, Pose6], ...] = (("base_link", _ORIGIN), ("base", _ORIGIN))

    def model(self) -> SerialModel:
        return self.build()

    @property
    def frame(self) -> str:
        """The frame the entry's geometry is written in (the default of every command)."""
        return self.frames[0][0]

    def frames_text(self) -> str:
        """The frames for people: the default, then where each other one lies in it."""
        return "; ".join([f"{self.frame} (default)", *(f"{name} at {pose_words(pose)}"
                                                       for name, pose in self.frames[1:])])

    def model_in(self, frame: str) -> SerialModel:
        """The nominal model with its base in one of `frames` (by name)."""
        poses = dict(self.frames)
        if frame not in poses:
            raise ModelError(f"robot '{self.name}' has no frame '{frame}'; its frames: "
                             f"{', '.join(poses)} (default {self.frame})")
        return in_frame(self.model(), transform_from_pose(poses[frame]))


def pose_words(pose: Sequence[float]) -> str:
    """A pose (x, y, z mm, rx, ry, rz deg) for people: its non-zero parts, e.g. 'z 330 mm'."""
    rounded = [round(float(v), 6) + 0.0 for v in pose]
    rounded[3:] = [180.0 if v == -180.0 else v for v in rounded[3:]]  # angles in (-180, 180]
    parts = [f"{k} {v:g} {'mm' if k in 'xyz' else 'deg'}"
             for k, v in zip(("x", "y", "z", "rx", "ry", "rz"), rounded, strict=True) if v]
    return ", ".join(parts) or "the same place"


def in_frame(model: SerialModel, F: np.ndarray) -> SerialModel:
    """The same robot with its base frame moved to F (the new frame's pose in the old base
    frame, mm): axes, home flange and masses re-expressed; the measuring frame's `base` keeps
    the robot where it is. F turns about z only (gravity stays along -z)."""
    if abs(F[2, 2] - 1.0) > 1e-12:
        raise ModelError("a robot's base frame can only turn about its z axis here")
    Finv = np.linalg.inv(F)
    R, t = Finv[:3, :3], Finv[:3, 3]
    masses = tuple(replace(m, home_mm=tuple((R @ np.asarray(m.home_mm) + t).tolist()))
                   for m in model.masses)
    return replace(model, axis_dirs=model.axis_dirs @ R.T,
                   axis_points_mm=model.axis_points_mm @ R.T + t,
                   home_flange=Finv @ model.home_flange, base=model.base @ F, masses=masses)


def _lumped(total_kg: float, shoulder: np.ndarray, elbow: np.ndarray, wrist: np.ndarray
            ) -> tuple[LumpedMass, ...]:
    """Upper arm (moves with joint 2), forearm (joint 3) and wrist (joint 5) masses."""
    up, fore, wr = (total_kg * s for s in _MASS_SHARES)
    return (LumpedMass(1, up, tuple(((shoulder + elbow) / 2).tolist())),
            LumpedMass(2, fore, tuple(((elbow + wrist) / 2).tolist())),
            LumpedMass(4, wr, tuple(wrist.tolist())))


def wrist_arm(name: str, *, base_mm: float, shoulder_mm: float, upper_arm_mm: float,
              forearm_offset_mm: float, forearm_mm: float, flange_mm: float,
              limits_deg: Limits, axes: Axes = ABB_AXES, upright: bool = True,
              total_kg: float | None = None, masses: tuple[LumpedMass, ...] | None = None,
              tool0_rxyz_deg: tuple[float, float, float] = ABB_TOOL0) -> SerialModel:
    """A wrist-partitioned 6R arm from its dimension drawing (mm): axis 2 at (shoulder, 0,
    base) and the upper arm vertical at home (`upright`, ABB and FANUC) or horizontal (KUKA);
    the forearm offset perpendicular to it, then the forearm to the wrist centre and the flange
    along x."""
    s2 = np.array([shoulder_mm, 0.0, base_mm])
    s3 = s2 + ([0.0, 0.0, upper_arm_mm] if upright else [upper_arm_mm, 0.0, 0.0])
    z4 = s3[2] + forearm_offset_mm
    wrist = np.array([s3[0] + forearm_mm, 0.0, z4])
    points = np.array([[0, 0, 0], s2, s3, [0, 0, z4], wrist, [0, 0, z4]], dtype=float)
    if masses is None:
        masses = _lumped(total_kg or 0.0, s2, s3, wrist) if total_kg else ()
    return SerialModel(
        name=name, joint_types=("R",) * 6, axis_dirs=np.array(axes, dtype=float),
        axis_points_mm=points,
        home_flange=transform_from_pose([wrist[0] + flange_mm, 0.0, z4, *tool0_rxyz_deg]),
        limits=np.radians(limits_deg), masses=masses)


def ur_arm(name: str, d1: float, a2: float, a3: float, d4: float, d5: float, d6: float,
           total_kg: float) -> SerialModel:
    """A Universal Robots arm from UR's published DH parameters (mm), limits +-360 deg."""
    half = np.pi / 2
    rows = tuple(DHRow(a_mm=a, alpha=al, d_mm=d, theta=0.0) for a, al, d in (
        (0.0, half, d1), (a2, 0.0, 0.0), (a3, 0.0, 0.0), (0.0, half, d4), (0.0, -half, d5),
        (0.0, 0.0, d6)))
    model = model_from_dh(DHTable("dh", rows, np.eye(4), np.eye(4)), name,
                          np.radians([[-360.0, 360.0]] * 6))
    p = model.axis_points_mm
    return replace(model, masses=_lumped(total_kg, p[1], p[2], p[4]))


def irb1600() -> SerialModel:
    """ABB IRB 1600 (1.2 m reach). Home flange (815, 0, 961.5) mm, Ry(+90 deg)."""
    return wrist_arm("irb1600", base_mm=486.5, shoulder_mm=150, upper_arm_mm=475,
                     forearm_offset_mm=0, forearm_mm=600, flange_mm=65,
                     limits_deg=[[-180, 180], [-90, 150], [-245, 65], [-200, 200], [-115, 115],
                                 [-400, 400]], masses=ROBOT_MASSES["irb1600"])


def irb120() -> SerialModel:
    """ABB IRB 120. Home flange (374, 0, 630) mm, Ry(+90 deg)."""
    return wrist_arm("irb120", base_mm=290, shoulder_mm=0, upper_arm_mm=270,
                     forearm_offset_mm=70, forearm_mm=302, flange_mm=72,
                     limits_deg=[[-165, 165], [-110, 110], [-110, 70], [-160, 160], [-120, 120],
                                 [-400, 400]], masses=ROBOT_MASSES["irb120"])


def _other(name: str, kg: float, dims: Dims, limits: Limits, axes: Axes, upright: bool,
           tool0: tuple[float, float, float] = ABB_TOOL0) -> Callable[[], SerialModel]:
    h, s, u, fo, f, t = dims
    return lambda: wrist_arm(name, base_mm=h, shoulder_mm=s, upper_arm_mm=u,
                             forearm_offset_mm=fo, forearm_mm=f, flange_mm=t, limits_deg=limits,
                             axes=axes, upright=upright, total_kg=kg, tool0_rxyz_deg=tool0)


def _abb(name: str, kg: float, dims: Dims, limits: Limits) -> Callable[[], SerialModel]:
    return _other(name, kg, dims, limits, ABB_AXES, True)


def _reach(mm: float, source: str, tol: float = 0.005) -> DatasheetCheck:
    return DatasheetCheck("reach_mm", (mm,), tol * mm, source)


def _fanuc_frames(j2_height_mm: float) -> tuple[tuple[str, Pose6], ...]:
    """FANUC's World frame (ROS-I's `base`) lies in the plane of J2, above `base_link`."""
    return (("base_link", _ORIGIN), ("base", (0.0, 0.0, j2_height_mm, 0.0, 0.0, 0.0)))


# UR: the geometry is in the controller's base frame (UR's DH frame 0, ROS's `base`);
# ROS's base_link is turned 180 deg about z from it
_UR_FRAMES: tuple[tuple[str, Pose6], ...] = (("base", _ORIGIN),
                                             ("base_link", (0.0, 0.0, 0.0, 0.0, 0.0, 180.0)))
_ABB_PS = "ABB product specification"
_KR_AGILUS: Limits = [[-170, 170], [-190, 45], [-120, 156], [-185, 185], [-120, 120], [-350, 350]]
ENTRIES: tuple[RobotEntry, ...] = (
    RobotEntry("irb120", "ABB IRB 120-3/0.6", "ABB", 25.0,
               f"{_ABB_PS} IRB 120 (dimension drawing, axis ranges, mass 25 kg)",
               _reach(580.0, "IRB 120 datasheet: reach 580 mm"), irb120),
    RobotEntry("irb1200", "ABB IRB 1200-7/0.7", "ABB", 52.0,
               f"{_ABB_PS} IRB 1200 (7 kg / 0.7 m variant; mass 52 kg)",
               _reach(703.0, "IRB 1200-7/0.7 datasheet: reach 703 mm"),
               _abb("irb1200", 52.0, (399.1, 0, 350, 42, 351, 82),
                    [[-170, 170], [-100, 135], [-200, 70], [-270, 270], [-130, 130],
                     [-400, 400]])),
    RobotEntry("irb1600", "ABB IRB 1600-6/1.2", "ABB", 250.0,
               f"{_ABB_PS} IRB 1600 (1.2 m variant; thesis Fig. 37 reproduces its FK)",
               DatasheetCheck("home_flange_mm", (815.0, 0.0, 961.5), 1e-9,
                              "IRB 1600 product specification: tool0 at home"), irb1600),
    RobotEntry("irb2600", "ABB IRB 2600-12/1.65", "ABB", 272.0,
               f"{_ABB_PS} IRB 2600 (12 kg / 1.65 m variant; mass 272 kg)",
               _reach(1650.0, "IRB 2600-12/1.65 datasheet: reach 1.65 m"),
               _abb("irb2600", 272.0, (445, 150, 700, 115, 795, 85),
                    [[-180, 180], [-95, 155], [-180, 75], [-400, 400], [-120, 120],
                     [-400, 400]])),
    RobotEntry("irb4600", "ABB IRB 4600-60/2.05", "ABB", 425.0,
               f"{_ABB_PS} IRB 4600 (60 kg / 2.05 m variant; mass 425 kg)",
               _reach(2050.0, "IRB 4600-60/2.05 datasheet: reach 2.05 m"),
               _abb("irb4600", 425.0, (495, 175, 900, 175, 960, 135),
                    [[-180, 180], [-90, 150], [-180, 75], [-400, 400], [-125, 120],
                     [-400, 400]])),
    RobotEntry("irb6700", "ABB IRB 6700-200/2.60", "ABB", 1170.0,
               f"{_ABB_PS} IRB 6700 (200 kg / 2.60 m variant; mass 1170 kg)",
               _reach(2600.0, "IRB 6700-200/2.60 datasheet: reach 2.60 m"),
               _abb("irb6700", 1170.0, (780, 320, 1125, 200, 1142.5, 200),
                    [[-170, 170], [-65, 85], [-180, 70], [-300, 300], [-130, 130],
                     [-360, 360]])),
    RobotEntry("kr6-r900", "KUKA KR 6 R900 sixx (KR AGILUS)", "KUKA", 52.0,
               "KUKA KR AGILUS sixx specification (dimensions, axis ranges, mass 52 kg)",
               _reach(901.5, "KR 6 R900 sixx datasheet: max. reach 901.5 mm"),
               _other("kr6-r900", 52.0, (400, 25, 455, 35, 420, 80), _KR_AGILUS, KUKA_AXES,
                      False),
               note="KUKA's zero: A2 = 0 is the upper arm horizontal (home is A2 -90, A3 +90)"),
    RobotEntry("kr10-r900", "KUKA KR 10 R900 sixx (KR AGILUS)", "KUKA", 52.0,
               "KUKA KR AGILUS sixx specification (same arm as the KR 6 R900, 10 kg payload)",
               _reach(901.5, "KR 10 R900 sixx datasheet: max. reach 901.5 mm"),
               _other("kr10-r900", 52.0, (400, 25, 455, 35, 420, 80), _KR_AGILUS, KUKA_AXES,
                      False),
               note="KUKA's zero: A2 = 0 is the upper arm horizontal (home is A2 -90, A3 +90)"),
    RobotEntry("kr16", "KUKA KR 16-2", "KUKA", 235.0,
               "KUKA KR 16-2 specification (dimensions, axis ranges, mass 235 kg)",
               _reach(1611.0, "KR 16-2 datasheet: max. reach 1611 mm"),
               _other("kr16", 235.0, (675, 260, 680, -35, 670, 158),
                      [[-185, 185], [-155, 35], [-130, 154], [-350, 350], [-130, 130],
                       [-350, 350]], KUKA_AXES, False),
               note="KUKA's zero: A2 = 0 is the upper arm horizontal (home is A2 -90, A3 +90)"),
    RobotEntry("lrmate200id", "FANUC LR Mate 200iD", "FANUC", 25.0,
               "FANUC LR Mate 200iD datasheet (dimensions, motion ranges, mass 25 kg)",
               _reach(717.0, "LR Mate 200iD datasheet: reach 717 mm"),
               _other("lrmate200id", 25.0, (330, 50, 330, 35, 335, 80),
                      [[-170, 170], [-100, 145], [-140, 280], [-190, 190], [-125, 125],
                       [-360, 360]], FANUC_AXES, True, FANUC_TOOL0),
               note=FANUC_NOTE, frames=_fanuc_frames(330.0)),
    RobotEntry("m20ia", "FANUC M-20iA", "FANUC", 250.0,
               "FANUC M-20iA datasheet (dimensions, motion ranges, mass 250 kg)",
               _reach(1811.0, "M-20iA datasheet: reach 1811 mm"),
               _other("m20ia", 250.0, (525, 150, 790, 250, 835, 100),
                      [[-170, 170], [-100, 160], [-185, 273], [-200, 200], [-140, 140],
                       [-270, 270]], FANUC_AXES, True, FANUC_TOOL0),
               note=FANUC_NOTE, frames=_fanuc_frames(525.0)),
    RobotEntry("ur5e", "Universal Robots UR5e", "Universal Robots", 20.6,
               "UR's published DH parameters of the UR5e (d1 162.5, a2 -425, a3 -392.2, d4 "
               "133.3, d5 99.7, d6 99.6 mm); datasheet mass 20.6 kg, joint ranges +-360 deg",
               DatasheetCheck("home_flange_mm", (-817.2, -232.9, 62.8), 1e-6,
                              "UR5e DH table: flange at all joints 0"),
               lambda: ur_arm("ur5e", 162.5, -425.0, -392.2, 133.3, 99.7, 99.6, 20.6),
               frames=_UR_FRAMES),
    RobotEntry("ur10e", "Universal Robots UR10e", "Universal Robots", 33.5,
               "UR's published DH parameters of the UR10e (d1 180.7, a2 -612.7, a3 -571.55, "
               "d4 174.15, d5 119.85, d6 116.55 mm); datasheet mass 33.5 kg, ranges +-360 deg",
               DatasheetCheck("home_flange_mm", (-1184.25, -290.7, 60.85), 1e-6,
                              "UR10e DH table: flange at all joints 0"),
               lambda: ur_arm("ur10e", 180.7, -612.7, -571.55, 174.15, 119.85, 116.55, 33.5),
               frames=_UR_FRAMES),
)
LIBRARY: dict[str, RobotEntry] = {e.name: e for e in ENTRIES}
BUILTIN_MODELS: dict[str, Callable[[], SerialModel]] = {e.name: e.build for e in ENTRIES}


def accepted_robots() -> str:
    """What a robot argument accepts, for messages."""
    return (f"a library robot ({', '.join(LIBRARY)}; `screwcal robot list`) or the path of a "
            "robot file (`screwcal robot import`), model file or calibration result")


def builtin_model(name: str) -> SerialModel:
    """A library robot's nominal model by name."""
    try:
        return BUILTIN_MODELS[name]()
    except KeyError:
        raise ModelError(f"unknown robot '{name}'; give {accepted_robots()}") from None


def reach_mm(model: SerialModel, samples: int = 61, rounds: int = 3) -> float:
    """The wrist centre's (axis 5 point's) largest distance from axis 1 over joints 2 and 3
    within their limits: what the datasheets call reach. A grid of `samples` x `samples` over
    the limits, then `rounds` grids as fine around the best point so far, each 2 cells of the
    one before wide (0.005 deg cells after 3 rounds; a 721 x 721 grid took 70 times longer
    for 0.1 deg cells: `screwcal robot list` computed it for every robot in 3 s)."""
    from screwcal.kinematics.forward import forward_kinematics

    home = np.eye(4)
    home[:3, 3] = model.axis_points_mm[4]
    arm = SerialModel(name=model.name, joint_types=model.joint_types[:3],
                      axis_dirs=model.axis_dirs[:3], axis_points_mm=model.axis_points_mm[:3],
                      home_flange=home, limits=model.limits[:3])
    w1 = model.axis_dirs[0]
    lo, hi = model.limits[1:3, 0].copy(), model.limits[1:3, 1].copy()
    best, where = -np.inf, (lo + hi) / 2
    for _ in range(rounds + 1):
        g2, g3 = np.meshgrid(np.linspace(lo[0], hi[0], samples),
                             np.linspace(lo[1], hi[1], samples))
        q = np.zeros((g2.size, 3))
        q[:, 1], q[:, 2] = g2.ravel(), g3.ravel()
        rel = forward_kinematics(arm, q)[:, :3, 3] - model.axis_points_mm[0]
        radial = np.linalg.norm(rel - np.outer(rel @ w1, w1), axis=1)
        k = int(np.argmax(radial))
        if radial[k] > best:
            best, where = float(radial[k]), q[k, 1:3]
        cell = (hi - lo) / (samples - 1)
        lo = np.maximum(where - 2 * cell, model.limits[1:3, 0])
        hi = np.minimum(where + 2 * cell, model.limits[1:3, 1])
    return best
