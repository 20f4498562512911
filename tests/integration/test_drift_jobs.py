"""Drift over a long job (service/drift.py) and lost motion (calibration/backlash.py) on the
emulated robot: reference poses re-measured during the job follow the robot's thermal drift
(simulators/realism.py), a drift since the calibration beyond its promise is a warning, and a
calibration list with two-direction pairs identifies the backlash imposed."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from screwcal.kinematics.forward import forward_kinematics
from service.document import JobOptions, ResultDocument
from service.drift import (
    DRIFT_PHASE,
    DriftSchedule,
    DriftState,
    drift_schedule,
    drift_section,
    drift_warnings,
)
from service.plans import PlannedPose, plan_for
from simulators.realism import HARSH, IDEAL, realism_from_document
from tests.integration.conftest import ARM_POSITION, FAST, add_robot, finished, start_rig, stop_rig
from tests.integration.test_jobs import wait_state

# harsh's drift (80 ppm) on a robot that warms up fast (time constant 300 s of its own clock):
# a job of a few hundred poses (about 1.5 s each) sees most of the warm-up
WARMING = realism_from_document({"preset": "harsh", "warmup_s": 300.0}, "test")


@contextlib.asynccontextmanager
async def cell(realism):
    """The seed-1 robot with `realism`; `rig.clock`: the robot's own running time at each
    arrival."""
    rig = await start_rig(realism=realism, seed=1)
    rig.clock = []
    rig.world.observers.append(lambda w: rig.clock.append(w.running_s))
    try:
        yield rig
    finally:
        await stop_rig(rig)


async def _procedure(service, rig, **options) -> tuple[dict, dict]:
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", json={"robot_id": robot, "kind": "procedure", "options": {
        "calibration_poses": 60, "cycles": 8, "arm_position_mm": ARM_POSITION,
        "drift_poses": 3, "drift_period_poses": 30, **options}})
    assert r.status_code == 202, r.text
    job = await finished(service, r.json()["id"])
    assert job["state"] == "done", job["reason"]
    return job, (await service.get(f"/jobs/{job['id']}/result")).json()


def _expected_drift(rig, drift: dict, schedule_targets: dict) -> np.ndarray:
    """(K, R) the true robot's change at each reference pose from the first check, by the
    realism's own definition: every length grown by drift_scale(running_s)."""
    world = rig.world
    out = []
    for k, before in enumerate(drift["poses_before"]):
        row = []
        for j, label in enumerate(drift["reference"]):
            arrival = before + k * 2 * len(drift["reference"]) + 2 * j + 1  # approach, target
            world.running_s = rig.clock[arrival]
            model = world.true_model().with_frames(tool=np.eye(4))
            row.append(forward_kinematics(model, np.radians([schedule_targets[label]]))[0, :3, 3])
        out.append(row)
    p = np.array(out)
    return np.linalg.norm(p - p[0], axis=2)


async def test_drift_curve_follows_the_warm_up_and_warns_since_the_calibration(service):
    async with cell(WARMING) as rig:
        job, result = await _procedure(service, rig)
        drift = result["drift"]
        assert drift["reference"] == ["P1", "P2", "P4"]
        measured = np.array([drift["deviation_mm"][label] for label in drift["reference"]]).T
        k = len(drift["t_s"])
        assert k >= 10 and drift["poses_before"][0] == 0
        options = JobOptions.model_validate(job["options"])
        schedule = drift_schedule(options, plan_for(rig.world.nominal, "perf", options))
        targets = {p.point: p.joints_deg for p in schedule.references if p.role == "reference"}
        expected = _expected_drift(rig, drift, targets)
        # rising with the warm-up: the last checks near the full growth, the curve's shape that
        # of 1 - exp(-t / 300 s) on the robot's clock
        assert expected[-1].mean() > 0.05
        assert np.abs(measured - expected).mean() < 0.03, (measured, expected)
        assert measured[-3:].mean() > 2 * measured[1:4].mean()
        assert np.all(np.diff(expected.mean(axis=1)) >= 0)
        since = drift["since_calibration"]
        # harsh's 80 ppm: within one procedure the drift after its calibration list stays
        # below the calibration's promise (the list before it warmed the robot): no warning
        assert since is not None and not since["exceeded"], since
        print(f"drift checks {k}, last {measured[-1].round(3)}, expected "
              f"{expected[-1].round(3)}; since calibration {since}")


