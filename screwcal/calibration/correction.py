"""Correction (thesis 4.5) and compensation of a calibrated robot.

- Joint-offset correction, for a controller whose kinematic parameters are closed: return home,
  move each joint by its identified offset, and make that position the joints' new zero (update
  the revolution counters). If the joint's true angle is q_reported + z, the position whose true
  angle is 0 reads -z: the ZERO command targets -z. Offsets beyond a plausibility bound
  (default 5 deg, the thesis's search range) or not identified to better than a tenth of a
  degree are refused, never sent.
- Compensation, for a controller whose nominal model stays as it is: for each desired pose, the
  joint targets that make the *calibrated* robot reach it (numerical IK on the calibrated model,
  on the branch and 2-pi turn nearest a reference solution, inside the limits), and the nominal
  tool0 pose of those joints: what to program so that the nominal controller drives the joints
  there. Desired poses are flange (tool0) poses in the robot base frame (`frame="base"`: what a
  program or a pose list commands) or poses of the measured point in the measuring system's frame
  (`frame="measuring"`: what the measuring system will see). A compensation that moves any joint
  further than the plausibility bound from the reference is refused.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike

from screwcal.calibration.singular_fit import (
    fit_poses,
    meets,
    near_singular_solutions,
    turned_toward,
    wrist_singular,
    wrist_solutions,
)
from screwcal.errors import (
    CorrectionRefusedError,
    JointLimitError,
    TargetRefusedError,
    UnreachableError,
)
from screwcal.kinematics.forward import (
    flange_kinematics,
)
from screwcal.kinematics.ik import local_ik, numerical_ik
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.se3 import Array

if TYPE_CHECKING:  # a type only: compensating a program needs none of the error models
    from screwcal.calibration.error_parameters import Param
    from screwcal.calibration.residual_model import ResidualModel, ResidualPrediction

PLAUSIBLE_OFFSET_DEG = 5.0
# A compensated joint moves by its offset plus what the other joints' errors ask of it (J4 and
# J6 together near the wrist singularity): twice the offsets' bound.
PLAUSIBLE_CHANGE_DEG = 2 * PLAUSIBLE_OFFSET_DEG
MAX_STD_ERROR_DEG = 0.1


@dataclass(frozen=True)
class JointCorrection:
    offsets_deg: Array  # identified joint offsets (true angle = reading + offset)
    zero_command_deg: Array  # the ZERO targets: move there, then make it the new zero
    identified: Array  # bool per joint: False where the data could not tell the offset

    def to_dict(self) -> dict:
        return {"offsets_deg": self.offsets_deg.tolist(),
                "zero_command_deg": self.zero_command_deg.tolist(),
                "identified": self.identified.tolist(),
                "procedure": "home; move to zero_command_deg; set that position as the new "
                             "zero (thesis 4.5)"}


def joint_correction(params: Sequence[Param], values_deg: ArrayLike,
                     std_errors_deg: ArrayLike, n_joints: int,
                     bound_deg: float = PLAUSIBLE_OFFSET_DEG,
                     max_std_deg: float = MAX_STD_ERROR_DEG) -> JointCorrection:
    """The joint-offset correction from the identified joint zeros (deg) among `params`."""
    values = np.asarray(values_deg, float)
    stds = np.asarray(std_errors_deg, float)
    offsets = np.zeros(n_joints)
    identified = np.zeros(n_joints, bool)
    for k, p in enumerate(params):
        if p.kind != "zero" or not p.is_angle:
            continue
        i = p.joint
        if abs(values[k]) > bound_deg:
            raise CorrectionRefusedError(
                f"joint {i + 1} offset {values[k]:+.3f} deg ({p.name}) exceeds the plausible "
                f"bound of +-{bound_deg:g} deg: check the data and the set-up before correcting")
        if stds[k] > max_std_deg:
            raise CorrectionRefusedError(
                f"joint {i + 1} offset {values[k]:+.3f} deg ({p.name}) is uncertain (std error "
                f"{stds[k]:.3f} deg > {max_std_deg:g}): measure better-spread poses")
        offsets[i], identified[i] = values[k], True
    return JointCorrection(offsets, -offsets, identified)


@dataclass(frozen=True)
class Compensation:
    q_rad: Array  # (N, n) joint targets (controller readings) that reach the desired poses
    nominal_tool0: Array  # (N, 4, 4) the nominal flange pose of those joints: what to program
    change_deg: Array  # (N, n) q_rad minus the reference solution, deg (zeros without one)
    refused: tuple[tuple[int, str], ...] = ()  # (target, why), with strict=False only
    residual: ResidualPrediction | None = None  # the residual model's correction, when given

    @property
    def ok(self) -> Array:
        """(N,) the targets compensated (False where refused)."""
        out = np.ones(len(self.q_rad), bool)
        out[[k for k, _ in self.refused]] = False
        return out

    @property
    def max_change_deg(self) -> float:
        change = self.change_deg[self.ok]
        return float(np.abs(change).max()) if change.size else 0.0


def compensate(calibrated: SerialModel, nominal: SerialModel, T_desired: ArrayLike,
               q_ref: ArrayLike | None = None, *,
               frame: Literal["base", "measuring"] = "measuring",
               bound_deg: float = PLAUSIBLE_CHANGE_DEG, strict: bool = True,
               residual: ResidualModel | None = None) -> Compensation:
    """Joint targets (from q_ref (N, n) or (n,), on its branch and turn; without it, the
    branch nearest all zeros; within the limits) and nominal tool0 poses that take the
    calibrated robot to T_desired (N, 4, 4): flange poses in the robot base frame
    (`frame="base"`) or measured-point poses in the measuring frame.

    With q_ref, a joint that would move more than `bound_deg` from it is refused: no plausible
    calibration moves a joint that far. `strict`: the first refused target raises
    (CorrectionRefusedError, UnreachableError or JointLimitError naming it); otherwise the
    refusals are listed in the result and those rows keep q_ref.

    `residual`: the calibrated robot's residual model (`_with_residual`).
    """
    if residual is not None:
        return _with_residual(calibrated, nominal, np.asarray(T_desired, dtype=float), q_ref,
                              residual, frame=frame, bound_deg=bound_deg, strict=strict)
    return _physical(calibrated, nominal, np.asarray(T_desired, dtype=float), q_ref,
                     frame=frame, bound_deg=bound_deg, strict=strict)


def _physical(calibrated: SerialModel, nominal: SerialModel, T: Array,
              q_ref: ArrayLike | None, *, frame: Literal["base", "measuring"],
              bound_deg: float, strict: bool) -> Compensation:
    """`compensate` with the calibrated robot's physical model alone."""
    robot = calibrated if frame == "measuring" else \
        calibrated.with_frames(base=np.eye(4), tool=np.eye(4))
    if q_ref is None:
        q = nearest_home_solution(robot, T)
        calibrated.check_limits(q, "compensated target")
        return Compensation(q, flange_kinematics(nominal, q), np.zeros_like(q))
    ref = np.broadcast_to(np.asarray(q_ref, float), (T.shape[0], calibrated.n_joints))
    # the solution next to the reference: its branch and turn, even near singularities
    q, reached = local_ik(robot, T, ref)
    change = calibrated.joints_to_deg(q - ref)
    reached, inside = reached.astype(bool), calibrated.within_limits(q).astype(bool)
    plausible = np.abs(change).max(axis=1, initial=0.0) <= bound_deg
    beyond: dict[int, tuple[float, float]] = {}  # unreached: how near the calibrated robot gets
    near_wrist = wrist_singular(nominal, ref)
    # Gauss-Newton stalls next to the stretched arm, or runs off along a singular direction
    # (joint 1 at -733 deg for a target whose solution is 2 deg from the reference, next to
    # the shoulder singularity): LM from the reference, which stays next to it
    stuck = np.flatnonzero(~(reached & inside & plausible) & ~near_wrist)
    if stuck.size:
        q_s, met, gap = near_singular_solutions(robot, T[stuck], ref[stuck])
        # Gauss-Newton's joints outside the limits, where LM from the reference misses the
        # target too: a run off along a singular direction (joint 6 at 9294 deg), not the
        # target's solution; the target is out of the calibrated robot's reach there (which of
        # the two a run ended in turned on the last bits of the reference)
        reached[stuck[~met & ~inside[stuck]]] = False
        q[stuck[met]], reached[stuck[met]] = q_s[met], True
        inside[stuck] = calibrated.within_limits(q[stuck]).astype(bool)
        change[stuck] = calibrated.joints_to_deg(q[stuck] - ref[stuck])
        plausible[stuck] = np.abs(change[stuck]).max(axis=1, initial=0.0) <= bound_deg
        beyond.update(zip(stuck[~met & ~reached[stuck]].tolist(),
                          gap[~met & ~reached[stuck]].tolist(), strict=True))
    wrist = near_wrist & ~(reached & inside & plausible)
    if wrist.any():  # joints 4 and 6 trade freely there: solve on every branch instead
        at = np.flatnonzero(wrist)
        q_w, _, measure = wrist_solutions(robot, T[at], ref[at])
        met_w = np.isfinite(measure)  # the solution next to the reference, usable or not: a
        at, q_w, measure = at[met_w], q_w[met_w], measure[met_w]  # refusal names its joints
        q[at], reached[at] = q_w, True
        inside[at] = calibrated.within_limits(q_w).astype(bool)
        plausible[at] = measure <= bound_deg  # joints 4 and 6 counted by their combined turn
        change[at] = calibrated.joints_to_deg(q_w - ref[at])
    refused = []
    error: type[TargetRefusedError]
    for k in np.flatnonzero(~(reached & inside & plausible)).tolist():
        if not reached[k]:
            why, error = "the calibrated robot cannot reach it near the nominal solution", \
                UnreachableError
            if k in beyond:  # next to a singularity (the arm stretched): out of its reach
                why += (" (its nearest pose there is {:.4f} mm, {:.4f} deg away: the target is "
                        "beyond its reach)").format(*beyond[k])
            elif wrist[k]:
                why += " (at the wrist singularity, joint 5 near 0, on no branch near it)"
        elif not inside[k]:
            j = int(np.argmax(np.maximum(calibrated.limits[:, 0] - q[k],
                                         q[k] - calibrated.limits[:, 1])))
            why, error = (f"joint {j + 1} would be {np.degrees(q[k, j]):.4f} deg, outside "
                          "its limits"), JointLimitError
        else:
            j = int(np.argmax(np.abs(change[k])))
            why, error = (f"compensation moves joint {j + 1} by {change[k, j]:+.3f} deg, beyond "
                          f"the plausible +-{bound_deg:g} deg: a target next to a singularity, "
                          "or a wrong calibrated model: check it before using it"), \
                CorrectionRefusedError
        if strict:
            raise error(f"target {k}: {why}", index=k)
        refused.append((int(k), why))
    bad = [k for k, _ in refused]
    q[bad], change[bad] = ref[bad], 0.0
    return Compensation(q, flange_kinematics(nominal, q), change, tuple(refused))


