"""Each job kind through the REST API, against the emulators, in AUTO and STEP."""

import asyncio
import threading

import numpy as np
import pytest

import service.api.jobs as api_jobs
import service.runner as runner_module
from screwcal.kinematics.modelfile import parse_model
from service.plans import plan_for
from tests.integration.conftest import AUTH, FAST, add_robot

THESIS_OFFSETS = {"J2ry": 1.1, "J3rz": 3.1, "J4rx": -2.0, "J5ry": 3.7, "J6rx": -4.6}


async def wait_state(http, job_id, states=("done", "failed", "aborted"), timeout_s=60,
                     operator: bool = False):
    """The job once in one of `states`; `operator`: a person gives every go-ahead asked for
    (ZERO's, on a real IRC5, in every mode)."""
    async with asyncio.timeout(timeout_s):
        while True:
            job = (await http.get(f"/jobs/{job_id}")).json()
            if job["state"] in states:
                return job
            if operator and job.get("waiting_for"):
                await http.post(f"/jobs/{job_id}/go", headers=AUTH,
                                json={"index": job["waiting_for"]["index"]})
            await asyncio.sleep(0.02)


async def test_procedure_in_auto_compensates_the_robot(service, rig):
    """The default route: the full model, the performance list after sent as compensated
    joint targets; the robot itself reaches the nominal targets."""
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={"robot_id": robot, "kind": "procedure",
                                                       "options": FAST})
    assert r.status_code == 202
    job = await wait_state(service, r.json()["id"])
    assert job["state"] == "done", job["reason"]
    result = (await service.get(f"/jobs/{job['id']}/result")).json()
    assert result["correction"]["route"] == "compensate"
    assert result["correction"]["compensated_lists"] == ["perf_after"]
    assert result["correction"]["left_in_robot"] == []
    assert rig.emu.world.truth.joint_zero[1] != 0  # nothing was changed in the controller
    before = result["performance"]["perf_before"]["overall"]["ap_mm_mean"]
    after = result["performance"]["perf_after"]["overall"]["ap_mm_mean"]
    assert before > 40 and after < 0.1
    noise = result["estimation"]["noise"]
    assert noise["joint"]["estimated"] and noise["joint"]["value"] < 0.01  # none in the emulator
    assert noise["position"]["value"] == pytest.approx(0.013, rel=0.5)
    assert result["estimation"]["chi2_reduced"] == pytest.approx(1.0, abs=0.2)
    assert set(job["phases"]) >= {"setup", "perf_before", "cal", "estimation", "correction",
                                  "perf_after", "evaluation"}
    measured = (await service.get(f"/jobs/{job['id']}/measurements",
                                  params={"phase": "cal"})).json()
    assert [m["idx"] for m in measured] == list(range(30))  # each once
    sent = (await service.get(f"/jobs/{job['id']}/measurements",
                              params={"phase": "perf_after"})).json()
    planned = (await service.get(f"/jobs/{job['id']}/measurements",
                                 params={"phase": "perf_before"})).json()
    moved = np.abs(np.array(sent[0]["joints_deg"]) - planned[0]["joints_deg"]).max()
    assert 0.5 < moved < 5.0  # compensated targets, within the plausible bound
    model = await service.get(f"/jobs/{job['id']}/model")
    assert model.status_code == 200 and model.json()["format"] == "screwcal-calibration"
    calibrated = parse_model(model.json())  # a file predict, compensate and the filter read
    assert calibrated.name == "irb1600"
    page = await service.get(f"/jobs/{job['id']}/report")
    assert page.status_code == 200 and "ISO 9283" in page.text and "<svg class='chart'" in page.text
    assert "Summary" in page.text and "test condition (ISO 9283)" in page.text
    assert "Route: compensate" in page.text