@pytest.mark.slow
async def test_harsh_drifts_too_little_after_a_procedures_calibration_to_warn(service):
    """harsh's thermal drift (80 ppm, 1800 s): within one procedure the list before the
    calibration warms the robot first, so the true change of the reference poses after the
    calibration list (about 0.01 mm) stays below what a check can see (its own noise): no
    warning, rightly, however long the lists (at most a quarter of the full growth)."""
    async with cell(HARSH) as rig:
        job, result = await _procedure(service, rig, cycles=15, calibration_poses=40)
        drift = result["drift"]
        options = JobOptions.model_validate(job["options"])
        schedule = drift_schedule(options, plan_for(rig.world.nominal, "perf", options))
        targets = {p.point: p.joints_deg for p in schedule.references if p.role == "reference"}
        true = _expected_drift(rig, drift, targets)
        at = [k for k, lst in enumerate(drift["list_of_check"]) if lst == "cal"][-1]
        since = drift["since_calibration"]
        true_since = float(np.abs(true[-1] - true[at]).mean())
        print(f"harsh: robot clock {rig.clock[-1]:.0f} s, true drift since the calibration "
              f"{true_since:.4f} mm, measured {since['drift_mm']} mm, promised "
              f"{since['promised_mm']} + noise {since['noise_mm']} mm")
        assert true_since < 0.02 < since["noise_mm"]
        assert not since["exceeded"]
        assert not any("drift since the calibration" in w for w in result.get("warnings", []))


async def test_an_ideal_robot_does_not_warn(service):
    async with cell(IDEAL) as rig:
        _, result = await _procedure(service, rig)
        since = result["drift"]["since_calibration"]
        assert since is not None and not since["exceeded"], since
        assert not any("drift since the calibration" in w for w in result.get("warnings", []))
        print(f"ideal: since calibration {since}")


def _rows(positions, lists, start_id=1):
    """Committed rows of checks (approach, reference per pose) at `positions` (K, R, 3), each
    check after one pose of the list named in `lists`."""
    drift, others, rid = [], [], start_id
    for k, (check, phase) in enumerate(zip(positions, lists, strict=True)):
        others.append({"id": rid, "idx": k, "phase": phase, "created": 10.0 * k,
                       "flange_pose": [0.0] * 6})
        rid += 1
        for j, p in enumerate(check):
            for role in range(2):
                drift.append({"id": rid, "idx": k * 2 * len(check) + 2 * j + role,
                              "phase": DRIFT_PHASE, "created": 10.0 * k + 1,
                              "flange_pose": [*p, 0.0, 0.0, 0.0]})
                rid += 1
    return drift, others


@pytest.mark.parametrize("moved_mm, warned", [(0.2, True), (0.03, False)])
def test_drift_since_the_calibration_warns_beyond_the_promise(moved_mm, warned):
    """Three reference poses, 0.01 mm of noise per coordinate, a calibration that promised
    0.02 mm per coordinate (0.035 mm as a distance): a move of 0.2 mm after the calibration
    warns, one of 0.03 mm does not."""
    rng = np.random.default_rng(1)
    refs = tuple(PlannedPose(0, (0.0,) * 6, role, label) for label in ("P1", "P2", "P4")
                 for role in ("approach", "reference"))
    schedule = DriftSchedule(refs, period_poses=10)
    k = 12
    lists = ["perf_before"] * 4 + ["cal"] * 4 + ["perf_after"] * 4
    grown = np.r_[np.zeros(8), np.linspace(moved_mm / 4, moved_mm, 4)]
    positions = 1000.0 * np.ones((k, 3, 3)) + grown[:, None, None] / np.sqrt(3) + \
        rng.normal(0.0, 0.01, (k, 3, 3))
    drift_rows, others = _rows(positions, lists)
    loads = dict.fromkeys(lists, "none")
    section = drift_section(schedule, drift_rows, others, loads, ["cal"], 0.02)
    assert section.reference == ["P1", "P2", "P4"] and len(section.t_s) == k
    assert section.list_of_check[7] == "cal" and section.poses_before[:3] == [1, 2, 3]
    since = section.since_calibration
    assert since["promised_mm"] == pytest.approx(0.02 * np.sqrt(3), abs=1e-4)
    assert since["exceeded"] is warned, since
    said = drift_warnings(ResultDocument(drift=section))
    assert len(said) == warned and (not said or "residual noise level" in said[0])


