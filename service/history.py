"""A robot's history: every job with its provenance, every calibrated model as a version, the
accuracy trend across jobs, and the drift alarm (issue 28, points 4-5).

Provenance of a job, as stored when it was made and run: the software that made it, the robot's
identity then (serial number, controller software, tool, payload), the service that ran it, the
data it measured (poses per list), the correction route. A job whose estimation produced a model
is a model version (1, 2, ... per robot, in the order they were made).

Accuracy is ISO 9283's AP (mean over the poses, mm) of the job's last performance list: the
list after the correction for a procedure, its only list for a performance job. The alarm: the
newest AP measured after the robot's newest model has grown by more than `threshold_mm` over the
AP that model reached (its procedure's list after; or, for a calibration alone, the first
performance job after it), i.e. the robot has drifted since its last calibration (a collision, a
gearbox or motor change, thermal change): re-calibrate.
"""

from __future__ import annotations

import time
from typing import Any

from pydantic import BaseModel, Field

from service.document import JobRecord
from service.job_state import JobState
from service.phases import PERF_PHASES, is_correction
from service.store import IDENTITY, Store


class HistoryEntry(BaseModel):
    job: int
    kind: str
    state: JobState
    created: float
    finished: float | None = Field(None, description="when the job ended (epoch seconds)")
    software: str = Field(description="the screwcal that made the job")
    service: str | None = Field(None, description="the service (lease holder) that ran it last")
    robot_identity: dict[str, Any] | None = Field(
        None, description="serial, controller software, tool, payload when the job was made")
    poses: dict[str, int] = Field(description="the data: poses measured per list")
    route: str | None = Field(None, description="the correction route applied (procedures)")
    confirmed: list[dict[str, Any]] = Field(
        default_factory=list, description="the correction's go-aheads: phase, pose, who, when "
        "(a ZERO waits for a person in every mode)")
    go_aheads: int = Field(0, description="go-aheads given by people in all (STEP mode)")
    model_version: int | None = Field(None, description="the n-th model of this robot: set "
                                      "when the job's estimation produced one")
    ap_before_mm: float | None = Field(None, description="AP before the correction")
    ap_mm: float | None = Field(None, description="AP of the job's last performance list")
    rp_mm: float | None = None


class DriftAlarm(BaseModel):
    model_version: int
    model_job: int
    baseline_ap_mm: float
    latest_job: int
    latest_ap_mm: float
    threshold_mm: float
    message: str


class RobotHistory(BaseModel):
    robot: int
    name: str
    identity: dict[str, Any]
    entries: list[HistoryEntry]
    trend: list[tuple[int, float, float]] = Field(
        description="(job, when it ended, AP mm) of every finished job that measured AP")
    alarm: DriftAlarm | None = None


def _accuracy(job: JobRecord) -> tuple[float | None, float | None, float | None]:
    """(AP before the correction, AP of the last performance list, its RP) of a job."""
    result = job.result
    measured = [p for p in PERF_PHASES if result.overall(p, "ap_mm_mean") is not None]
    if not measured:
        return None, None, None
    first, last = measured[0], measured[-1]
    before = result.overall(first, "ap_mm_mean") if len(measured) > 1 else None
    return before, result.overall(last, "ap_mm_mean"), result.overall(last, "rp_mm_mean")


def _entry(job: JobRecord, extra: dict[str, Any], version: int | None,
           confirmations: list[dict[str, Any]]) -> HistoryEntry:
    before, ap, rp = _accuracy(job) if job.state == JobState.DONE else (None, None, None)
    route = job.result.correction.route if job.result.correction is not None else None
    return HistoryEntry(
        job=job.id, kind=job.kind, state=job.state, created=job.created,
        finished=job.updated if job.state.finished else None,
        software=extra["software"] or "unknown (made before provenance was kept)",
        service=extra["service"], robot_identity=extra["robot_identity"],
        poses=extra["poses"], route=route, model_version=version, ap_before_mm=before,
        confirmed=[c for c in confirmations if is_correction(c["phase"])],
        go_aheads=len(confirmations),
        ap_mm=ap, rp_mm=rp)


def drift_alarm(entries: list[HistoryEntry], threshold_mm: float) -> DriftAlarm | None:
    """The alarm when AP has degraded by more than threshold_mm since the newest model."""
    models = [e for e in entries if e.model_version is not None]
    if not models:
        return None
    model = models[-1]
    measured = [(e.job, e.ap_mm) for e in entries if e.job > model.job and e.ap_mm is not None]
    if model.ap_mm is not None:
        measured.insert(0, (model.job, model.ap_mm))
    # the baseline: what the model reached (or, a calibration alone, the first AP after it)
    if len(measured) < 2:
        return None
    baseline = measured[0][1]
    latest_job, latest_ap = measured[-1]
    if latest_ap - baseline <= threshold_mm:
        return None
    return DriftAlarm(
        model_version=model.model_version or 0, model_job=model.job,
        baseline_ap_mm=baseline, latest_job=latest_job, latest_ap_mm=latest_ap,
        threshold_mm=threshold_mm,
        message=f"accuracy has drifted since model {model.model_version} (job {model.job}): AP "
                f"{baseline:.3f} -> {latest_ap:.3f} mm (job {latest_job}), more than "
                f"{threshold_mm:g} mm worse: check the robot (collision, gearbox or motor "
                "change, temperature) and calibrate it again")


def robot_history(store: Store, robot_id: int, threshold_mm: float) -> RobotHistory:
    robot = store.robot(robot_id)
    entries, version = [], 0
    for job, extra in store.robot_jobs(robot_id):
        made = job.state == JobState.DONE and job.result.estimation is not None
        version += made
        entries.append(_entry(job, extra, version if made else None,
                              store.confirmations(job.id)))
    trend = [(e.job, e.finished or e.created, e.ap_mm) for e in entries
             if e.ap_mm is not None]
    return RobotHistory(robot=robot_id, name=robot.name,
                        identity=robot.model_dump(include=set(IDENTITY)), entries=entries,
                        trend=trend, alarm=drift_alarm(entries, threshold_mm))


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def history_text(doc: RobotHistory) -> str:
    """The history as the CLI prints it: one line per job, then the alarm (or its absence)."""
    ident = ", ".join(f"{k} {v}" for k, v in doc.identity.items() if v not in ("", None))
    lines = [f"robot {doc.robot}: {doc.name}" + (f" ({ident})" if ident else ""),
             f"{'job':>5} {'kind':<12}{'state':<9}{'model':<6}{'route':<17}{'AP before':>10}"
             f"{'AP mm':>8}{'RP mm':>8}  poses  software, service"]
    for e in doc.entries:
        lines.append(
            f"{e.job:>5} {e.kind:<12}{e.state:<9}"
            f"{'v' + str(e.model_version) if e.model_version else '-':<6}{e.route or '-':<17}"
            f"{_mm(e.ap_before_mm):>10}{_mm(e.ap_mm):>8}{_mm(e.rp_mm):>8}  "
            f"{sum(e.poses.values()):>5}  {e.software}, {e.service or '-'}")
        lines += [f"{'':>6}{c['phase']} confirmed by {c['operator']} at "
                  f"{time.strftime('%Y-%m-%d %H:%M:%S', time.localtime(c['at']))}"
                  for c in e.confirmed]
    lines.append(f"DRIFT ALARM: {doc.alarm.message}" if doc.alarm is not None else
                 "no drift alarm")
    return "\n".join(lines)