def _with_residual(calibrated: SerialModel, nominal: SerialModel, T: Array,
                   q_ref: ArrayLike | None, residual: ResidualModel, *,
                   frame: Literal["base", "measuring"], bound_deg: float, strict: bool
                   ) -> Compensation:
    """`compensate` with a residual model (`residual_model`): the calibrated robot is its
    model plus that residual; each target is moved back by the residual's correction (into
    the target's frame), taken at the reference solution (or, without one, at the physical
    model's solution): the compensated joints differ from it by far less than the residual's
    length scale. The result carries the correction and its uncertainty per target
    (`Compensation.residual`)."""
    from dataclasses import replace

    at = calibrated.n_joints
    if q_ref is None:
        robot = calibrated if frame == "measuring" else \
            calibrated.with_frames(base=np.eye(4), tool=np.eye(4))
        at_q = nearest_home_solution(robot, T)
    else:
        at_q = np.broadcast_to(np.asarray(q_ref, float), (T.shape[0], at))
    seen = residual.predict(at_q)
    shift = seen.correction_mm  # measuring frame; a base-frame target: into the robot's base
    if frame == "base":
        shift = shift @ calibrated.base[:3, :3]
    moved = T.copy()
    moved[:, :3, 3] -= shift
    comp = _physical(calibrated, nominal, moved, q_ref, frame=frame, bound_deg=bound_deg,
                     strict=strict)
    return replace(comp, residual=seen)


