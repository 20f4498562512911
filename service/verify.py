"""The `verify` job (issue 28, point 5): a short ISO 9283 pose test of a robot with its current
model, no estimation: cheaper than a calibration, and what the drift alarm watches.

Its frame and model are those of the robot's newest model (the newest job whose estimation
produced one, or the job named by frame_from_job): the accuracy is measured in the base frame
that calibration identified, and the targets are sent as the robot runs in production with it:
compensated by the calibrated model when its route compensates, as planned when the route was
ZERO (the controller holds the offsets) or when the model was never applied (a calibration
alone). The evaluation warns when the AP measured is worse than what that model reached by more
than the service's drift_alarm_mm (service/history.py).
"""

from __future__ import annotations

from screwcal.calibration.residual_model import residual_from_document
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import parse_model
from service import analysis
from service.document import JobOptions, JobRecord, ResultDocument
from service.errors import ConflictError
from service.history import drift_alarm, robot_history
from service.plans import PlannedPose
from service.store import Store

VERIFY_CYCLES = 10  # a short pose test: ISO 9283 asks 30 for a full one
VERIFY_PHASE = "perf_verify"


def newest_model_job(store: Store, robot_id: int) -> int | None:
    models = [e.job for e in robot_history(store, robot_id, threshold_mm=1.0).entries
              if e.model_version is not None]
    return models[-1] if models else None


def verify_options(store: Store, robot_id: int, options: JobOptions) -> JobOptions:
    """A verify job's options: the newest model's job as its frame (unless one is named), and
    the short cycle count unless cycles were given. ConflictError when the robot has no model
    to verify yet."""
    source = options.frame_from_job or newest_model_job(store, robot_id)
    if source is None:
        raise ConflictError(f"robot {robot_id} has no calibrated model to verify yet: run a "
                            "calibration or procedure job first")
    update: dict = {"frame_from_job": source}
    if "cycles" not in options.model_fields_set:
        update["cycles"] = VERIFY_CYCLES
    return options.model_copy(update=update)


def verification_targets(store: Store, plan: list[PlannedPose], source_job: int,
                         nominal: SerialModel) -> list[PlannedPose]:
    """The verify list as production would send it with the source job's model."""
    result = store.job(source_job).result
    suffix = result.latest_round()
    correction = result.correction_of(suffix)
    route = correction.route if correction is not None else "none"
    calibration = result.calibration_of(suffix)
    if "compensate" not in route or not calibration:
        return plan
    model = parse_model(calibration["model"], f"job {source_job} calibration{suffix}")
    return analysis.compensate_plan(plan, model, nominal, residual_from_document(
        calibration, f"job {source_job} calibration{suffix}"))[0]


def drift_warnings(store: Store, job: JobRecord, doc: ResultDocument,
                   threshold_mm: float) -> list[str]:
    """The drift alarm as a warning of the verify job itself (its AP against the model's)."""
    ap = doc.overall(VERIFY_PHASE, "ap_mm_mean")
    if ap is None:
        return []
    entries = [e for e in robot_history(store, job.robot_id, threshold_mm).entries
               if e.job != job.id]
    this = entries[-1].model_copy(update={"job": job.id, "kind": job.kind, "ap_mm": ap,
                                          "model_version": None}) if entries else None
    alarm = drift_alarm([*entries, this], threshold_mm) if this is not None else None
    return [alarm.message] if alarm is not None else []