async def test_procedure_zero_route_recovers_table11_and_leaves_the_links(service, rig):
    """The thesis's route with its model: ZERO takes the joint offsets out; the link
    offsets stay in the robot and the report says so."""
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "procedure",
        "options": {**FAST, "model": "thesis", "correction": "zero"}})
    job = await wait_state(service, r.json()["id"], operator=True)
    assert job["state"] == "done", job["reason"]
    result = (await service.get(f"/jobs/{job['id']}/result")).json()
    values = {p["name"]: p["value"] for p in result["estimation"]["parameters"]}
    for name, imposed in THESIS_OFFSETS.items():  # the thesis model recovers Table 11
        assert values[name] == pytest.approx(imposed, abs=0.1), name
    assert "J1rz" in {p["name"] for p in result["estimation"]["removed"]}
    corr = result["correction"]
    assert corr["route"] == "zero" and corr["sent"]
    assert {p["name"] for p in corr["left_in_robot"]} >= {"J2pz", "J4px"}
    np.testing.assert_allclose(np.degrees(rig.emu.world.truth.joint_zero[1:]),
                               [0, 0, 0, 0, 0], atol=0.1)  # ZERO applied
    before = result["performance"]["perf_before"]["overall"]["ap_mm_mean"]
    after = result["performance"]["perf_after"]["overall"]["ap_mm_mean"]
    assert before > 5 * after and 0.2 < after < 2.0  # the links' error stays


@pytest.mark.parametrize("mode", ["AUTO", "STEP"])
async def test_zero_wait_needs_the_operator_in_every_mode(service, rig, mode):
    """A real IRC5 stops after ZERO while a person enters the offsets: even an AUTO job waits
    for the operator's go-ahead there, and the robot is not corrected until it is given."""
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "procedure", "mode": mode,
        "options": {**FAST, "correction": "zero+compensate"}})
    job_id = r.json()["id"]
    async with asyncio.timeout(60):
        while True:
            job = (await service.get(f"/jobs/{job_id}")).json()
            waiting = job["waiting_for"]
            if waiting and waiting["phase"] == "correction":
                break
            if waiting:  # STEP: the operator lets every measuring pose go
                await service.post(f"/jobs/{job_id}/go", headers=AUTH,
                                   json={"index": waiting["index"]})
            await asyncio.sleep(0.01)
    zero_before = rig.emu.world.truth.joint_zero.copy()
    await asyncio.sleep(0.3)
    assert (await service.get(f"/jobs/{job_id}")).json()["state"] == "running"
    np.testing.assert_array_equal(rig.emu.world.truth.joint_zero, zero_before)
    assert (await service.post(f"/jobs/{job_id}/go", headers=AUTH,
                               json={"index": 0})).status_code == 204
    async with asyncio.timeout(60):
        while True:
            job = (await service.get(f"/jobs/{job_id}")).json()
            if job["state"] in ("done", "failed", "aborted"):
                break
            if job["waiting_for"]:
                await service.post(f"/jobs/{job_id}/go", headers=AUTH,
                                   json={"index": job["waiting_for"]["index"]})
            await asyncio.sleep(0.01)
    assert job["state"] == "done", job["reason"]
    assert not np.array_equal(rig.emu.world.truth.joint_zero, zero_before)
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    assert result["performance"]["perf_after"]["overall"]["ap_mm_mean"] < 0.1


async def test_calibration_in_step_waits_for_the_operator(service, rig):
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "mode": "STEP",
        "options": {**FAST, "calibration_poses": 12}})
    job_id = r.json()["id"]
    for k in range(12):
        async with asyncio.timeout(10):
            while (job := (await service.get(f"/jobs/{job_id}")).json())["waiting_for"] is None:
                await asyncio.sleep(0.01)
        assert job["waiting_for"] == {"phase": "cal", "index": k}  # never a stale one
        assert rig.emu.world.arrivals == k  # the robot has not moved there yet
        wrong = await service.post(f"/jobs/{job_id}/go", headers=AUTH, json={"index": k + 1})
        assert wrong.status_code == 409
        assert (await service.post(f"/jobs/{job_id}/go", headers=AUTH,
                                   json={"index": k})).status_code == 204
        again = await service.post(f"/jobs/{job_id}/go", headers=AUTH, json={"index": k})
        assert again.status_code == 409  # one go-ahead, one move
    job = await wait_state(service, job_id)
    assert job["state"] == "done", job["reason"]  # a calibration job sends no correction
    assert len((await service.get(f"/jobs/{job_id}/measurements")).json()) == 12
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    assert result["correction"]["route"] == "none"


