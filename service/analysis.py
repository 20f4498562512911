"""What a job's measurements say, computed without I/O: the estimation's summary, the correction a
route would make (checked before anything moves), ISO 9283 performance (the performance package's
own computation), the home check (thesis Table 14), the test conditions, and the warnings a user
must see."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from screwcal.calibration.backlash import backlash_from_pairs
from screwcal.calibration.beam_weighting import BeamFit
from screwcal.calibration.correction import (
    CorrectionRefusedError,
    after_zero,
    compensate,
    joint_correction,
)
from screwcal.calibration.identify import CalibrationResult
from screwcal.calibration.lag import commands_for_lost_motion
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.residual_model import ResidualModel
from screwcal.calibration.resultfile import compliance_summary, lost_motion_deg
from screwcal.kinematics.compliance import Payload
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
from screwcal.kinematics.se3 import Array, invert_transform, transform_points
from screwcal.performance.evaluate import PerformanceData, PointData, performance_section
from screwcal.performance.straightness import straightness
from service.document import (
    CorrectionPlan,
    EstimatedParameter,
    EstimationSummary,
    HomeCheck,
    HomeMeasurement,
    JobOptions,
    MeasuringFrame,
    PerformanceSection,
    RemovedParameter,
    ResultDocument,
)
from service.phases import PERF_PHASES, ROUND_SUFFIXES, Round, compensated_list, list_kind
from service.plans import BACKLASH_ROLES, PlannedPose
from service.robot_record import RobotRecord

POOR_FIT_CHI2 = 10.0  # chi2/dof above this with the stated noise: the model misses something


def measurement_set(rows: Sequence[Mapping[str, Any]],
                    interleaved: Sequence[Mapping[str, Any]] = ()) -> MeasurementSet:
    """The committed poses of a phase as the identification reads them, in the order measured:
    each pose's previous readings are those of the pose the robot came from (the read-back
    lag's `q_previous`): the pose before it, or the last pose of `interleaved` (the job's poses
    of its other phases: the drift checks, the list before this one) committed between the
    two, or before the first; unknown for a first pose nothing was committed before. Poses of
    one measured point (a tracker's one SMR) are positions only, each with the covariance the
    instrument stated."""
    q = np.radians([r["joints_deg"] for r in rows])
    previous = np.full_like(q, np.nan)
    previous[1:] = q[:-1]
    if interleaved and all("id" in r for r in rows):
        between = sorted(interleaved, key=lambda r: int(r["id"]))
        ids = np.array([int(r["id"]) for r in between])
        row_ids = np.array([int(r["id"]) for r in rows])
        last = np.searchsorted(ids, row_ids) - 1  # the last pose committed before each
        after_pose_before = (last >= 0) & (ids[np.maximum(last, 0)] > np.r_[-1, row_ids[:-1]])
        q_between = np.radians([r["joints_deg"] for r in between])
        previous[after_pose_before] = q_between[last[after_pose_before]]
    names = tuple(str(r["idx"]) for r in rows)
    if positions_only(rows):
        cov = np.array([r["covariance_mm2"][0] for r in rows], dtype=float) \
            if all(r.get("covariance_mm2") for r in rows) else None
        return MeasurementSet(q, np.array([r["holes_mm"][0] for r in rows], dtype=float),
                              None, names, q_previous=previous, position_cov_mm2=cov)
    T = transform_from_pose(np.array([r["flange_pose"] for r in rows]))
    return MeasurementSet(q, T[:, :3, 3].copy(), T[:, :3, :3].copy(), names,
                          q_previous=previous)


def positions_only(rows: Sequence[Mapping[str, Any]]) -> bool:
    """Poses measured as one point each (no flange pose): positions only."""
    return bool(rows) and not rows[0]["flange_pose"]


def backlash_summary(result: CalibrationResult, rows: Sequence[Mapping[str, Any]],
                     plan: Sequence[PlannedPose]) -> dict[str, Any] | None:
    """Lost motion per joint (`screwcal.calibration.backlash`) from the calibration list's
    two-direction pairs (`service/plans.py`), against the calibrated model; the readings
    corrected for the read-back lag the estimation found (the approach is the pose before)."""
    by_idx = {int(r["idx"]): r for r in rows}
    roles = {p.idx: p for p in plan}
    a_rows, b_rows = [], []
    for idx, p in roles.items():
        if p.role == BACKLASH_ROLES[0]:
            b = next((k for k, o in roles.items() if o.role == BACKLASH_ROLES[1]
                      and o.point == p.point), None)
            if b is not None and {idx, idx - 1, b, b - 1} <= set(by_idx):
                a_rows.append((by_idx[idx], by_idx[idx - 1]))
                b_rows.append((by_idx[b], by_idx[b - 1]))
    if not a_rows:
        return None
    lag = np.zeros(result.model.n_joints) if result.reading_lag is None else \
        np.asarray(result.reading_lag)

    def joints(pairs: list[tuple[Mapping[str, Any], Mapping[str, Any]]]) -> Array:
        q = np.radians([r["joints_deg"] for r, _ in pairs])
        before = np.radians([r["joints_deg"] for _, r in pairs])
        return q + lag * (q - before)  # calibration.lag: q_true = q_read + lag (q_read - q_prev)

    def flanges(pairs: list[tuple[Mapping[str, Any], Mapping[str, Any]]]) -> Array:
        return transform_from_pose(np.array([r["flange_pose"] for r, _ in pairs]))

    noise = result.noise
    sigma_mm = noise.position_mm if noise is not None and np.isfinite(noise.position_mm) \
        else 0.02
    sigma_rad = np.radians(noise.orientation_deg) if noise is not None and \
        np.isfinite(noise.orientation_deg) else sigma_mm / 100.0
    est = backlash_from_pairs(result.model, joints(a_rows), joints(b_rows), flanges(a_rows),
                              flanges(b_rows), np.ones((len(a_rows), result.model.n_joints)),
                              sigma_mm=float(sigma_mm), sigma_rad=float(sigma_rad))
    return est.to_dict()


def list_payload(options: JobOptions, kind: str) -> Payload:
    """What the flange carries during a job's "cal" or "perf" list (its options)."""
    kg, cog = options.payload_kg, options.payload_cog_mm
    if kind == "cal" and options.calibration_payload_kg is not None:
        kg = options.calibration_payload_kg
        cog = options.calibration_payload_cog_mm or cog
    return Payload(float(kg), (float(cog[0]), float(cog[1]), float(cog[2])))


def compensate_plan(plan: list[PlannedPose], robot: SerialModel, nominal: SerialModel,
                    residual: ResidualModel | None = None) -> tuple[list[PlannedPose], float]:
    """The plan's joints replaced by those that take `robot` (with its residual model, when
    its calibration kept one) to the `nominal` model's targets, and the largest joint change
    (deg). Raises before anything moves when one cannot be reached."""
    q_nominal = np.radians([p.joints_deg for p in plan])
    comp = compensate(robot, nominal, flange_kinematics(nominal, q_nominal), q_nominal,
                      frame="base", residual=residual)
    q = np.round(np.degrees(comp.q_rad), 4)
    return ([replace(p, joints_deg=tuple(float(v) for v in q[k]))
             for k, p in enumerate(plan)], comp.max_change_deg)


def taken_up(plan: list[PlannedPose], lost_motion_deg: Sequence[float] | None
             ) -> list[PlannedPose]:
    """The plan with each joint commanded half its lost motion beyond its target, on the side
    it comes from in the plan's order (`lag.commands_for_lost_motion`); as it is without one."""
    if lost_motion_deg is None or not plan:
        return plan
    q = commands_for_lost_motion(np.array([p.joints_deg for p in plan]),
                                 np.asarray(lost_motion_deg, dtype=float))
    q = np.round(q, 4)
    return [replace(p, joints_deg=tuple(float(v) for v in q[k])) for k, p in enumerate(plan)]


def flange_error_mm(robot: SerialModel, q_sent: Array, target: Array) -> Array:
    """Per pose: how far `robot`'s flange (its base frame) lands from the target (N, 4, 4) when
    sent the joints q_sent (N, n) rad."""
    return np.linalg.norm(flange_kinematics(robot, q_sent)[:, :3, 3] - target[:, :3, 3], axis=1)


def estimation_summary(result: CalibrationResult, beam: BeamFit | None = None
                       ) -> EstimationSummary:
    """The robot's identified parameters; the measuring frame as the pose it came out as (its
    parameters are increments from the starting alignment, meaningless alone); a tracker's
    points fitted by their beams (`beam`): the noise along and across the beam beside."""
    x, y, z, rx, ry, rz = (float(v) for v in pose_from_transform(result.model.base))
    noise = result.noise.to_dict() if result.noise is not None else None
    if beam is not None:
        noise = {**(noise or {}), **{
            name: {"value": level, "unit": "mm", "estimated": True, "std": None,
                   "measured": True, "excess_mm": excess,
                   "meaning": f"noise {words} (1 sigma; a first fit's residuals), and what of "
                              "it the instrument's stated covariances did not explain "
                              "(added to every point's weight)"}
            for name, words, level, excess in (
                ("along_beam", "along the tracker's beam", beam.levels.radial_mm,
                 beam.excess.radial_mm),
                ("across_beam", "across the beam, per direction", beam.levels.lateral_mm,
                 beam.excess.lateral_mm))}}
    return EstimationSummary(
        parameters=[EstimatedParameter(name=p.name, unit=p.unit, value=float(v),
                                       std_error=float(s))
                    for p, v, s in zip(result.params, result.values, result.std_errors,
                                       strict=True) if p.group == "robot"],
        measuring_frame=MeasuringFrame(
            x=x, y=y, z=z, rx=rx, ry=ry, rz=rz,
            meaning="robot base in the measuring system's frame, mm/deg"),
        removed=[RemovedParameter(name=n, reason=why) for n, why in result.removed],
        rank=result.rank, condition_number=result.condition_number,
        chi2_reduced=result.chi2_reduced, converged=result.converged,
        noise=noise,
        warnings=list(result.warnings),
        residual_before_mm=float(result.residuals_before.mean()),
        residual_after_mm=float(result.residuals_after.mean()),
        compliance=compliance_summary(result),
        reading_lag={"per_joint": None if result.reading_lag is None else
                     [float(v) for v in result.reading_lag], "note": result.lag_note,
                     "meaning": "fraction of the previous move the joint readings trail",
                     "lost_motion_deg": lost_motion_deg(result)},
        explained_share=explained_share(result))


def explained_share(result: CalibrationResult) -> float:
    """How much of the error before the model explains: 1 - mean(after^2) / mean(before^2) of
    the calibration's position residuals (the nominal model's, then the identified one's)."""
    before = float(np.mean(np.square(result.residuals_before)))
    after = float(np.mean(np.square(result.residuals_after)))
    return 1.0 - after / before if before > 0 else 0.0


@dataclass(frozen=True)
class PlannedCorrection:
    """What a route will do (the result document's `correction` section) and, when it
    compensates, the performance list as it will be sent."""

    section: CorrectionPlan
    compensated: list[PlannedPose] | None = None


def plan_correction(result: CalibrationResult, route: str, nominal: SerialModel,
                    perf_plan: list[PlannedPose], suffix: Round,
                    payload: Payload | None = None, take_up_lost_motion: bool = False
                    ) -> PlannedCorrection:
    """What the route will do, checked before anything moves: the ZERO targets (refused
    when implausible), the compensated lists (refused when unreachable or implausible), the
    accuracy the model predicts before and after, and what stays in the robot. `payload`:
    what the robot carries during the performance list (default: the calibration's)."""
    robot_params = [(p, v) for p, v in zip(result.params, result.values, strict=True)
                    if p.group == "robot"]
    not_identified = [n for n, _ in result.removed if not n.startswith(("base", "tool"))]
    if route == "none":
        return PlannedCorrection(CorrectionPlan(
            route="none", note="a calibration job sends no correction; the calibrated model "
            "is downloadable (screwcal job model N)", not_identified=not_identified))
    q_nominal = np.radians([p.joints_deg for p in perf_plan])
    calibrated = result.model if payload is None else replace(result.model, payload=payload)
    robot = calibrated
    out: dict[str, Any] = {"route": route, "not_identified": not_identified}
    if route.startswith("zero"):
        correction = joint_correction(result.params, result.values, result.std_errors,
                                      nominal.n_joints)
        out |= correction.to_dict()
        robot = after_zero(robot, correction.zero_command_deg)
    target = flange_kinematics(nominal, q_nominal)
    before = flange_error_mm(calibrated, q_nominal, target)
    compensated = None
    if "compensate" in route:
        compensated, change = compensate_plan(perf_plan, robot, nominal)
        q_sent = np.radians([p.joints_deg for p in compensated])
        after = flange_error_mm(robot, q_sent, target)
        out |= {"compensated_lists": [compensated_list(suffix)], "max_joint_change_deg": change,
                "left_in_robot": []}
        if take_up_lost_motion and result.reading_lost_motion is not None:
            compensated = taken_up(compensated, lost_motion_deg(result))
            out["lost_motion_taken_up_deg"] = lost_motion_deg(result)
    else:
        after = flange_error_mm(robot, q_nominal, target)
        out["left_in_robot"] = [
            {"name": p.name, "value": float(v), "unit": p.unit}
            for p, v in robot_params if p.kind != "zero" and abs(v) > 0.0]
    out["predicted_position_error_mm"] = {
        "before": float(before.mean()), "after": float(after.mean()),
        "meaning": "mean over the performance targets of the calibrated model's flange "
                   "position minus the nominal target"}
    if after.mean() > before.mean():
        raise CorrectionRefusedError(
            f"the {route} route would leave the robot worse ({before.mean():.3f} -> "
            f"{after.mean():.3f} mm predicted): nothing is sent")
    return PlannedCorrection(CorrectionPlan.model_validate(out), compensated)


def performance_figures(rows: Sequence[Mapping[str, Any]], plan: Mapping[int, PlannedPose],
                        base: Array, point_in_tool0_mm: Array | None = None
                        ) -> PerformanceSection:
    """ISO 9283 per point and straightness of one performance list's committed poses, as the
    performance package computes them (`performance_section`: the evaluate command's), attained
    poses in the robot base frame. Poses of one measured point (positions only): the point's
    positions, commanded where the commanded tool0 puts `point_in_tool0_mm`."""
    full = not positions_only(rows)
    to_base = invert_transform(base)
    if full:
        attained = pose_from_transform(to_base @ transform_from_pose(
            np.array([r["flange_pose"] for r in rows])))
    else:
        attained = transform_points(to_base, np.array([r["holes_mm"][0] for r in rows]))
    point = np.zeros(3) if point_in_tool0_mm is None else np.asarray(point_in_tool0_mm)

    def commanded(p: PlannedPose) -> Array:
        cmd = np.array(p.commanded)
        if full:
            return cmd
        return np.concatenate([transform_points(transform_from_pose(cmd), point[None])[0],
                               cmd[3:]])

    by_point: dict[str, list[int]] = {}
    line = []
    for k, r in enumerate(rows):
        p = plan[r["idx"]]
        if p.role == "target":
            by_point.setdefault(p.point, []).append(k)
        elif p.role == "line":
            line.append(attained[k][:3] if not full else r["flange_pose"][:3])
    data = PerformanceData("measurements", tuple(
        PointData(label, commanded(plan[rows[ks[0]]["idx"]]), attained[ks])
        for label, ks in sorted(by_point.items()) if len(ks) >= 2), full_pose=full)
    path = straightness(np.array(line)) if len(line) >= 3 else None
    return PerformanceSection.model_validate(performance_section(data, path))


def home_check(nominal: SerialModel, last_home_rows: Mapping[str, Mapping[str, Any]],
               base: Array) -> HomeCheck | None:
    """Table 14: the flange at home (all joints 0) measured before and after the correction,
    in the robot base frame, against the nominal home. `last_home_rows`: the last committed
    pose of each home phase measured, by phase."""
    home = flange_kinematics(nominal, np.zeros((1, nominal.n_joints)))[0, :3, 3]
    measured: dict[str, HomeMeasurement] = {}
    for phase, row in last_home_rows.items():
        if not row["flange_pose"]:  # one point measured: not the flange
            continue
        T = invert_transform(base) @ transform_from_pose(np.array(row["flange_pose"]))
        error = T[:3, 3] - home
        measured[phase.removeprefix("home_")] = HomeMeasurement(
            measured_mm=T[:3, 3].round(3).tolist(), error_mm=error.round(3).tolist(),
            distance_mm=round(float(np.linalg.norm(error)), 3))
    if not measured:
        return None
    return HomeCheck.model_validate({
        **measured, "nominal_mm": home.round(3).tolist(),
        "note": "the robot sent to all joints 0 (HOME), its flange measured and compared with "
                "the nominal home (thesis Table 14); error = measured - nominal, robot base "
                "frame. After ZERO the controller's zeros are corrected; the compensate route "
                "corrects programmed targets, not the joints' zeros, so its home is the "
                "robot's uncorrected one"})


def iso_test_conditions(robot: RobotRecord, model: SerialModel,
                        options: JobOptions, plan: Mapping[int, PlannedPose],
                        created: float | None) -> dict[str, str | int | float]:
    """The conditions ISO 9283 asks a report to state."""
    centre = next(p.commanded[:3] for p in plan.values()
                  if p.point == "P1" and p.role == "target")
    return {
        "robot": f"{robot.name} (model {model.name})",
        "controller": f"{robot.controller_host}:{robot.controller_port}",
        **({"measuring arm": robot.arm_url} if robot.arm_url else
           {"instrument": robot.instrument_text()}),
        "cube edge mm": float(options.cube_edge_mm),
        "cube centre (P1) mm": ", ".join(f"{v:.1f}" for v in centre),
        "cycles": int(options.cycles),
        "warm-up": f"{options.warmup_cycles} test cycles run unmeasured before the test"
                   if options.warmup_cycles else "none",
        "speed": "v100, fine (the RAPID server module's MoveAbsJ)",
        "payload (performance lists)": _payload_text(list_payload(options, "perf")),
        "payload (calibration list)": _payload_text(list_payload(options, "cal")),
        "model beyond the geometry": f"compliance {options.compliance}, read-back lag "
                                     f"{options.lag}",
        "date (UTC)": time.strftime("%Y-%m-%d %H:%M", time.gmtime(created)) if created else "",
    }


def instrument_conditions(rows: Sequence[Mapping[str, Any]]) -> dict[str, str]:
    """What the instrument stated beside its points, over the job's committed poses: each
    point's uncertainty (the standard deviation along its worst direction) and the air it
    measured in; nothing for what it did not state."""
    out: dict[str, str] = {}
    cov = [c for r in rows for c in (r.get("covariance_mm2") or [])]
    if cov:
        worst = np.sqrt(np.linalg.eigvalsh(np.array(cov, dtype=float))[:, -1]) * 1000.0
        out["instrument uncertainty"] = (
            f"per point as it stated it, 1 sigma along the worst direction: median "
            f"{np.median(worst):.1f} um, {worst.min():.1f}-{worst.max():.1f} um "
            f"({len(worst)} points)")
    air = np.array([(c["temperature_c"], c["pressure_mbar"], c["humidity_pct"])
                    for r in rows if (c := r.get("conditions"))], dtype=float)
    if len(air):
        out["air (the instrument's weather)"] = (
            f"{air[:, 0].mean():.1f} deg C ({air[:, 0].min():.1f}-{air[:, 0].max():.1f}), "
            f"{air[:, 1].mean():.1f} mbar, {air[:, 2].mean():.0f} %RH (mean of {len(air)} "
            "poses)")
    return out


def payload_label(options: JobOptions, phase: str) -> str:
    """What the flange carries during a measured phase, as text (drift checks compare like
    with like)."""
    return _payload_text(list_payload(options, list_kind(phase)))


def _payload_text(payload: Payload) -> str:
    return (f"{payload.kg:g} kg at ({', '.join(f'{v:g}' for v in payload.cog_mm)}) mm in the "
            "flange frame" if payload.kg else "none")


def job_warnings(result: ResultDocument) -> list[str]:
    """What a user must see: a poor fit, an accuracy that did not improve, poses skipped."""
    out = [f"{len(skipped)} {phase} pose(s) skipped, never measured: the tracker's beam stayed "
           f"broken there (poses {', '.join(map(str, skipped))}): the reflector facing away or "
           "the robot in the line of sight; stand the tracker elsewhere to measure them"
           for phase, skipped in (result.poses_skipped or {}).items()]
    for suffix in ROUND_SUFFIXES:
        est = result.estimation_of(suffix)
        if est is None:
            continue
        out += [f"estimation{suffix}: {w}" for w in est.warnings]
        if est.chi2_reduced > POOR_FIT_CHI2:
            out.append(f"poor fit in the estimation{suffix}: chi2/dof {est.chi2_reduced:.1f} "
                       f"(> {POOR_FIT_CHI2:g}): the model misses something (compliance, a loose "
                       "flange, drift) or the noise is larger than stated")
    first, *later = PERF_PHASES
    before_ap, before_rp = result.overall(first, "ap_mm_mean"), result.overall(first, "rp_mm_mean")
    for phase in later:
        after_ap = result.overall(phase, "ap_mm_mean")
        if before_ap is not None and after_ap is not None and after_ap > before_ap:
            out.append(f"accuracy got worse in {phase}: AP mean {before_ap:.3f} -> "
                       f"{after_ap:.3f} mm; do not use this correction")
        after_rp = result.overall(phase, "rp_mm_mean")
        # repeatability is the robot's own: a correction should not change it; a rise beyond
        # 20 % (and 0.01 mm) says the corrected targets sit where the robot repeats worse
        if before_rp is not None and after_rp is not None and \
                after_rp > 1.2 * before_rp + 0.01:
            out.append(f"repeatability got worse in {phase}: RP mean {before_rp:.3f} -> "
                       f"{after_rp:.3f} mm (a correction should leave it unchanged): check "
                       "the cell (warm-up, payload, fixture) before trusting the after-figures")
    return out
