"""Runs one job: the thesis's flow (Fig. 41) against a real (or emulated) controller and arm.

A short sequencer over three parts: acquisition (`service/acquisition.py`: the links, the
measured poses, the operator's gate), analysis (`service/analysis.py`: estimation summary,
correction planning, ISO 9283 performance, home check, warnings; no I/O) and the job's result
document as stored.

Kinds: `performance` (the ISO 9283 list), `calibration` (the calibration list and the
estimation), `procedure` (performance before, calibration, estimation, correction, performance
after); the steps of each are in `service/phases.py`.

Correction routes (`options.correction`) of a procedure:
- `compensate` (default): nothing changes in the controller; every performance list after the
  estimation is sent as the joint targets that make the *calibrated* robot reach the nominal
  targets
  (`screwcal.calibration.correction.compensate`), all computed and checked (reach, limits,
  plausibility) before anything moves;
- `zero`: the thesis's route (4.5): ZERO moves to the identified offsets and makes them the new
  zero; the link errors stay in the robot;
- `zero+compensate`: ZERO for the joint offsets, then compensation of what remains with the model
  updated for the new zeros.
A ZERO on a real IRC5 stops (WAIT 0) while a person enters the offsets on the FlexPendant: that
WAIT needs the operator's go-ahead in every mode, AUTO included.

A lost controller or arm link pauses the job (its state says why); it resumes from the next
unmeasured pose when the link is back. A store that cannot be written for now (a full disk, a
file-size limit, a lost PostgreSQL connection) pauses it too, the robot waiting where it is,
until the store takes the call again (service/outage.py). A correction outside plausible
bounds, or a target outside the joint limits, fails the job before anything is sent.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from protocol.errors import ControllerError
from screwcal.calibration.correction import CorrectionRefusedError, after_zero
from screwcal.calibration.identify import identify
from screwcal.calibration.residual_model import residual_from_document
from screwcal.calibration.residual_stage import learn_residual
from screwcal.calibration.resultfile import result_document
from screwcal.errors import ScrewcalError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import model_document, parse_model
from service import analysis, instrument_fit
from service.acquisition import LINK_ERRORS, Acquisition, JobAborted, OperatorGate
from service.document import JobRecord, PhaseRecord, ResultDocument
from service.drift import (
    DRIFT_PHASE,
    DriftSchedule,
    drift_schedule,
    drift_section,
    drift_warnings,
)
from service.errors import ConflictError, SafetyError, StoreLostError, StoreUnavailableError
from service.events import JobEvents
from service.job_state import JobState
from service.outage import StoreOutage
from service.phases import (
    ESTIMATION_FOR,
    HOME_PHASES,
    PERF_PHASES,
    SETUP,
    STEP_OF,
    Action,
    Round,
    calibration_list,
    compensated_list,
    correction_step,
    is_correction,
    job_steps,
    list_kind,
)
from service.plans import LISTS_OF_KIND, PlannedPose, plan_for
from service.robot_record import RobotRecord
from service.settings import ServiceSettings
from service.store import Store
from service.verify import VERIFY_PHASE, verification_targets
from service.verify import drift_warnings as alarm_warnings


class JobRunner:
    """One job's runner. Every store call of its coroutines runs in a worker thread (the event
    loop serves every other job and client meanwhile); `open` reads the job and its robot."""

    def __init__(self, store: Store, settings: ServiceSettings, events: JobEvents,
                 job: JobRecord, robot: RobotRecord, on_fatal: Callable[[str], None] | None = None,
                 plans: dict[str, list[PlannedPose]] | None = None):
        self.store, self.settings, self.events, self.job_id = store, settings, events, job.id
        self.on_fatal = on_fatal
        self.job, self.robot = job, robot
        self.model = parse_model(self.robot.model, f"robot {self.robot.id}")
        self.options = self.job.options
        self.gate = OperatorGate(step_mode=self.job.mode == "STEP")
        self.outage = StoreOutage(store, events, job.id, settings.reconnect_interval_s)
        self.acquisition = Acquisition(store, settings, events, job.id, self.robot, self.model,
                                       self.gate, self.outage)
        self._plans: dict[str, list[PlannedPose]] = dict(plans or {})
        self._compensated: dict[str, list[PlannedPose]] = {}

    @classmethod
    async def open(cls, store: Store, settings: ServiceSettings, events: JobEvents, job_id: int,
                   on_fatal: Callable[[str], None] | None = None,
                   plans: dict[str, list[PlannedPose]] | None = None) -> JobRunner:
        """The runner of a stored job (its records read in a worker thread)."""
        job = await asyncio.to_thread(store.job, job_id)
        robot = await asyncio.to_thread(store.robot, job.robot_id)
        return cls(store, settings, events, job, robot, on_fatal, plans)

    # -- plans ---------------------------------------------------------------------------------
    def plan(self, kind: str) -> list[PlannedPose]:
        """The job's "cal" or "perf" list (deterministic from its options; built once: by the
        request that posted the job, else by `_build_plans` when the runner starts)."""
        if kind not in self._plans:
            self._plans[kind] = plan_for(self.model, kind, self.options, self.robot.instrument)
        return self._plans[kind]

    async def _build_plans(self) -> None:
        """The lists the job's kind runs, built in a worker thread (tens of ms of IK each:
        not on the event loop, where every other job's link waits meanwhile)."""
        for kind in LISTS_OF_KIND[self.job.kind]:
            if kind not in self._plans:
                self._plans[kind] = await asyncio.to_thread(plan_for, self.model, kind,
                                                            self.options,
                                                            self.robot.instrument)

    @property
    def route(self) -> str:
        """The correction route of a procedure; 'none' for the other kinds."""
        return self.options.correction if self.job.kind == "procedure" else "none"

    def targets(self, phase: str) -> list[PlannedPose]:
        """What a phase sends: its plan, compensated when the route says so (built once)."""
        if phase in HOME_PHASES:
            return [PlannedPose(0, (0.0,) * self.model.n_joints, "home")]
        plan = self.plan(list_kind(phase))
        if phase == VERIFY_PHASE and self.options.frame_from_job is not None:
            if phase not in self._compensated:  # as production sends it with the model
                self._compensated[phase] = verification_targets(
                    self.store, plan, self.options.frame_from_job, self.model)
            return self._compensated[phase]
        suffix = ESTIMATION_FOR.get(phase)
        if suffix is None or "compensate" not in self.route:
            return plan
        if phase not in self._compensated:
            compensated = analysis.compensate_plan(
                plan, self.robot_model(suffix), self.model,
                residual_from_document(self.job.result.calibration_of(suffix)))[0]
            est = self.job.result.estimation_of(suffix)
            lost = (est.reading_lag or {}).get("lost_motion_deg") if est is not None else None
            self._compensated[phase] = analysis.taken_up(
                compensated, lost if self.options.take_up_lost_motion else None)
        return self._compensated[phase]

    def robot_model(self, suffix: Round) -> SerialModel:
        """The robot as its controller now reads it, from the stored calibration document."""
        doc = self.job.result.calibration_of(suffix)
        if not doc:
            raise SafetyError(f"no calibrated model for the estimation{suffix or ''}: the "
                              "compensated targets cannot be built")
        robot = parse_model(doc["model"], f"job {self.job_id} calibration{suffix}")
        return replace(robot, payload=analysis.list_payload(self.options, "perf"))

    def warmup_plan(self) -> list[PlannedPose]:
        """ISO 9283's warm-up: the performance list's first cycle (return points and targets),
        `warmup_cycles` times."""
        cycle = [p for p in self.plan("perf") if p.cycle == 1]
        return [replace(p, idx=k * len(cycle) + i) for k in range(self.options.warmup_cycles)
                for i, p in enumerate(cycle)]

    def steps(self) -> tuple[str, ...]:
        return job_steps(self.job.kind, self.options.rounds, self.options.warmup_cycles > 0)

    # -- the job -------------------------------------------------------------------------------
    async def run(self) -> None:
        """The steps in order. Before each, the step is claimed in the store, which re-reads the
        job's phases there: what is done is skipped, a correction that was started and not
        finished is never sent again, and a runner whose job another ended stops."""
        try:
            await self._set(JobState.RUNNING, "")
            t0 = time.perf_counter()
            await self._build_plans()
            await self._with_links(SETUP)
            if SETUP not in self.job.phases:
                await self.outage.call(self.store.finish_step, self.job_id, SETUP,
                                       time.perf_counter() - t0)
            for step in self.steps():
                phase = await self.outage.call(self._claim, step)
                if phase.done:
                    continue
                if is_correction(step) and phase.started \
                        and self.route.startswith("zero"):
                    raise SafetyError("the job stopped during the correction: whether ZERO took "
                                      "effect is unknown; check the controller, then start anew")
                start = time.perf_counter()
                await self._with_links(step)
                seconds = time.perf_counter() - start
                await self.outage.call(self.store.finish_step, self.job_id, step, seconds)
                await self.events.publish("phase", phase=step, seconds=seconds)
            await self._set(JobState.DONE, "")
            await self.events.publish(JobState.DONE)
        except ConflictError as err:  # a stale runner: another ended this job; touch nothing
            await self.events.publish("stale", reason=str(err))
        except StoreLostError as err:
            if self.on_fatal is not None:
                self.on_fatal(str(err))
            await self.events.publish(JobState.FAILED, reason=str(err))
        except JobAborted:
            await self._aborted()
        except ControllerError as err:
            if self.gate.aborted.is_set():  # the controller's ERR 22 for the run we aborted
                await self._aborted()
            else:
                await self._failed(str(err))
        except (SafetyError, CorrectionRefusedError, ScrewcalError) as err:
            await self._failed(str(err))
        except Exception as err:  # a job never stays "running" after its task ended
            await self._set(JobState.FAILED, f"internal error: {err!r}")
            await self.events.publish(JobState.FAILED, reason=repr(err))
            raise
        finally:
            await self.acquisition.disconnect()

    def _claim(self, step: str) -> PhaseRecord:
        """Claim `step` in the store (ConflictError for a stale runner); its record as it was,
        and the job's results as stored, not our copy."""
        phase = self.store.claim_step(self.job_id, step).get(step, PhaseRecord())
        self.job = self.store.job(self.job_id)
        return phase

    async def abort(self) -> None:
        await self.acquisition.abort()

    async def _aborted(self) -> None:
        await self._set(JobState.ABORTED, "aborted by the operator")
        await self.events.publish(JobState.ABORTED)

    async def _failed(self, reason: str) -> None:
        await self._set(JobState.FAILED, reason)
        await self.events.publish(JobState.FAILED, reason=reason)

    async def _set(self, state: JobState, reason: str) -> None:
        self.job = await self.outage.call(self.store.set_state, self.job_id, state, reason)

    async def _with_links(self, step: str) -> None:
        """Run a step; a lost link pauses the job until it is back, then the step goes on; so
        does a store that failed it (an estimation's result not stored, say): once the store
        is back, the step runs again (what it committed is kept, service/outage.py)."""
        while True:
            try:
                await self._step(step)
                return
            except StoreUnavailableError as err:
                await self.outage.wait(err)
            except LINK_ERRORS as err:
                if self.gate.aborted.is_set():
                    raise JobAborted() from None
                await self._set(JobState.PAUSED, f"{type(err).__name__}: {err}")
                await self.events.publish(JobState.PAUSED, reason=str(err))
                await self.acquisition.reconnect()
                await self._set(JobState.RUNNING, "")
                await self.events.publish("resumed", phase=step)

    async def _step(self, step: str) -> None:
        action, suffix = STEP_OF[step].action, STEP_OF[step].round
        if action is Action.SETUP:
            await self.acquisition.connect()
        elif action is Action.WARMUP:
            await self.acquisition.move_through(step, self.warmup_plan())
        elif action is Action.MEASURE:
            if self.options.drift_poses and self.acquisition.drift is None:
                # the test cube's search: in a thread, never in the loop (nor at start-up)
                self.acquisition.drift = await asyncio.to_thread(self.drift_schedule)
            # compensated targets: CPU and a store read, in a thread
            await self.acquisition.measure(step, await asyncio.to_thread(self.targets, step))
        elif action is Action.ESTIMATE:
            await asyncio.to_thread(self.estimate, suffix)
        elif action is Action.CORRECT:
            await self.correct(suffix)
        elif action is Action.EVALUATE:
            await asyncio.to_thread(self.evaluate)
            for warning in self.job.result.warnings or []:
                await self.events.publish("warning", message=warning)

    # -- estimation, correction, evaluation ---------------------------------------------------
    def estimate(self, suffix: Round = "") -> None:
        kind = self.options.model
        by_phase = self._rows_by_phase()
        rows = by_phase.get(calibration_list(suffix), [])
        # every other pose of the job: the one the robot came from to each (the lag's)
        data = analysis.measurement_set(rows, [r for phase, others in by_phase.items()
                                               if phase != calibration_list(suffix)
                                               for r in others])
        nominal = replace(self.model, payload=analysis.list_payload(self.options, "cal"))
        result, beam, frames = instrument_fit.fit(  # by what the instrument measured
            nominal, data, self.robot, kind=kind, compliance=self.options.compliance,
            lag=self.options.lag)
        doc = self.job.result.with_round(
            suffix, estimation=analysis.estimation_summary(result, beam),
            calibration=result_document(
                result, self.model.name, {"model": kind, "frames": frames, "poses": len(data),
                                          "job": self.job_id, "phase": calibration_list(suffix),
                                          "compliance": self.options.compliance,
                                                          "lag": self.options.lag})
            | {"residual_model": learn_residual(result, data).to_dict()})  # its stage
        doc.base = result.model.base.tolist()
        if self.options.backlash_poses:
            doc.backlash = analysis.backlash_summary(result, rows, self.plan("cal"))
        doc = self.with_drift(doc, by_phase)
        doc.warnings = analysis.job_warnings(doc) + drift_warnings(doc)
        try:
            perf_plan = self.plan("perf") if self.route != "none" else []
            planned = analysis.plan_correction(
                result, self.route, self.model, perf_plan, suffix,
                analysis.list_payload(self.options, "perf"), self.options.take_up_lost_motion)
            doc = doc.with_round(suffix, correction=planned.section)
            if planned.compensated is not None:
                self._compensated[compensated_list(suffix)] = planned.compensated
        finally:
            self.job = self.store.set_result(self.job_id, doc)

    async def correct(self, suffix: Round = "") -> None:
        correction = self.job.result.correction_of(suffix)
        if not self.route.startswith("zero"):
            await self.events.publish("corrected", route=self.route, note="nothing sent to "
                                      "the controller: the later lists are compensated")
            return
        zero = np.array(correction.zero_command_deg if correction is not None
                        and correction.zero_command_deg is not None else [], dtype=float)
        if correction is None or zero.size != self.model.n_joints:
            raise SafetyError("no correction to send")
        if not self.model.within_limits(np.radians(zero)):
            raise SafetyError(f"correction target {zero.round(4).tolist()} outside the limits")
        await self.acquisition.zero(correction_step(suffix), zero.tolist())
        doc = dict(self.job.result.calibration_of(suffix) or {})
        doc["model"] = model_document(after_zero(parse_model(doc["model"]), zero))
        doc["model_note"] = ("the robot once ZERO made the identified offsets the new zero: "
                             "the model of the joints as the controller now reads them")
        sent = correction.model_copy(update={"sent": True})
        self.job = await self.outage.call(self.store.set_result, self.job_id,
                                          self.job.result.with_round(suffix, calibration=doc,
                                                                     correction=sent))
        await self.events.publish("corrected", route=self.route,
                                  zero_command_deg=zero.tolist())

    def evaluate(self) -> None:
        doc = self.job.result.model_copy()
        by_phase = self._rows_by_phase()
        if doc.base is not None:
            doc.frame_note = ("accuracy measured in the robot base frame identified by this "
                              "job's calibration, before and after alike")
        elif (source := self.options.frame_from_job) is not None:
            # the frame an earlier calibration identified
            doc.base = self.store.job(source).result.base
            doc.frame_note = (f"accuracy measured in the robot base frame identified by job "
                              f"{source}'s calibration")
        else:  # a performance job alone: the measuring frame from its own data
            data = analysis.measurement_set(by_phase.get(PERF_PHASES[0], []))
            nominal = self.model if data.rotations is not None else \
                self.model.with_frames(tool=instrument_fit.point_frame(self.robot))
            doc.base = identify(nominal, data, kind="frames", frames="base").model.base.tolist()
            doc.frame_note = (
                "accuracy measured in a robot base frame fitted to this performance data "
                "itself (no calibration in this job): it hides any error such a frame absorbs, "
                "so it reads lower than after a calibration's frame")
        if doc.base is None:
            raise SafetyError(f"job {self.options.frame_from_job} has no identified robot base "
                              "frame to measure in")
        base = np.array(doc.base)
        plan = {p.idx: p for p in self.plan("perf")}
        point = None if not any(map(analysis.positions_only, by_phase.values())) else \
            instrument_fit.measured_point(self.robot, doc.calibration_of(doc.latest_round()))
        doc.performance = {
            phase: analysis.performance_figures(rows, plan, base, point) for phase in PERF_PHASES
            if (rows := by_phase.get(phase))}
        last_home = {phase: rows[-1] for phase in HOME_PHASES if (rows := by_phase.get(phase))}
        home = analysis.home_check(self.model, last_home, base)
        if home is not None:
            doc.home_check = home
        doc.test_conditions = {
            **analysis.iso_test_conditions(self.robot, self.model, self.options, plan,
                                           self.job.created),
            **analysis.instrument_conditions([r for rows in by_phase.values() for r in rows])}
        doc = self.with_drift(doc, by_phase)
        doc.warnings = analysis.job_warnings(doc) + drift_warnings(doc)
        if self.job.kind == "verify":  # the drift alarm, in the job's own result and report
            doc.warnings += alarm_warnings(self.store, self.job, doc,
                                           self.settings.drift_alarm_mm)
        self.job = self.store.set_result(self.job_id, doc)

    def drift_schedule(self) -> DriftSchedule | None:
        """The job's drift checks (service/drift.py), from its performance list."""
        return drift_schedule(self.options, self.plan("perf")) if self.options.drift_poses \
            else None

    def _rows_by_phase(self) -> dict[str, list[dict]]:
        """The job's committed poses (read once), by phase, each phase's in index order."""
        by_phase: dict[str, list[dict]] = {}
        for row in self.store.measurements(self.job_id):  # ordered by phase, then index
            by_phase.setdefault(row["phase"], []).append(row)
        return by_phase

    def with_drift(self, doc: ResultDocument, by_phase: dict[str, list[dict]]
                   ) -> ResultDocument:
        """The result with its drift section (service/drift.py) from the committed checks
        (`by_phase`: the job's rows, `_rows_by_phase`), against the latest calibration's
        promise (in a thread: it may build the plan)."""
        schedule = self.drift_schedule()
        if schedule is None:
            return doc
        drift_rows = by_phase.get(DRIFT_PHASE, [])
        others = [r for phase, rows in by_phase.items() if phase != DRIFT_PHASE for r in rows]
        loads = {phase: self._series_of(phase) for phase in by_phase if phase != DRIFT_PHASE}
        promised, cal_phases = None, []
        suffix = doc.latest_round()
        est = doc.estimation_of(suffix)
        if est is not None:
            cal_phases = [calibration_list(suffix)]
            sigma = (est.noise or {}).get("position", {}).get("value") or \
                est.residual_after_mm / np.sqrt(3.0)
            promised = float(sigma)
        return doc.model_copy(update={"drift": drift_section(
            schedule, drift_rows, others, loads, cal_phases, promised)})

    def _series_of(self, phase: str) -> str:
        """Which drift series a check interleaved with `phase` belongs to: what the flange
        carries, and on a ZERO route how many ZEROs came before (a ZERO moves the joints'
        zeros, so the same commanded joints put the arm elsewhere: no drift)."""
        label = analysis.payload_label(self.options, phase)
        steps = self.steps()
        zeros = sum(1 for step in steps[:steps.index(phase)] if is_correction(step)) \
            if self.route.startswith("zero") and phase in steps else 0
        return f"{label}, after {zeros} ZERO" if zeros else label