async def test_performance_job_alone(service, rig):
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={"robot_id": robot,
                                                       "kind": "performance", "options": FAST})
    job = await wait_state(service, r.json()["id"])
    assert job["state"] == "done", job["reason"]
    perf = (await service.get(f"/jobs/{job['id']}/result")).json()["performance"]
    assert set(perf["perf_before"]["points"]) == {"P1", "P2", "P3", "P4", "P5"}
    assert perf["perf_before"]["straightness"]["peak_to_valley_mm"] < 1.0


async def test_abort_stops_a_step_job(service, rig):
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "mode": "STEP", "options": FAST})).json()["id"]
    async with asyncio.timeout(10):
        while (await service.get(f"/jobs/{job_id}")).json()["waiting_for"] is None:
            await asyncio.sleep(0.01)
    assert (await service.post(f"/jobs/{job_id}/abort", headers=AUTH)).status_code == 204
    job = await wait_state(service, job_id)
    assert job["state"] == "aborted" and rig.emu.world.arrivals == 0


async def test_auth_and_bad_requests(service, rig):
    body = {"name": "x", "arm_url": "loop://"}
    no_token = {"Authorization": ""}  # the fixture's client sends the token by default
    assert (await service.post("/robots", json=body, headers=no_token)).status_code == 401
    assert (await service.get("/jobs", headers=no_token)).status_code == 401  # reads too
    assert (await service.post("/robots", json=body,
                               headers={"Authorization": "Bearer nope"})).status_code == 403
    r = await service.post("/robots", headers=AUTH, json={**body, "controller_port": 0})
    assert r.status_code == 422 and "controller_port" in r.text
    r = await service.post("/jobs", headers=AUTH, json={"robot_id": 99, "kind": "procedure"})
    assert r.status_code == 404
    r = await service.post("/jobs", headers=AUTH, json={"robot_id": 1, "kind": "dance"})
    assert r.status_code == 422 and "kind" in r.text
    assert (await service.get("/jobs/12345")).status_code == 404
    spec = (await service.get("/openapi.json")).json()
    assert {"/robots", "/jobs", "/jobs/{job_id}/go", "/jobs/{job_id}/events",
            "/jobs/{job_id}/report", "/jobs/{job_id}/measurements",
            "/jobs/{job_id}/result"} <= set(spec["paths"])
    schemas = spec["components"]["schemas"]
    assert {"estimation", "correction", "performance"} <= set(schemas["JobResult"]["properties"])
    assert "flange_pose" in schemas["MeasurementPublic"]["properties"]
    assert "text/event-stream" in spec["paths"]["/jobs/{job_id}/events"]["get"]["responses"][
        "200"]["content"]


async def operate(http, job_id, timeout_s=60):
    """An operator who says go to every pose the job asks about, until the job ends."""
    asked = 0
    async with asyncio.timeout(timeout_s):
        while (job := (await http.get(f"/jobs/{job_id}")).json())["state"] not in (
                "done", "failed", "aborted"):
            if job["waiting_for"] is not None:
                r = await http.post(f"/jobs/{job_id}/go", headers=AUTH,
                                    json={"index": job["waiting_for"]["index"]})
                asked += r.status_code == 204
            await asyncio.sleep(0.002)
    return job, asked


@pytest.mark.parametrize("kind", ["performance", "calibration", "procedure"])
@pytest.mark.parametrize("mode", ["AUTO", "STEP"])
async def test_every_kind_in_every_mode(service, rig, kind, mode):
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": kind, "mode": mode, "options": FAST})).json()["id"]
    job, asked = await operate(service, job_id)
    assert job["state"] == "done", job["reason"]
    # the procedure's default route compensates: no ZERO move; HOME before and after
    moves = {"performance": 31, "calibration": 30, "procedure": 1 + 31 + 30 + 1 + 31}[kind]
    assert asked == (moves if mode == "STEP" else 0)  # STEP: one go-ahead per move
    assert rig.emu.world.arrivals == moves
    if kind == "procedure":  # Table 14's check, in the result
        home = (await service.get(f"/jobs/{job_id}/result")).json()["home_check"]
        assert set(home) == {"before", "after", "nominal_mm", "note"}
        assert home["nominal_mm"] == pytest.approx([815.0, 0.0, 961.5], abs=1e-3)


