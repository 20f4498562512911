"""Runs one job: the thesis's flow (Fig. 41) against a real (or emulated) controller and arm.

Kinds: `performance` (the ISO 9283 list), `calibration` (the calibration list and the
estimation), `procedure` (performance before, calibration, estimation, correction, performance
after). Every list runs in STEP mode on the wire: the go-ahead for a pose is sent only once the
previous pose is committed to the store, so no measurement is ever lost to a crash; an AUTO job
gives the go-ahead itself, a STEP job waits for the operator's.

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
unmeasured pose when the link is back. A correction outside plausible bounds, or a target outside
the joint limits, fails the job before anything is sent.
"""

from __future__ import annotations

import asyncio
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from protocol.arm import ArmReader
from protocol.arm_url import check_arm_url
from protocol.client import ControllerClient, Timeouts
from protocol.codec import MAX_LIST
from protocol.errors import (
    ArmLineError,
    ControllerError,
    LinkError,
    LinkTimeoutError,
    ProtocolError,
)
from screwcal.calibration.correction import (
    CorrectionRefusedError,
    after_zero,
    compensate,
    joint_correction,
)
from screwcal.calibration.flange import MeasuringFlange
from screwcal.calibration.identify import CalibrationResult, identify
from screwcal.calibration.measurements import MeasurementSet
from screwcal.calibration.resultfile import result_document
from screwcal.errors import ScrewcalError
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import model_document, parse_model
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
from screwcal.kinematics.se3 import invert_transform
from screwcal.performance.evaluate import PerformanceData, PointData, point_metrics, summarise
from screwcal.performance.straightness import straightness
from service.errors import ConflictError, SafetyError, StoreFullError, StoreLostError
from service.events import JobEvents
from service.plans import PlannedPose, plan_for
from service.readings import EarlierReadings, MotionTolerance, PoseReading, refusal
from service.settings import ServiceSettings
from service.store import Store

STEPS = {
    "performance": ("perf_before", "evaluation"),
    "calibration": ("cal", "estimation"),
    "procedure": ("home_before", "perf_before", "cal", "estimation", "correction", "home_after",
                  "perf_after", "evaluation"),
}
# Table 14's check: the robot sent home (all joints 0) before and after, its flange measured.
HOME_PHASES = ("home_before", "home_after")
# The thesis's "Calibracao 2" (4.7): acquire again, estimate, correct, evaluate.
SECOND_ROUND = ("cal_2", "estimation_2", "correction_2", "perf_after_2")
PERF_PHASES = ("perf_before", "perf_after", "perf_after_2")
POOR_FIT_CHI2 = 10.0  # chi2/dof above this with the stated noise: the model misses something
# The estimation whose model drives a performance list's targets when the route compensates.
# A calibration list (the second round's) is sent as planned: its poses need reach no
# particular target, only be measured, and compensating them could push one out of the limits.
ESTIMATION_FOR = {"perf_after": "", "perf_after_2": "_2"}
ZERO_NOTE = ("ZERO: the robot stands at the correction; enter the offsets on the FlexPendant "
             "(calibration data), then give the go-ahead")
LINK_ERRORS = (LinkError,)  # protocol/errors.py: lost, timed out, busy, the arm's line or port


class JobAborted(Exception):  # noqa: N818 (control flow, not an error)
    """The operator aborted the job."""


