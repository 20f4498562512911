"""The ISO 9283 test cube, its inclined measuring plane, P1-P5, and the performance pose list.

ISO 9283 (thesis 2.3.1, Fig. 13): a cube with edges parallel to the base axes, as large as the
workspace allows; the measuring plane is the diagonal plane through the cube's lower front edge
and upper back edge (inclined 45 deg). P1 is the cube's centre; P2-P5 lie on the plane's
diagonals at 10 % of the diagonal's length from its corners. Each target is approached from the
same direction: the robot first goes to a return point (the target plus `approach_mm`), then to
the target (Fig. 13). One cycle visits P1, P5, P4, P3, P2 (ISO 9283's sequence); the default is 30
cycles. Every pose has the same commanded orientation.

A cube is feasible when every corner, target and return point has a closed-form IK solution on one
branch (shoulder front, elbow up, no wrist flip) inside the joint limits less a margin, away from
the wrist singularity, and — when a measuring arm is given — inside its sphere.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from screwcal.errors import InfeasibleCubeError, InputError, ModelError
from screwcal.kinematics.forward import frame_inverses
from screwcal.kinematics.ik import BRANCHES, IKSolutions, closed_form_ik
from screwcal.kinematics.ik_branches import all_branches
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import transform_from_pose
from screwcal.kinematics.se3 import Array
from screwcal.tables import fixed_texts, write_csv_atomic

CYCLE_ORDER = ("P1", "P5", "P4", "P3", "P2")
DIAGONAL_FRACTION = 0.10
_BRANCH = BRANCHES.index(("front", "up", "noflip"))
FLANGE_DOWN_DEG = (0.0, 180.0, 0.0)


@dataclass(frozen=True)
class ArmSphere:
    """The measuring arm's reach: centre in the robot base frame (mm) and radius (mm)."""

    centre_mm: tuple[float, float, float]
    radius_mm: float = 1200.0


@dataclass(frozen=True)
class TestCube:
    __test__ = False  # a test cube of ISO 9283, not a pytest test class
    centre_mm: Array  # (3,)
    edge_mm: float
    orientation_deg: Array  # (3,) rx, ry, rz of every pose
    approach_mm: Array  # (3,) return point = target + approach

    @property
    def corners_mm(self) -> Array:
        """C1..C8, shape (8, 3): all sign combinations of +-edge/2 about the centre."""
        h = self.edge_mm / 2
        signs = np.array([[sx, sy, sz] for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)])
        return self.centre_mm + h * signs

    @property
    def plane_corners_mm(self) -> Array:
        """The inclined plane's corners (4, 3): lower front edge (x-, z-) then upper back edge
        (x+, z+), in order around the rectangle."""
        h = self.edge_mm / 2
        s = np.array([[-1, -1, -1], [-1, 1, -1], [1, 1, 1], [1, -1, 1]], float)
        return self.centre_mm + h * s

    @property
    def points_mm(self) -> dict[str, Array]:
        """P1 (centre) and P2-P5 at 10 % of the diagonal from the plane's corners."""
        c = self.centre_mm
        out = {"P1": c.copy()}
        for label, corner in zip(("P2", "P3", "P4", "P5"), self.plane_corners_mm, strict=True):
            opposite = 2 * c - corner
            out[label] = corner + DIAGONAL_FRACTION * (opposite - corner)
        return out

    def poses(self, positions_mm: ArrayLike) -> Array:
        """Commanded poses (n, 6) at the given positions with the cube's orientation."""
        p = np.atleast_2d(np.asarray(positions_mm, dtype=float))
        return np.column_stack([p, np.tile(self.orientation_deg, (len(p), 1))])


@dataclass(frozen=True)
class PosePlan:
    """One entry of a performance pose list."""

    index: int
    cycle: int
    point: str
    role: str  # "approach" (return point, not measured) or "target" (measured)
    q_deg: tuple[float, ...]
    pose_cmd: tuple[float, ...]  # x, y, z (mm), rx, ry, rz (deg)


def _margins(model: SerialModel, poses: Array, wrist_margin_deg: float
             ) -> tuple[Array, Array]:
    """Joint solutions (..., k, 6) rad on the cube's branch, and the worst joint-limit margin in
    deg over the k poses, for commanded poses (..., k, 6); -inf where a pose is unreachable or
    too close to the wrist singularity."""
    shape = poses.shape[:-1]
    q, margin = _pose_margins(model, poses.reshape(-1, 6), wrist_margin_deg)
    return q.reshape(*shape, 6), margin.reshape(shape).min(axis=-1)