def compensate_each(calibrated: SerialModel, nominal: SerialModel, T_desired: ArrayLike, *,
                    frame: Literal["base", "measuring"] = "measuring",
                    bound_deg: float = PLAUSIBLE_CHANGE_DEG,
                    residual: ResidualModel | None = None) -> Compensation:
    """Every target of T_desired (N, 4, 4) that can be compensated, from the nominal solution
    nearest home (`frame="base"`) or the calibrated one nearest home (`"measuring"`); the
    others are listed in `refused` with why (their rows hold zeros), never raised.
    `residual`: as `compensate`'s (refused rows: a zero correction)."""
    T = np.asarray(T_desired, dtype=float)
    try:
        return _compensate_from_home(calibrated, nominal, T, frame, bound_deg, residual)
    except TargetRefusedError:
        pass  # one target fails the batch: each on its own
    n = calibrated.n_joints
    q, tool0, change = np.zeros((len(T), n)), np.tile(np.eye(4), (len(T), 1, 1)), \
        np.zeros((len(T), n))
    refused = []
    seen = []  # the residual model's prediction for each target compensated
    for k in range(len(T)):
        try:
            one = _compensate_from_home(calibrated, nominal, T[k:k + 1], frame, bound_deg,
                                        residual)
        except TargetRefusedError as err:
            refused.append((k, str(err).replace("target 0 is", "it is")
                            .replace("target 0: ", "").replace("target 0", "it")))
            continue
        if one.refused:
            refused.append((k, one.refused[0][1]))
            continue
        q[k], tool0[k], change[k] = one.q_rad[0], one.nominal_tool0[0], one.change_deg[0]
        if one.residual is not None:
            seen.append((k, one.residual))
    if seen:  # the residual's predictions of the single targets as one (zeros where none)
        from screwcal.calibration.residual_model import stacked_predictions

        return Compensation(q, tool0, change, tuple(refused), stacked_predictions(seen, len(T)))
    return Compensation(q, tool0, change, tuple(refused))