def test_checks_under_another_payload_start_their_own_series():
    refs = (PlannedPose(0, (0.0,) * 6, "approach", "P1"), PlannedPose(1, (0.0,) * 6,
                                                                      "reference", "P1"))
    positions = np.array([[[0.0, 0, 0]], [[0.0, 0, 0.5]], [[0.0, 0, 0.5]]])  # 10 kg bends it
    drift_rows, others = _rows(positions, ["perf_before", "cal", "cal"])
    section = drift_section(DriftSchedule(refs, 10), drift_rows, others,
                            {"perf_before": "none", "cal": "10 kg"})
    assert section.deviation_mm["P1"] == [0.0, 0.0, 0.0]


def test_a_check_counts_the_poses_before_it_and_belongs_to_the_list_it_follows():
    """Each check: how many other poses were committed before it and the list of the one
    just before (the job's first check, made before any pose: the list just after)."""
    refs = (PlannedPose(0, (0.0,) * 6, "approach", "P1"), PlannedPose(1, (0.0,) * 6,
                                                                      "reference", "P1"))

    def pose(id_, phase, idx=0):
        return {"id": id_, "idx": idx, "phase": phase, "created": float(id_),
                "flange_pose": [0.0] * 6}
    drift_rows = [pose(i, DRIFT_PHASE, k) for k, i in enumerate((1, 2, 6, 7, 11, 12))]
    others = [pose(9, "cal"), pose(3, "perf_before"), pose(10, "cal"), pose(4, "perf_before"),
              pose(5, "perf_before")]
    section = drift_section(DriftSchedule(refs, 10), drift_rows, others, {})
    assert section.poses_before == [0, 3, 5]
    assert section.list_of_check == ["perf_before", "perf_before", "cal"]


def test_schedule_from_the_store_alone():
    refs = tuple(PlannedPose(i, (0.0,) * 6, role, "P1") for i, role in
                 enumerate(("approach", "reference")))
    s = DriftSchedule(refs, period_poses=10)
    assert s.due(DriftState(0, None, 0), 0.0, False) == 0  # the job's first poses
    assert s.due(DriftState(1, 5.0, 0), 6.0, False) == 0  # a check begun is finished first
    assert s.due(DriftState(2, 5.0, 4), 6.0, False) is None and s.room(DriftState(2, 5.0, 4)) == 6
    assert s.due(DriftState(2, 5.0, 10), 6.0, False) == 1
    assert s.due(DriftState(2, 5.0, 1), 6.0, True) == 1  # after each list
    assert s.due(DriftState(4, 5.0, 0), 6.0, True) is None  # nothing measured since
    timed = DriftSchedule(refs, period_poses=10, period_s=60.0)
    assert timed.due(DriftState(2, 5.0, 3), 64.0, False) is None
    assert timed.due(DriftState(2, 5.0, 3), 65.0, False) == 1
    assert [p.idx for p in s.check(3)] == [6, 7]
    assert DRIFT_PHASE == "drift"


@pytest.mark.parametrize("options, field", [({"drift_poses": 6}, "drift_poses"),
                                            ({"drift_period_poses": 2}, "drift_period_poses"),
                                            ({"drift_period_s": 0}, "drift_period_s"),
                                            ({"backlash_poses": -1}, "backlash_poses")])