def _pose_margins(model: SerialModel, poses: Array, wrist_margin_deg: float
                  ) -> tuple[Array, Array]:
    """Per commanded pose (M, 6): the joints (M, 6) rad on the cube's branch and the pose's
    joint-limit margin (M,) deg, -inf where unreachable or at the wrist singularity."""
    sol = _branches(model, transform_from_pose(poses))
    q = sol.q[:, 0]
    lim = np.degrees(model.limits)
    qd = np.degrees(np.nan_to_num(q))
    margin = np.minimum(qd - lim[:, 0], lim[:, 1] - qd).min(axis=1)
    bad = np.logical_not(sol.reachable[:, 0]) | (np.abs(qd[:, 4]) < wrist_margin_deg)
    return q, np.where(bad, -np.inf, margin)


def _branches(model: SerialModel, T_world: Array) -> IKSolutions:
    """The cube's branch of world tool poses (second axis of length 1): the ABB closed form,
    else the closed forms of the arms whose joints count the other way (KUKA, FANUC) or whose
    wrist is offset (UR)."""
    try:
        return closed_form_ik(model, T_world, require_all=False, check=False, branch=_BRANCH)
    except ModelError:
        base_inv, tool_inv = frame_inverses(model)
        T = T_world if base_inv is None else base_inv @ T_world
        return all_branches(model, T if tool_inv is None else T @ tool_inv, branch=_BRANCH)


# The corners (`_offsets`: C1..C8, x fastest, then y, then z) first, the cube's extremes where
# most candidates fail: opposite corners in turn, the upper far one (the reach) and the lower
# near one (the body, the floor) first; then the targets and the return points. (Solved in
# this order, the four library makers' searches solve 44 % fewer poses than corner by corner.)
_SCREENING_ORDER = (7, 0, 4, 3, 6, 1, 5, 2)


def _best_margin(model: SerialModel, positions: Array, orientation: Array,
                 wrist_margin_deg: float, floor_deg: float) -> Array:
    """The worst margin (C,) over the k positions (C, k, 3) of each candidate cube: its poses
    solved a position at a time, and a cube whose margin fell below `floor_deg` (it cannot be
    chosen) dropped from the next positions (its margin then: that of the positions solved;
    below the floor, as it would be over all of them)."""
    C, k, _ = positions.shape
    worst = np.full(C, np.inf)
    alive = np.arange(C)
    for j in _SCREENING_ORDER + tuple(range(8, k)):
        if alive.size == 0:
            break
        poses = np.column_stack([positions[alive, j], np.broadcast_to(orientation,
                                                                      (alive.size, 3))])
        worst[alive] = np.minimum(worst[alive],
                                  _pose_margins(model, poses, wrist_margin_deg)[1])
        alive = alive[worst[alive] >= floor_deg]
    return worst


def _offsets(edge_mm: float, approach_mm: Array) -> Array:
    """Every position that must be feasible, relative to the centre: corners, targets, returns."""
    cube = TestCube(np.zeros(3), edge_mm, np.zeros(3), approach_mm)
    targets = np.array(list(cube.points_mm.values()))
    return np.vstack([cube.corners_mm, targets, targets + approach_mm])