class JobRunner:
    def __init__(self, store: Store, settings: ServiceSettings, events: JobEvents, job_id: int,
                 on_fatal: Callable[[str], None] | None = None):
        self.store, self.settings, self.events, self.job_id = store, settings, events, job_id
        self.on_fatal = on_fatal
        self.discarded: Counter[str] = Counter()  # arm readings refused, by kind
        self.job = store.job(job_id)
        self.robot = store.robot(self.job["robot_id"])
        self.model = parse_model(self.robot["model"], f"robot {self.robot['id']}")
        self.flange = MeasuringFlange.from_holes_in_flange(self.robot["holes_mm"])
        self.options: dict[str, Any] = self.job["options"]
        self.client: ControllerClient | None = None
        self.arm: ArmReader | None = None
        self.aborted = asyncio.Event()
        self.go_ahead: asyncio.Queue[int] = asyncio.Queue()
        self.waiting_for: tuple[str, int] | None = None
        self._plans: dict[str, list[PlannedPose]] = {}
        self._compensated: dict[str, list[PlannedPose]] = {}

    # -- plans ---------------------------------------------------------------------------------
    def plan(self, kind: str) -> list[PlannedPose]:
        """The job's "cal" or "perf" list (deterministic from its options; built once)."""
        if kind not in self._plans:
            self._plans[kind] = plan_for(self.model, kind, self.options)
        return self._plans[kind]

    @property
    def route(self) -> str:
        """The correction route of a procedure; 'none' for the other kinds."""
        if self.job["kind"] != "procedure":
            return "none"
        return str(self.options.get("correction", "compensate"))

    def targets(self, phase: str) -> list[PlannedPose]:
        """What a phase sends: its plan, compensated when the route says so (built once)."""
        if phase in HOME_PHASES:
            return [PlannedPose(0, (0.0,) * self.model.n_joints, "home")]
        plan = self.plan("cal" if phase.startswith("cal") else "perf")
        suffix = ESTIMATION_FOR.get(phase)
        if suffix is None or "compensate" not in self.route:
            return plan
        if phase not in self._compensated:
            self._compensated[phase] = self._compensate_plan(plan, self.robot_model(suffix))[0]
        return self._compensated[phase]

    def robot_model(self, suffix: str) -> SerialModel:
        """The robot as its controller now reads it, from the stored calibration document."""
        doc = (self.job["result"] or {}).get("calibration" + suffix)
        if not doc:
            raise SafetyError(f"no calibrated model for the estimation{suffix or ''}: the "
                              "compensated targets cannot be built")
        return parse_model(doc["model"], f"job {self.job_id} calibration{suffix}")

    def _compensate_plan(self, plan: list[PlannedPose], robot: SerialModel
                         ) -> tuple[list[PlannedPose], float]:
        """The plan's joints replaced by those that take `robot` to the nominal targets, and the
        largest joint change (deg). Raises before anything moves when one cannot be reached."""
        q_nominal = np.radians([p.joints_deg for p in plan])
        comp = compensate(robot, self.model, flange_kinematics(self.model, q_nominal),
                          q_nominal, frame="base")
        q = np.round(np.degrees(comp.q_rad), 4)
        return ([replace(p, joints_deg=tuple(float(v) for v in q[k]))
                 for k, p in enumerate(plan)], comp.max_change_deg)

    def steps(self) -> tuple[str, ...]:
        steps = STEPS[self.job["kind"]]
        if self.job["kind"] == "procedure" and int(self.options.get("rounds", 1)) == 2:
            steps = (*steps[:-1], *SECOND_ROUND, steps[-1])
        return steps

    # -- the job -------------------------------------------------------------------------------
    async def run(self) -> None:
        """The steps in order. Before each, the step is claimed in the store, which re-reads the
        job's phases there: what is done is skipped, a correction that was started and not
        finished is never sent again, and a runner whose job another ended stops."""
        try:
            self._set("running", "")
            t0 = time.perf_counter()
            await self._with_links("setup")
            if "setup" not in self.job["phases"]:
                self.store.finish_step(self.job_id, "setup", time.perf_counter() - t0)
            for step in self.steps():
                phases = self.store.claim_step(self.job_id, step)
                if phases.get(step, {}).get("done"):
                    continue
                if step.startswith("correction") and phases.get(step, {}).get("started") \
                        and self.route.startswith("zero"):
                    raise SafetyError("the job stopped during the correction: whether ZERO took "
                                      "effect is unknown; check the controller, then start anew")
                self.job = self.store.job(self.job_id)  # the results as stored, not our copy
                start = time.perf_counter()
                await self._with_links(step)
                seconds = time.perf_counter() - start
                self.store.finish_step(self.job_id, step, seconds)
                await self.events.publish("phase", phase=step, seconds=seconds)
            self._set("done", "")
            await self.events.publish("done")
        except ConflictError as err:  # a stale runner: another ended this job; touch nothing
            await self.events.publish("stale", reason=str(err))
        except StoreFullError as err:  # nothing committed is lost: the job waits for space
            await self._store_full(err)
        except StoreLostError as err:
            if self.on_fatal is not None:
                self.on_fatal(str(err))
            await self.events.publish("failed", reason=str(err))
        except JobAborted:
            await self._aborted()
        except ControllerError as err:
            if self.aborted.is_set():  # the controller's ERR 22 for the run we aborted
                await self._aborted()
            else:
                self._set("failed", str(err))
                await self.events.publish("failed", reason=str(err))
        except (SafetyError, CorrectionRefusedError, ScrewcalError) as err:
            self._set("failed", str(err))
            await self.events.publish("failed", reason=str(err))
        except Exception as err:  # a job never stays "running" after its task ended
            self._set("failed", f"internal error: {err!r}")
            await self.events.publish("failed", reason=repr(err))
            raise
        finally:
            await self._disconnect()

    async def _store_full(self, err: StoreFullError) -> None:
        """Paused, not failed: a restart with free space resumes the job from its last
        committed pose (an unfinished job is resumed; if even this small write fails, the job
        stays as stored, unfinished, and is resumed all the same)."""
        try:
            self._set("paused", str(err))
        except StoreFullError:
            pass
        await self.events.publish("paused", reason=str(err))

    async def _aborted(self) -> None:
        self._set("aborted", "aborted by the operator")
        await self.events.publish("aborted")

    def _set(self, state: str, reason: str) -> None:
        self.job = self.store.set_state(self.job_id, state, reason)

    async def _with_links(self, step: str) -> None:
        """Run a step; a lost link pauses the job until it is back, then the step goes on."""
        while True:
            try:
                await self._step(step)
                return
            except LINK_ERRORS as err:
                if self.aborted.is_set():
                    raise JobAborted() from None
                self._set("paused", f"{type(err).__name__}: {err}")
                await self.events.publish("paused", reason=str(err))
                await self._reconnect()
                self._set("running", "")
                await self.events.publish("resumed", phase=step)

    async def _step(self, step: str) -> None:
        suffix = "_2" if step.endswith("_2") else ""  # the second round's steps
        if step == "setup":
            await self._connect()
        elif step.startswith(("perf", "cal", "home")):
            await self.measure(step, self.targets(step))
        elif step.startswith("estimation"):
            await asyncio.to_thread(self.estimate, suffix)
        elif step.startswith("correction"):
            await self.correct(suffix)
        elif step == "evaluation":
            await asyncio.to_thread(self.evaluate)
            for warning in self.job["result"].get("warnings", []):
                await self.events.publish("warning", message=warning)

    # -- links ---------------------------------------------------------------------------------
    async def _connect(self) -> None:
        if self.client is None or self.client.lost is not None:
            self.client = ControllerClient(self.robot["controller_host"],
                                           self.robot["controller_port"],
                                           Timeouts(pose_s=self.settings.pose_timeout_s))
            # a few quick tries: the controller may not yet have seen the last client leave
            await self.client.reconnect(attempts=3, first_delay_s=0.05)
        if self.arm is None:
            url = check_arm_url(self.robot["arm_url"])  # a record older than the check too
            opening = asyncio.ensure_future(asyncio.to_thread(ArmReader, url))
            try:
                self.arm = await asyncio.shield(opening)
            except asyncio.CancelledError:  # aborted while the port opened: close it when open
                opening.add_done_callback(_close_opened)
                raise

    async def _disconnect(self) -> None:
        if self.client is not None:
            await self.client.close()
            self.client = None
        if self.arm is not None:
            # pyserial's socket:// close() sleeps 0.3 s: never on the event loop.
            await asyncio.to_thread(self.arm.close)
            self.arm = None

    async def _reconnect(self) -> None:
        while True:
            if self.aborted.is_set():
                raise JobAborted()
            await self._disconnect()
            try:
                await self._connect()
                return
            except LINK_ERRORS:
                await asyncio.sleep(self.settings.reconnect_interval_s)

    # -- measuring -----------------------------------------------------------------------------
    async def measure(self, phase: str, plan: list[PlannedPose]) -> None:
        assert self.client is not None and self.arm is not None
        for p in plan:  # the service refuses targets outside the limits before sending
            if not self.model.within_limits(np.radians(p.joints_deg)):
                raise SafetyError(f"{phase} pose {p.idx} is outside the joint limits")
        list_name = "CAL" if phase.startswith("cal") else "PERF"
        last = self.store.last_measurement(self.job_id)
        previous = None if last is None else self._reading(
            last["holes_mm"], last["flange_pose"], last["joints_deg"])
        rows = self.store.measurements(self.job_id)
        earlier = EarlierReadings.empty() if not rows else EarlierReadings(
            np.array([r["holes_mm"] for r in rows], dtype=float),
            flange_kinematics(self.model, np.radians([r["joints_deg"] for r in rows]))[:, :3, 3],
            tuple(f"{r['phase']}/{r['idx']}" for r in rows))
        while True:
            measured = self.store.measured_indices(self.job_id, phase)  # once per chunk
            todo = [p for p in plan if p.idx not in measured]
            if not todo:
                return
            done = len(measured)
            chunk = todo[:MAX_LIST]
            await self.client.load(list_name, [p.joints_deg for p in chunk])

            async def gate(k: int, chunk: list[PlannedPose] = chunk) -> None:
                await self._gate(phase, chunk[k])

            async for got in self.client.run(list_name, "STEP", on_wait=gate, count=len(chunk)):
                planned = chunk[got.idx]
                reading = await self._read_pose(phase, planned.idx, got.joints_deg, previous,
                                                earlier)
                self.store.add_measurement(self.job_id, phase, planned.idx, list(got.joints_deg),
                                           list(got.tool0), reading.holes_mm.tolist(),
                                           pose_from_transform(reading.flange).tolist())
                previous = reading
                earlier = earlier.plus(reading, f"{phase}/{planned.idx}")
                done += 1
                await self.events.publish("measured", phase=phase, index=planned.idx,
                                          done=done, total=len(plan))
            self._count_discarded()

    def _reading(self, holes_mm: Any, flange_pose: Any, joints_deg: Any) -> PoseReading:
        nominal = flange_kinematics(self.model, np.radians([joints_deg]))[0]
        flange = transform_from_pose(np.asarray(flange_pose, dtype=float))
        return PoseReading(np.asarray(holes_mm, dtype=float), flange, nominal)

    async def _read_pose(self, phase: str, idx: int, joints_deg: Any,
                         previous: PoseReading | None, earlier: EarlierReadings
                         ) -> PoseReading:
        """The arm reading of the pose the robot reported arriving at (service/readings.py): a
        duplicated, stale or early triple is discarded and logged and the next one read; when
        none is accepted in time, the arm is asked to probe again (`remeasure_attempts`), then
        the job pauses and the pose is measured anew."""
        assert self.arm is not None
        tol = MotionTolerance(self.settings.motion_tolerance_mm,
                              self.settings.motion_tolerance_rel,
                              self.settings.motion_tolerance_deg)
        attempts = 0
        last_refusal = ""
        deadline = time.monotonic() + self.settings.arm_timeout_s
        while True:
            try:
                holes = await asyncio.to_thread(self.arm.read_holes,
                                                max(0.05, deadline - time.monotonic()))
            except LinkTimeoutError:
                if last_refusal and attempts >= self.settings.remeasure_attempts:
                    raise ArmLineError(  # say why, not only "no reading": it may be the check
                        f"{phase} pose {idx}: every reading of this pose was refused, the last "
                        f"one: {last_refusal}. If the robot is this far from its nominal "
                        "model, raise motion_tolerance_deg / motion_tolerance_rel") from None
                if attempts >= self.settings.remeasure_attempts or not self.discarded:
                    raise
                attempts += 1
                await asyncio.to_thread(self.arm.request)
                deadline = time.monotonic() + self.settings.arm_timeout_s
                continue
            points = np.array(holes.points_mm)
            flange = self.flange.flange_poses(points)[0]
            nominal = flange_kinematics(self.model, np.radians([joints_deg]))[0]
            reading = PoseReading(points, flange, nominal)
            refused = refusal(previous, reading, tol, earlier)
            if refused is None:
                return reading
            kind, why = refused
            last_refusal = why
            self.discarded[kind] += 1
            await self.events.publish("discarded", phase=phase, index=idx, reason=why,
                                      seqs=list(holes.seqs))

    def _count_discarded(self) -> None:
        """The result says how many arm readings were refused and why (and the arm's lines
        that were not readings at all)."""
        assert self.arm is not None
        if not self.discarded and not self.arm.problems:
            return
        job_result = dict(self.store.job(self.job_id)["result"] or {})
        job_result["arm_readings_discarded"] = {
            "duplicate": self.discarded["duplicate"], "stale": self.discarded["stale"],
            "motion": self.discarded["motion"],
            "bad_lines": len(self.arm.problems),
            "meaning": "arm triples not used as a pose's reading: repeats of the previous "
                       "pose's, re-probes of a pose the robot had left (stale), readings whose "
                       "measured motion disagreed with the commanded one (early, foreign), and "
                       "lines that broke a triple"}
        self.job = self.store.set_job(self.job_id, result=job_result)

    async def _gate(self, phase: str, planned: PlannedPose, note: str = "") -> None:
        """Before the robot moves to `planned`: the previous pose is committed; drop stale arm
        lines; in a STEP job wait for the operator's go-ahead. A `note` (a step that needs a
        person at the controller) waits for the operator in every mode."""
        if self.aborted.is_set():
            raise JobAborted()
        assert self.arm is not None
        await asyncio.to_thread(self.arm.drain)
        if self.job["mode"] != "STEP" and not note:
            return
        self.waiting_for = (phase, planned.idx)
        extra = {"note": note} if note else {}
        await self.events.publish("waiting", phase=phase, index=planned.idx,
                                  joints_deg=list(planned.joints_deg), **extra)
        try:
            while True:
                getter = asyncio.create_task(self.go_ahead.get())
                stopper = asyncio.create_task(self.aborted.wait())
                finished, _ = await asyncio.wait({getter, stopper},
                                                 return_when=asyncio.FIRST_COMPLETED)
                getter.cancel()
                stopper.cancel()
                if self.aborted.is_set():
                    raise JobAborted()
                if getter in finished and getter.result() == planned.idx:
                    return
        finally:
            self.waiting_for = None

    async def abort(self) -> None:
        self.aborted.set()
        if self.client is not None and self.client.lost is None:
            try:
                await self.client.abort()
            except ProtocolError:
                pass

    # -- estimation, correction, evaluation ---------------------------------------------------
    def measurement_set(self, phase: str) -> MeasurementSet:
        rows = self.store.measurements(self.job_id, phase)
        T = transform_from_pose(np.array([r["flange_pose"] for r in rows]))
        return MeasurementSet(np.radians([r["joints_deg"] for r in rows]), T[:, :3, 3].copy(),
                              T[:, :3, :3].copy(), tuple(str(r["idx"]) for r in rows))

    def estimate(self, suffix: str = "") -> None:
        kind = self.options.get("model", "full")
        data = self.measurement_set("cal" + suffix)
        result = identify(self.model, data, kind=kind, frames="base")
        job_result = dict(self.job["result"] or {})
        job_result["estimation" + suffix] = _estimation_summary(result)
        job_result["base"] = result.model.base.tolist()
        job_result["calibration" + suffix] = result_document(
            result, self.model.name, {"model": kind, "frames": "base", "poses": len(data),
                                      "job": self.job_id, "phase": "cal" + suffix})
        job_result["warnings"] = _warnings(job_result)
        try:
            job_result["correction" + suffix] = self._plan_correction(result, suffix)
        finally:
            self.job = self.store.set_job(self.job_id, result=job_result)

    def _plan_correction(self, result: CalibrationResult, suffix: str) -> dict:
        """What the route will do, checked before anything moves: the ZERO targets (refused
        when implausible), the compensated lists (refused when unreachable or implausible), the
        accuracy the model predicts before and after, and what stays in the robot."""
        route = self.route
        robot_params = [(p, v) for p, v in zip(result.params, result.values, strict=True)
                        if p.group == "robot"]
        not_identified = [n for n, _ in result.removed if not n.startswith(("base", "tool"))]
        if route == "none":
            return {"route": "none", "note": "a calibration job sends no correction; the "
                    "calibrated model is downloadable (screwcal job model N)",
                    "not_identified": not_identified}
        plan = self.plan("perf")
        q_nominal = np.radians([p.joints_deg for p in plan])
        robot = result.model
        out: dict[str, Any] = {"route": route, "not_identified": not_identified}
        if route.startswith("zero"):
            correction = joint_correction(result.params, result.values, result.std_errors,
                                          self.model.n_joints)
            out |= correction.to_dict()
            robot = after_zero(robot, correction.zero_command_deg)
        target = flange_kinematics(self.model, q_nominal)
        before = _flange_error_mm(result.model, q_nominal, target)
        if "compensate" in route:
            lists = ["perf_after" + suffix]
            self._compensated[lists[0]], change = self._compensate_plan(plan, robot)
            q_sent = np.radians([p.joints_deg for p in self._compensated[lists[0]]])
            after = _flange_error_mm(robot, q_sent, target)
            out |= {"compensated_lists": lists, "max_joint_change_deg": change,
                    "left_in_robot": []}
        else:
            after = _flange_error_mm(robot, q_nominal, target)
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
        return out

    async def correct(self, suffix: str = "") -> None:
        assert self.client is not None
        correction = (self.job["result"] or {}).get("correction" + suffix, {})
        if not self.route.startswith("zero"):
            await self.events.publish("corrected", route=self.route, note="nothing sent to "
                                      "the controller: the later lists are compensated")
            return
        zero = np.array(correction.get("zero_command_deg", []), dtype=float)
        if zero.size != self.model.n_joints:
            raise SafetyError("no correction to send")
        if not self.model.within_limits(np.radians(zero)):
            raise SafetyError(f"correction target {zero.round(4).tolist()} outside the limits")

        async def gate(idx: int) -> None:  # a person enters the offsets: in every mode
            await self._gate("correction" + suffix, PlannedPose(idx, tuple(zero.tolist()),
                                                                "zero"), note=ZERO_NOTE)

        await self.client.zero(zero.tolist(), on_wait=gate)
        job_result = dict(self.job["result"] or {})
        doc = dict(job_result["calibration" + suffix])
        doc["model"] = model_document(after_zero(parse_model(doc["model"]), zero))
        doc["model_note"] = ("the robot once ZERO made the identified offsets the new zero: "
                             "the model of the joints as the controller now reads them")
        job_result["calibration" + suffix] = doc
        job_result["correction" + suffix] = {**correction, "sent": True}
        self.job = self.store.set_job(self.job_id, result=job_result)
        await self.events.publish("corrected", route=self.route,
                                  zero_command_deg=zero.tolist())

    def evaluate(self) -> None:
        job_result = dict(self.job["result"] or {})
        base = job_result.get("base")
        source = self.options.get("frame_from_job")
        if base is None and source is not None:  # the frame an earlier calibration identified
            base = (self.store.job(int(source))["result"] or {})["base"]
            job_result["base"] = base
            job_result["frame_note"] = (f"accuracy measured in the robot base frame identified "
                                        f"by job {source}'s calibration")
        elif base is None:  # a performance job alone: the measuring frame from its own data
            fit = identify(self.model, self.measurement_set("perf_before"), kind="frames",
                           frames="base")
            base = fit.model.base.tolist()
            job_result["base"] = base
            job_result["frame_note"] = (
                "accuracy measured in a robot base frame fitted to this performance data "
                "itself (no calibration in this job): it hides any error such a frame absorbs, "
                "so it reads lower than after a calibration's frame")
        else:
            job_result["frame_note"] = ("accuracy measured in the robot base frame identified "
                                        "by this job's calibration, before and after alike")
        plan = {p.idx: p for p in self.plan("perf")}
        performance = {}
        for phase in PERF_PHASES:
            rows = self.store.measurements(self.job_id, phase)
            if rows:
                performance[phase] = _performance(rows, plan, np.array(base))
        job_result["performance"] = performance
        home = self._home_check(np.array(base))
        if home:
            job_result["home_check"] = home
        job_result["test_conditions"] = self._test_conditions(plan)
        job_result["warnings"] = _warnings(job_result)
        self.job = self.store.set_job(self.job_id, result=job_result)

    def _home_check(self, base: np.ndarray) -> dict:
        """Table 14: the flange at home (all joints 0) measured before and after the correction,
        in the robot base frame, against the nominal home."""
        nominal = flange_kinematics(self.model, np.zeros((1, self.model.n_joints)))[0, :3, 3]
        out: dict[str, Any] = {}
        for phase in HOME_PHASES:
            rows = self.store.measurements(self.job_id, phase)
            if rows:
                T = invert_transform(base) @ transform_from_pose(np.array(rows[-1]["flange_pose"]))
                error = T[:3, 3] - nominal
                out[phase.removeprefix("home_")] = {
                    "measured_mm": T[:3, 3].round(3).tolist(),
                    "error_mm": error.round(3).tolist(),
                    "distance_mm": round(float(np.linalg.norm(error)), 3)}
        if out:
            out["nominal_mm"] = nominal.round(3).tolist()
            out["note"] = ("the robot sent to all joints 0 (HOME), its flange measured and "
                           "compared with the nominal home (thesis Table 14); error = measured "
                           "- nominal, robot base frame. After ZERO the controller's zeros are "
                           "corrected; the compensate route corrects programmed targets, not "
                           "the joints' zeros, so its home is the robot's uncorrected one")
        return out

    def _test_conditions(self, plan: dict[int, PlannedPose]) -> dict[str, Any]:
        centre = next(p.commanded[:3] for p in plan.values()
                      if p.point == "P1" and p.role == "target")
        return {
            "robot": f"{self.robot['name']} (model {self.model.name})",
            "controller": f"{self.robot['controller_host']}:{self.robot['controller_port']}",
            "measuring arm": self.robot["arm_url"],
            "cube edge mm": float(self.options.get("cube_edge_mm", 300.0)),
            "cube centre (P1) mm": ", ".join(f"{v:.1f}" for v in centre),
            "cycles": int(self.options.get("cycles", 30)),
            "speed": "v100, fine (the RAPID server module's MoveAbsJ)",
            "date (UTC)": time.strftime("%Y-%m-%d %H:%M", time.gmtime(self.job["created"]))
            if self.job.get("created") else "",
        }