def _compensate_from_home(calibrated: SerialModel, nominal: SerialModel, T: Array,
                          frame: Literal["base", "measuring"], bound_deg: float,
                          residual: ResidualModel | None = None) -> Compensation:
    if frame == "measuring":
        return compensate(calibrated, nominal, T, frame=frame, bound_deg=bound_deg,
                          residual=residual)
    q_ref = nearest_home_solution(nominal.with_frames(np.eye(4), np.eye(4)), T)
    return compensate(calibrated, nominal, T, q_ref, frame=frame, bound_deg=bound_deg,
                      strict=False, residual=residual)


def nearest_home_solution(robot: SerialModel, T: Array) -> Array:
    """The solution nearest home of targets T (N, 4, 4) (tool poses of `robot` with its frames:
    the nominal robot's flange, or the calibrated one's measured point). Next to the stretched
    arm the numerical IK's Gauss-Newton may stop short of its 1e-9 mm; a single target is then
    solved to 1e-6 mm with more iterations (or, where that finds none, from home itself) and
    polished by Levenberg-Marquardt, accepted on the wrist singularity's tolerances (a batch
    raises UnreachableError: compensate_each then takes its targets one by one)."""
    home = np.zeros(robot.n_joints)
    try:
        return numerical_ik(robot, T).nearest(home)
    except UnreachableError:
        if len(T) > 1:
            raise
    try:
        q0 = numerical_ik(robot, T, tol_mm=1e-6, tol_rad=1e-8, max_iter=200).nearest(home)
    except UnreachableError:  # the sampled seeds of an arm without a closed form all missed
        q0 = home[None, :]  # (a target next to the stretched zero pose): from home itself
    q = turned_toward(fit_poses(robot, T, q0)[0], q0)
    if not meets(T, robot, q)[0]:  # the singular tolerances: a reference, not a target
        raise UnreachableError("target 0 is out of the arm's reach on every branch", index=0)
    return q


def after_zero(model: SerialModel, zero_command_deg: ArrayLike) -> SerialModel:
    """The model of the robot once ZERO made the readings at `zero_command_deg` the new zero:
    the controller now reads q - zero_command where it read q (thesis 4.5)."""
    return model.derived(joint_zero=model.joint_zero + np.radians(
        np.asarray(zero_command_deg, float)) * model.is_revolute)