def find_test_cube(model: SerialModel, edge_mm: float | None = None, *,
                   orientation_deg: Sequence[float] = FLANGE_DOWN_DEG,
                   approach_mm: Sequence[float] = (0.0, 0.0, 50.0),
                   arm: ArmSphere | None = None, floor_z_mm: float = 0.0,
                   keepout_radius_mm: float = 300.0,
                   margin_deg: float = 5.0, wrist_margin_deg: float = 10.0,
                   grid_step_mm: float = 25.0, centre_mm: Sequence[float] | None = None
                   ) -> TestCube:
    """The test cube: of the given edge, or (edge None) the largest feasible edge to 10 mm.

    Centres are searched on a grid in the plane y = 0 in front of the robot (x > 0), with every
    point above `floor_z_mm` and outside a cylinder of `keepout_radius_mm` about axis 1 (the
    robot's own body: there is no collision model); among the feasible centres the one with the
    largest joint-limit margin is kept. With `centre_mm` (and an edge), that one cube is checked
    instead of searched for.
    """
    orientation = np.asarray(orientation_deg, dtype=float)
    approach = np.asarray(approach_mm, dtype=float)
    reach = float(np.linalg.norm(model.home_flange[:3, 3])) + 200.0
    xs = np.arange(grid_step_mm, reach, grid_step_mm)
    zs = np.arange(floor_z_mm, reach + floor_z_mm, grid_step_mm)
    centres = np.array([[x, 0.0, z] for x in xs for z in zs])
    if centre_mm is not None:
        if edge_mm is None:
            raise InputError("a given cube centre needs its edge length too")
        centres = np.asarray(centre_mm, dtype=float).reshape(1, 3)

    def best_for(edge: float) -> TestCube | None:
        offsets = _offsets(edge, approach)
        # The whole cube (not only its points) clears the floor and the robot's body (every
        # point above the floor: the lowest, a sum being monotonic in its terms).
        lo, hi = centres - edge / 2, centres + edge / 2
        gap = np.maximum(np.maximum(lo[:, :2], -hi[:, :2]), 0.0)  # to axis 1, per x and y
        keep = (centres[:, 2] + offsets[:, 2].min() >= floor_z_mm) & \
            (lo[:, 2] >= floor_z_mm) & (np.hypot(gap[:, 0], gap[:, 1]) >= keepout_radius_mm)
        positions = centres[keep][:, None, :] + offsets[None]  # (C kept, k, 3)
        if arm is not None:
            dist = np.linalg.norm(positions - np.asarray(arm.centre_mm), axis=2)
            inside = (dist <= arm.radius_mm).all(axis=1)
            keep[keep], positions = inside, positions[inside]
        if not keep.any():
            return None
        margin = _best_margin(model, positions, orientation, wrist_margin_deg, margin_deg)
        if margin.max() < margin_deg:
            return None
        return TestCube(centres[keep][int(np.argmax(margin))], edge, orientation, approach)

    if edge_mm is not None:
        cube = best_for(float(edge_mm))
        if cube is None:
            where = " inside the measuring arm's sphere" if arm else ""
            raise InfeasibleCubeError(
                f"no {edge_mm:g} mm cube with orientation {orientation.tolist()} deg fits model "
                f"'{model.name}' above z = {floor_z_mm:g} mm{where}; try a smaller edge "
                "(testcube --edge-mm, job start --cube-edge-mm)")
        return cube
    lo, hi, found = 10.0, 2.0 * reach, None
    while hi - lo > 10.0:
        mid = (lo + hi) / 2
        cube = best_for(mid)
        lo, hi, found = (mid, hi, cube) if cube is not None else (lo, mid, found)
    if found is None:
        raise InfeasibleCubeError(f"no test cube fits model '{model.name}' with these settings")
    return found


def performance_pose_list(model: SerialModel, cube: TestCube, cycles: int = 30
                          ) -> list[PosePlan]:
    """The PERF list: per cycle, for each of P1, P5, P4, P3, P2 a return point then the target,
    as joint targets (deg) on one IK branch, all inside the joint limits."""
    if cycles < 1:
        raise InputError(f"cycles must be at least 1; got {cycles}")
    pts = cube.points_mm
    order = [(label, role) for label in CYCLE_ORDER for role in ("approach", "target")]
    positions = np.array([pts[label] + (cube.approach_mm if role == "approach" else 0.0)
                          for label, role in order])
    poses = cube.poses(positions)
    q, margin = _margins(model, poses, 0.0)
    if margin < 0:
        raise InfeasibleCubeError(f"the cube's poses are not all reachable inside the limits of "
                                  f"model '{model.name}' on one IK branch")
    model.check_limits(q, "performance pose")
    q_deg = np.degrees(q)
    plans: list[PosePlan] = []
    for cycle in range(1, cycles + 1):
        for k, (label, role) in enumerate(order):
            plans.append(PosePlan(index=len(plans), cycle=cycle, point=label, role=role,
                                  q_deg=tuple(float(v) for v in q_deg[k]),
                                  pose_cmd=tuple(float(v) for v in poses[k])))
    return plans


POSE_LIST_COLUMNS = ("index", "cycle", "point", "role", "q1", "q2", "q3", "q4", "q5", "q6",
                     "x_cmd", "y_cmd", "z_cmd", "rx_cmd", "ry_cmd", "rz_cmd")


def write_pose_list(path: str, plans: Sequence[PosePlan]) -> None:
    """The pose list as CSV (joint targets in deg, commanded pose in mm/deg)."""
    write_csv_atomic(path, POSE_LIST_COLUMNS,
                     ([p.index, p.cycle, p.point, p.role, *fixed_texts(p.q_deg + p.pose_cmd, 4)]
                      for p in plans))