def _close_opened(opening: asyncio.Future[ArmReader]) -> None:
    if not opening.cancelled() and opening.exception() is None:
        opening.result().close()


def _warnings(job_result: dict) -> list[str]:
    """What a user must see: a poor fit, an accuracy that did not improve."""
    out = []
    for suffix in ("", "_2"):
        est = job_result.get("estimation" + suffix)
        out += [f"estimation{suffix}: {w}" for w in (est or {}).get("warnings", [])]
        if est and est["chi2_reduced"] > POOR_FIT_CHI2:
            out.append(f"poor fit in the estimation{suffix}: chi2/dof {est['chi2_reduced']:.1f} "
                       f"(> {POOR_FIT_CHI2:g}): the model misses something (compliance, a loose "
                       "flange, drift) or the noise is larger than stated")
    perf = job_result.get("performance") or {}
    overall = perf.get("perf_before", {}).get("overall", {})
    for phase in ("perf_after", "perf_after_2"):
        after = perf.get(phase, {}).get("overall", {})
        before_ap, after_ap = overall.get("ap_mm_mean"), after.get("ap_mm_mean")
        if before_ap is not None and after_ap is not None and after_ap > before_ap:
            out.append(f"accuracy got worse in {phase}: AP mean {before_ap:.3f} -> "
                       f"{after_ap:.3f} mm; do not use this correction")
        before_rp, after_rp = overall.get("rp_mm_mean"), after.get("rp_mm_mean")
        # repeatability is the robot's own: a correction should not change it; a rise beyond
        # 20 % (and 0.01 mm) says the corrected targets sit where the robot repeats worse
        if before_rp is not None and after_rp is not None and \
                after_rp > 1.2 * before_rp + 0.01:
            out.append(f"repeatability got worse in {phase}: RP mean {before_rp:.3f} -> "
                       f"{after_rp:.3f} mm (a correction should leave it unchanged): check "
                       "the cell (warm-up, payload, fixture) before trusting the after-figures")
    return out