async def test_a_second_round_refines_the_zero_correction(service, rig):
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "procedure", "options": {
            **FAST, "rounds": 2, "model": "thesis", "correction": "zero"}})).json()["id"]
    job = await wait_state(service, job_id, operator=True)
    assert job["state"] == "done", job["reason"]
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    second = {p["name"]: p["value"] for p in result["estimation_2"]["parameters"]}
    assert all(abs(second[n]) < 0.05 for n in THESIS_OFFSETS)  # little left after round 1
    home = result["home_check"]  # ZERO corrected the zeros: home is nearer after (Table 14)
    assert home["after"]["distance_mm"] < home["before"]["distance_mm"]
    perf = result["performance"]
    assert perf["perf_after_2"]["overall"]["ap_mm_mean"] < 2.0
    assert {"cal_2", "estimation_2", "correction_2", "perf_after_2"} <= set(job["phases"])


async def test_a_second_round_with_compensation(service, rig):
    """Round 2 measures the calibration list as planned, re-identifies the (unchanged) robot
    and compensates the last performance list with that model."""
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "procedure", "options": {**FAST, "rounds": 2}})).json()["id"]
    job = await wait_state(service, job_id)
    assert job["state"] == "done", job["reason"]
    result = (await service.get(f"/jobs/{job_id}/result")).json()
    assert result["correction"]["compensated_lists"] == ["perf_after"]
    assert result["correction_2"]["compensated_lists"] == ["perf_after_2"]
    perf = result["performance"]
    assert perf["perf_after"]["overall"]["ap_mm_mean"] < 0.15
    assert perf["perf_after_2"]["overall"]["ap_mm_mean"] < 0.15  # 30 poses, 30 parameters
    assert (await service.get(f"/jobs/{job_id}/model", params={"round": 2})).status_code == 200


async def test_aborting_an_auto_job_mid_move_ends_aborted(service, rig):
    """The controller answers the aborted run with ERR 22: that is the operator's abort, not a
    controller failure."""
    rig.emu.settings.time_scale = 0.05  # moves take a few ms: the abort lands mid-list
    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
    async with asyncio.timeout(30):
        while len((await service.get(f"/jobs/{job_id}/measurements")).json()) < 3:
            await asyncio.sleep(0.01)
    assert (await service.post(f"/jobs/{job_id}/abort", headers=AUTH)).status_code == 204
    job = await wait_state(service, job_id)
    assert job["state"] == "aborted", job["reason"]
    assert job["reason"] == "aborted by the operator"


async def test_a_performance_job_measures_in_an_earlier_jobs_frame(service, rig):
    """Alone, a performance job fits a frame to its own data (and reads low, 15 mm for a
    robot that is 52 mm off); with frame_from_job it measures in the frame a calibration
    identified, and says which."""
    robot = await add_robot(service, rig)
    cal = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
    assert (await wait_state(service, cal))["state"] == "done"
    alone = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "performance", "options": FAST})).json()["id"]
    await wait_state(service, alone)
    framed = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "performance",
        "options": {**FAST, "frame_from_job": cal}})).json()["id"]
    await wait_state(service, framed)
    a = (await service.get(f"/jobs/{alone}/result")).json()
    f = (await service.get(f"/jobs/{framed}/result")).json()
    assert "performance data itself" in a["frame_note"] and f"job {cal}" in f["frame_note"]
    ap_alone = a["performance"]["perf_before"]["overall"]["ap_mm_mean"]
    ap_framed = f["performance"]["perf_before"]["overall"]["ap_mm_mean"]
    assert ap_framed > 2 * ap_alone  # the own-data frame hides most of the error
    bad = await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "performance", "options": {**FAST, "frame_from_job": 999}})
    assert bad.status_code == 404


async def test_a_posted_jobs_plan_is_built_once_and_never_on_the_event_loop(service, rig,
                                                                           monkeypatch):
    """The request that posts a job builds its list to refuse one that cannot run; the runner
    takes that list (it built it a second time, on the event loop, where every other job's
    link waited meanwhile)."""
    built = []

    def counted(model, kind, options, instrument=None):
        built.append((kind, threading.current_thread() is threading.main_thread()))
        return plan_for(model, kind, options, instrument)

    monkeypatch.setattr(api_jobs, "plan_for", counted)
    monkeypatch.setattr(runner_module, "plan_for", counted)
    robot = await add_robot(service, rig)
    r = await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})
    job = await wait_state(service, r.json()["id"])
    assert job["state"] == "done", job["reason"]
    assert built == [("cal", False)]
