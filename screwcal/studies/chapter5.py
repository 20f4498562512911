"""Chapter 5's experiment replayed in simulation: the true robot with Table 11's errors (the
emulator's default true robot), the measuring arm set down beside it and aligned by hand with the
thesis's method (4.6: a sweep of joint 1, a sweep of joint 2, circles, their common normal), then
calibrated two ways:

- the thesis's route: the thesis model identified in that hand-aligned frame, the joint offsets
  sent to the controller as new zeros (ZERO, 4.5);
- ours: the full model with the measuring frames identified from the data, and the commands
  compensated (every later target sent as the calibrated robot's joints).

Both are scored as the thesis scored its experiment (T_PO of the targets "as measured", through
the frame the route believes in) and as the robot itself performs (its true flange against the
target in its base frame), on 40 other poses in the same cube; and at the home position, as
Table 14 checks it. The sweeps carry the joint errors into the hand alignment (the thesis's
remark in 5.1): that is why "as measured" flatters the thesis's route.
"""

from __future__ import annotations

import numpy as np

from screwcal.calibration.base_alignment import base_from_sweeps
from screwcal.calibration.correction import compensate
from screwcal.calibration.identify import identify
from screwcal.calibration.posesets import cube_set
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.kinematics.forward import flange_kinematics, forward_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import (
    Array,
    invert_transform,
    rotation_from_rotvec,
    transform_points,
)
from screwcal.studies.simulated_measurements import NOISE_MM, simulate_measurements
from screwcal.studies.thesis_metrics import Row, joint_error, set_errors

CHAPTER5_NOTE = ("Chapter 5 replayed (25.7 -> 7.1 mm in the thesis, T_PO as measured through "
                 "its hand-aligned frame): the thesis's route (hand alignment of 4.6, thesis "
                 "model, ZERO) against ours (frames identified, full model, compensated "
                 "commands), scored as measured and as the robot itself performs, and at home "
                 "(Table 14). The same two routes run end to end on the emulated IRC5 and arm "
                 "through the job service: `screwcal demo --correction zero --error-model thesis` "
                 "(the thesis's) and `screwcal demo` (ours); their tables give ISO 9283 AP and "
                 "the home check before and after.")
CHAPTER5_WHY = ("the thesis's robot, arm placement and hand alignment are its own (its real "
                "robot's errors were not Table 11's); compare the routes, not the digits")
HOME_NOMINAL_MM = (815.0, 0.0, 961.5)  # Table 14


def _arm_placement(rng: np.random.Generator) -> Array:
    """Where the arm stands: world (arm) <- robot base, a metre or so away, turned."""
    T = np.eye(4)
    T[:3, :3] = rotation_from_rotvec(np.r_[rng.normal(0, 0.01, 2), rng.uniform(-np.pi, np.pi)])
    T[:3, 3] = [rng.uniform(800, 1200), rng.uniform(-300, 300), rng.uniform(-200, 0)]
    return T


def _measure(truth: SerialModel, placed: Array, q: Array, rng: np.random.Generator) -> Array:
    """Flange origins the arm reports (its frame, mm) for commanded joints q."""
    p = forward_kinematics(truth, q + joint_error(truth, q, rng))[:, :3, 3]
    return transform_points(placed, p) + rng.normal(0, NOISE_MM, p.shape)


def hand_alignment(truth: SerialModel, placed: Array, rng: np.random.Generator) -> Array:
    """The thesis's alignment (4.6): sweeps of joints 1 and 2 measured by the arm."""
    s1 = np.zeros((9, 6))
    s1[:, 0] = np.radians(np.linspace(-40, 40, 9))
    s2 = np.zeros((9, 6))
    s2[:, 1] = np.radians(np.linspace(-20, 40, 9))
    return base_from_sweeps(irb1600(), _measure(truth, placed, s1, rng),
                            _measure(truth, placed, s2, rng))


def own_frame(T_true: Array, targets: Array) -> Array:
    """The true poses in the robot's own frame: turned about the base z axis (joint 1's) by the
    angle that best lays them on the targets. A joint-1 zero error is such a turn of the whole
    robot: nothing measured of the robot alone tells the two apart, so neither route is held
    to it."""
    p, t = T_true[:, :2, 3], targets[:, :2, 3]
    a = -np.arctan2(np.sum(p[:, 0] * t[:, 1] - p[:, 1] * t[:, 0]), np.sum(p * t))
    Rz = np.eye(4)
    Rz[:2, :2] = [[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]]
    return Rz @ T_true


def _scores(truth: SerialModel, robot_q: Array, targets: Array, frame: Array, placed: Array,
            rng: np.random.Generator, prefix: str) -> Row:
    """T_PO as measured (the arm's points brought into the robot frame through `frame`, the
    frame the route believes) and of the robot itself (in its own frame, `own_frame`), against
    the nominal targets."""
    T_true = forward_kinematics(truth, robot_q + joint_error(truth, robot_q, rng))
    seen = T_true.copy()
    seen[:, :3, 3] = transform_points(invert_transform(frame) @ placed, T_true[:, :3, 3])
    as_measured = set_errors(targets, seen)
    itself = set_errors(targets, own_frame(T_true, targets))
    return {f"{prefix}tpo_mm": as_measured["tpo_mm"],
            f"true_{prefix}tpo_mm": itself["tpo_mm"]}