async def test_drift_and_backlash_options_refused_by_name(service, rig, options, field):
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", json={"robot_id": robot, "kind": "calibration",
                                          "options": options})
    assert r.status_code == 422 and field in r.text, r.text


async def test_calibration_with_two_direction_pairs_identifies_the_backlash(service):
    """0.01 deg of lost motion on J2 alone; 10 calibration poses approached from both sides:
    the job names J2's backlash near 0.010 deg with its uncertainty, the others near zero, and
    says what the compensation cannot do."""
    only_j2 = realism_from_document({"preset": "ideal",
                                     "backlash_deg": [0, 0.01, 0, 0, 0, 0]}, "test")
    async with cell(only_j2) as rig:
        robot = await add_robot(service, rig)
        r = await service.post("/jobs", json={"robot_id": robot, "kind": "calibration",
                                              "options": {"calibration_poses": 40,
                                                          "backlash_poses": 10}})
        assert r.status_code == 202, r.text
        job = await finished(service, r.json()["id"])
        assert job["state"] == "done", job["reason"]
        result = (await service.get(f"/jobs/{job['id']}/result")).json()
    joints = {j["joint"]: j for j in result["backlash"]["joints"]}
    j2 = joints["J2"]
    assert j2["backlash_deg"] == pytest.approx(0.010, abs=max(3 * j2["std_deg"], 1e-3))
    assert j2["std_deg"] < 0.002
    for name in ("J1", "J3"):
        assert abs(joints[name]["backlash_deg"]) < 3 * joints[name]["std_deg"] + 1e-3
    assert "approached from one fixed direction" in result["backlash"]["compensation"]
    print(f"backlash J2 {j2['backlash_deg']:.4f} +- {j2['std_deg']:.4f} deg; "
          + ", ".join(f"{k} {v['backlash_deg']:.4f} +- {v['std_deg']:.4f}"
                      for k, v in joints.items()))


async def test_report_and_table_show_drift_and_backlash(service):
    from service.result_text import result_table
    from service.schemas import JobResult

    async with cell(WARMING) as rig:
        job, result = await _procedure(service, rig, calibration_poses=40, cycles=3,
                                       backlash_poses=4)
        report = (await service.get(f"/jobs/{job['id']}/report")).text
        full = (await service.get(f"/jobs/{job['id']}")).json()
    assert "Drift over the job" in report and "drift of the reference poses" in report
    # the chart's axis and the table's caption name the same quantity (the norm)
    from service.report.drift import QUANTITY

    assert report.count(QUANTITY.replace("|", "|").replace("'", "&#x27;")) >= 2, report
    assert "Lost motion (backlash) per joint" in report
    table = result_table(JobResult.model_validate({**full, **result}))
    assert "lost motion (backlash): J1" in table and "drift of the reference poses" in table



async def test_a_zero_correction_starts_a_new_drift_series(service, rig):
    """ZERO moves the joints' zeros (Table 11's offsets, degrees): the same commanded reference
    poses land millimetres away after it; that is no drift, so the checks after the ZERO start
    their own series and the drift since the calibration is measured from there."""
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", json={"robot_id": robot, "kind": "procedure", "options": {
        **FAST, "correction": "zero", "drift_poses": 2, "drift_period_poses": 20}})
    job = await wait_state(service, r.json()["id"], operator=True)
    assert job["state"] == "done", job["reason"]
    drift = (await service.get(f"/jobs/{job['id']}/result")).json()["drift"]
    after = [k for k, lst in enumerate(drift["list_of_check"]) if lst == "perf_after"]
    assert after and drift["list_of_check"][after[0] - 1] == "home_after"
    for label in drift["reference"]:
        assert max(drift["deviation_mm"][label]) < 0.1, drift  # no jump of the ZERO's size
    since = drift["since_calibration"]
    assert since is not None and not since["exceeded"], since
