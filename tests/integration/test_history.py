"""A robot's history through the REST API (issue 28, points 4-5): its jobs with their
provenance, its model versions, its accuracy trend, and the drift alarm when a verification
measures the robot worse than its newest model left it (a "collision" moves a joint's zero in
the emulated robot)."""

import asyncio
import time
from dataclasses import replace

import numpy as np

from service.history import RobotHistory, history_text
from tests.integration.conftest import AUTH, FAST, add_robot
from tests.integration.test_jobs import wait_state


async def test_history_keeps_provenance_and_raises_the_drift_alarm(service, rig):
    host, port = rig.address
    r = await service.post("/robots", headers=AUTH, json={
        "name": "line 3 cell 2", "controller_host": host, "controller_port": port,
        "arm_url": rig.arm.url, "serial": "6400-501234", "controller_software": "RW 6.15",
        "tool": "gripper A", "payload_kg": 4.5})
    assert r.status_code == 201, r.text
    robot = r.json()
    assert (robot["serial"], robot["payload_kg"]) == ("6400-501234", 4.5)

    async def run(kind: str, **options) -> int:
        r = await service.post("/jobs", json={"robot_id": robot["id"], "kind": kind,
                                              "options": {**FAST, **options}})
        assert r.status_code == 202, r.text
        job = await wait_state(service, r.json()["id"], operator=True)  # a ZERO waits
        assert job["state"] == "done", job["reason"]
        return job["id"]

    async def history() -> RobotHistory:
        r = await service.get(f"/robots/{robot['id']}/history")
        assert r.status_code == 200, r.text
        return RobotHistory.model_validate(r.json())

    calibrated = await run("procedure", model="thesis", correction="zero")
    verified = await run("verify")  # the newest model's frame; ZERO route: targets as planned
    h = await history()
    assert h.alarm is None
    first, check = h.entries
    assert (first.job, first.model_version, first.route) == (calibrated, 1, "zero")
    # the go-ahead with the shared token, no operator named: a shared token names nobody
    assert [(c["phase"], c["operator"]) for c in first.confirmed] == [("correction",
                                                                      "not named")]
    assert first.software.startswith("screwcal ") and first.service
    assert first.robot_identity == {"serial": "6400-501234", "controller_software": "RW 6.15",
                                    "tool": "gripper A", "payload_kg": 4.5}
    assert first.poses["cal"] == FAST["calibration_poses"] and first.poses["perf_after"] > 0
    assert first.ap_before_mm > 5 * first.ap_mm  # the correction's effect, as measured
    assert check.model_version is None and abs(check.ap_mm - first.ap_mm) < 0.3
    assert [t[0] for t in h.trend] == [calibrated, verified]

    r = await service.put(f"/robots/{robot['id']}/identity", json={"tool": "gripper B"})
    assert r.status_code == 200 and r.json()["tool"] == "gripper B"
    world = rig.emu.world  # a collision shifts J2: a new true robot, as a ZERO makes one
    world.truth = replace(world.truth, joint_zero=world.truth.joint_zero
                          + np.radians([0.0, 0.3, 0.0, 0.0, 0.0, 0.0]))
    drifted = await run("verify")
    h = await history()
    assert h.entries[0].robot_identity["tool"] == "gripper A"  # as it was when made
    assert h.entries[-1].robot_identity["tool"] == "gripper B"
    assert h.alarm is not None and h.alarm.latest_job == drifted
    assert h.alarm.model_job == calibrated and h.alarm.latest_ap_mm > h.alarm.baseline_ap_mm + 0.5
    warnings = (await service.get(f"/jobs/{drifted}/result")).json()["warnings"]
    assert any("drifted since model 1" in w for w in warnings)  # in the job's result and report
    text = history_text(h)
    assert "DRIFT ALARM" in text and f"job {drifted}" in text and "gripper B" in text

    missing = await service.get("/robots/999/history")
    assert missing.status_code == 404


async def test_verify_sends_the_targets_compensated_by_the_newest_model(service, rig):
    """A compensate-route model changes nothing in the controller: a verification measures the
    robot as production runs it, with the targets compensated by that model (AP as the
    procedure's list after, not the uncorrected robot's)."""
    robot = await add_robot(service, rig)
    refused = await service.post("/jobs", json={"robot_id": robot, "kind": "verify"})
    assert refused.status_code == 409 and "no calibrated model" in refused.json()["detail"]
    proc = (await service.post("/jobs", json={"robot_id": robot, "kind": "procedure",
                                              "options": FAST})).json()["id"]
    assert (await wait_state(service, proc))["state"] == "done"
    r = await service.post("/jobs", json={"robot_id": robot, "kind": "verify",
                                          "options": {"arm_position_mm": FAST["arm_position_mm"],
                                                      "cube_edge_mm": FAST["cube_edge_mm"]}})
    assert r.status_code == 202, r.text
    job = await wait_state(service, r.json()["id"])
    assert job["state"] == "done", job["reason"]
    assert job["options"]["cycles"] == 10 and job["options"]["frame_from_job"] == proc
    assert set(job["phases"]) == {"setup", "perf_verify", "evaluation"}  # no estimation
    perf = {p: (await service.get(f"/jobs/{j}/result")).json()["performance"][p]["overall"]
            for j, p in ((proc, "perf_after"), (job["id"], "perf_verify"))}
    assert perf["perf_verify"]["ap_mm_mean"] < 0.1  # compensated (uncorrected: > 40 mm)
    assert abs(perf["perf_verify"]["ap_mm_mean"] - perf["perf_after"]["ap_mm_mean"]) < 0.05


async def test_who_confirmed_a_zero_is_kept_in_the_history(service, rig):
    """A ZERO waits for a person in every mode; their go-ahead names them, and the robot's
    history says who applied the correction, and when."""
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", json={
        "robot_id": robot, "kind": "procedure",
        "options": {**FAST, "correction": "zero+compensate"}})).json()["id"]
    async with asyncio.timeout(90):
        while (waiting := (await service.get(f"/jobs/{job_id}")).json()["waiting_for"]) is None \
                or waiting["phase"] != "correction":
            await asyncio.sleep(0.01)
    before = time.time()
    r = await service.post(f"/jobs/{job_id}/go", json={"index": 0, "operator": "alice"})
    assert r.status_code == 204
    assert (await wait_state(service, job_id))["state"] == "done"
    h = RobotHistory.model_validate((await service.get(f"/robots/{robot}/history")).json())
    (entry,) = h.entries
    assert [(c["phase"], c["idx"], c["operator"]) for c in entry.confirmed] == \
        [("correction", 0, "alice")]
    assert before <= entry.confirmed[0]["at"] <= time.time() and entry.go_aheads == 1
    assert "correction confirmed by alice" in history_text(h)