def _home_mm(truth: SerialModel, q_home: Array) -> float:
    """|error| of the true flange at home against Table 14's nominal (joint 1's turn aside:
    `own_frame`)."""
    T = flange_kinematics(truth, q_home[None])
    p = own_frame(T, flange_kinematics(irb1600(), np.zeros((1, 6))))[0, :3, 3]
    return float(np.linalg.norm(p - HOME_NOMINAL_MM))


def _away_from_limits(model: SerialModel, q: Array, n: int, margin_deg: float = 10.0) -> Array:
    lo, hi = model.limits[:, 0] + np.radians(margin_deg), model.limits[:, 1] - np.radians(
        margin_deg)
    return q[np.all((q > lo) & (q < hi), axis=1)][:n]


def sample_chapter5(seed: int) -> list[Row]:
    rng = np.random.default_rng(seed)
    nominal = irb1600()
    truth = apply_virtual_joints(nominal, THESIS_TABLE11)
    placed = _arm_placement(rng)
    hand = hand_alignment(truth, placed, rng)  # world <- robot base, as the thesis gets it
    q_cal = cube_set(nominal, "Klimchik", 40, seed=seed)
    q_perf = _away_from_limits(nominal, cube_set(nominal, "Klimchik", 80, seed=seed + 7), 40)
    targets = flange_kinematics(nominal, q_perf)  # what the program asks for
    seen = simulate_measurements(truth, q_cal, rng)
    in_arm = seen.transformed(placed)
    home = np.zeros(6)
    rows = []

    # The thesis's route: the data brought into the robot frame by the hand alignment.
    in_robot = in_arm.transformed(invert_transform(hand))
    thesis = identify(nominal, in_robot, kind="thesis", frames="known")
    zeroed = truth.derived(joint_zero=truth.joint_zero - thesis.model.joint_zero)
    rows.append({"route": "thesis: ZERO",
                 **_scores(truth, q_perf, targets, hand, placed, rng, "before_"),
                 **_scores(zeroed, q_perf, targets, hand, placed, rng, ""),
                 "home_before_mm": _home_mm(truth, home), "home_mm": _home_mm(zeroed, home)})

    # Ours: frames identified (started at the hand alignment), commands compensated.
    ours = identify(nominal, in_arm, kind="full", frames="unknown", base_guess=hand)
    # The measured point is the flange: the targets, seen from the arm through our frames.
    comp = compensate(ours.model, nominal, ours.model.base @ targets, q_perf, strict=False)
    # Home is wrist-singular (joint 5 at 0): joints 4 and 6 trade freely there; the
    # compensation keeps them nearest home, judged by their combined turn (it was refused as
    # implausible before issue 26).
    at_home = compensate(ours.model, nominal,
                         ours.model.base @ flange_kinematics(nominal, home[None]), home[None],
                         strict=False)
    rows.append({"route": "ours: frames identified + compensation",
                 **_scores(truth, q_perf, targets, ours.model.base, placed, rng, "before_"),
                 **_scores(truth, comp.q_rad, targets, ours.model.base, placed, rng, ""),
                 "home_before_mm": _home_mm(truth, home),
                 "home_mm": float("nan") if at_home.refused else _home_mm(truth,
                                                                          at_home.q_rad[0]),
                 "refused": len(comp.refused)})
    return rows


def chapter5_conclusion(rows: list[Row]) -> str:
    def mean(route: str, key: str) -> float:
        return float(np.mean([float(r[key]) for r in rows if str(r["route"]).startswith(route)]))

    return (f"\n**Result.** The thesis's route: {mean('thesis', 'before_tpo_mm'):.1f} -> "
            f"{mean('thesis', 'tpo_mm'):.2f} mm as measured through the hand-aligned frame, "
            f"{mean('thesis', 'true_before_tpo_mm'):.1f} -> {mean('thesis', 'true_tpo_mm'):.2f} "
            f"mm for the robot itself; ours: {mean('ours', 'true_before_tpo_mm'):.1f} -> "
            f"{mean('ours', 'true_tpo_mm'):.3f} mm for the robot itself (both 'after' figures "
            "carry the ±0.05 deg joint error, ~0.5 mm). At home (Table 14) the robot itself is "
            f"off by {mean('thesis', 'home_before_mm'):.1f} mm before and "
            f"{mean('thesis', 'home_mm'):.2f} mm after ZERO; ours sends no new zero, and the "
            f"compensated HOME is {mean('ours', 'home_mm'):.2f} mm off: home is wrist-singular "
            "(joint 5 at 0), where joints 4 and 6 trade freely, and the compensation keeps "
            "them nearest home, judged by their combined turn. The hand alignment takes the "
            "joint-1 and joint-2 errors into the frame (its sweeps run on the erroneous robot), "
            "so the thesis model identified in it cannot separate them, and ZERO leaves the "
            "link offsets in the robot; identifying the frames with the robot and compensating "
            "every command removes both.\n")