def _flange_error_mm(robot: SerialModel, q_sent: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Per pose: how far `robot`'s flange (its base frame) lands from the target (N, 4, 4) when
    sent the joints q_sent (N, n) rad."""
    return np.linalg.norm(flange_kinematics(robot, q_sent)[:, :3, 3] - target[:, :3, 3], axis=1)


def _estimation_summary(result: CalibrationResult) -> dict:
    """The robot's identified parameters; the measuring frame as the pose it came out as (its
    parameters are increments from the starting alignment, meaningless alone)."""
    x, y, z, rx, ry, rz = (float(v) for v in pose_from_transform(result.model.base))
    return {
        "parameters": [{"name": p.name, "unit": p.unit, "value": float(v),
                        "std_error": float(s)}
                       for p, v, s in zip(result.params, result.values, result.std_errors,
                                          strict=True) if p.group == "robot"],
        "measuring_frame": {"x": x, "y": y, "z": z, "rx": rx, "ry": ry, "rz": rz,
                            "meaning": "robot base in the measuring system's frame, mm/deg"},
        "removed": [{"name": n, "reason": why} for n, why in result.removed],
        "rank": result.rank, "condition_number": result.condition_number,
        "chi2_reduced": result.chi2_reduced, "converged": result.converged,
        "noise": result.noise.to_dict() if result.noise is not None else None,
        "warnings": result.warnings,
        "residual_before_mm": float(result.residuals_before.mean()),
        "residual_after_mm": float(result.residuals_after.mean()),
    }


def _performance(rows: list[dict], plan: dict[int, PlannedPose], base: np.ndarray) -> dict:
    """ISO 9283 per point (the evaluate command's computation) and straightness, attained poses
    in the robot base frame."""
    attained = pose_from_transform(invert_transform(base) @ transform_from_pose(
        np.array([r["flange_pose"] for r in rows])))
    by_point: dict[str, list[int]] = {}
    line = []
    for k, r in enumerate(rows):
        p = plan[r["idx"]]
        if p.role == "target":
            by_point.setdefault(p.point, []).append(k)
        elif p.role == "line":
            line.append(r["flange_pose"][:3])
    data = PerformanceData("measurements", tuple(
        PointData(label, np.array(plan[rows[ks[0]]["idx"]].commanded), attained[ks])
        for label, ks in sorted(by_point.items()) if len(ks) >= 2), full_pose=True)
    metrics = point_metrics(data)
    out: dict[str, Any] = {"points": {k: m.to_dict() for k, m in metrics.items()}}
    if metrics:
        out["overall"] = summarise(metrics)
    if len(line) >= 3:
        s = straightness(np.array(line))
        out["straightness"] = {"peak_to_valley_mm": s.peak_to_valley_mm,
                               "along_mm": s.along_mm.tolist(),
                               "deviation_mm": s.deviation_u_mm.tolist()}
    return out
