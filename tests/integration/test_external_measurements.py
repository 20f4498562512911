"""Any other instrument feeding a job (issue 40 item 6): a robot whose instrument is `external`
waits at each pose for its measurement, posted to POST /jobs/ID/measurement by the instrument's
own software. Here that software is a script with httpx, a client nobody here wrote, talking to
the service served by uvicorn on a real TCP port; the points are where the emulated robot's
flange targets truly are, with a tracker-like noise. And `screwcal job measure`, the operator's
command, posts from arguments and from a file."""

from __future__ import annotations

import asyncio
import contextlib
import json
import time

import httpx
import numpy as np
import pytest

from screwcal.commands.main import main
from service.server import bind
from service.settings import ServiceSettings
from tests.integration.conftest import TOKEN

AUTH = {"Authorization": f"Bearer {TOKEN}"}
POSES = 12
OPTIONS = {"calibration_poses": POSES, "cycles": 2, "cube_edge_mm": 250.0}
NOISE_MM = 0.01


@pytest.fixture
async def served(tmp_path):
    """The service on a free TCP port (uvicorn, as `screwcal serve` runs it): its URL."""
    server = bind(ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN,
                                  reconnect_interval_s=0.05, pose_timeout_s=10.0), port=0)
    task = asyncio.create_task(server.serve())
    async with asyncio.timeout(20):
        while not server.uvicorn.started:
            await asyncio.sleep(0.02)
    host, port = server.address
    yield f"http://{host}:{port}"
    server.uvicorn.should_exit = True
    with contextlib.suppress(Exception):
        await asyncio.wait_for(task, 20)
    server.sock.close()


async def external_robot(http: httpx.AsyncClient, rig, **instrument) -> int:
    host, port = rig.address
    r = await http.post("/robots", json={
        "name": "IRB 1600 (emulated), measured by another instrument",
        "controller_host": host, "controller_port": port,
        "instrument": {"kind": "external", "name": "a script", **instrument}})
    assert r.status_code == 201, r.text
    return r.json()["id"]


async def wanted(http: httpx.AsyncClient, job_id: int) -> dict | None:
    """The pose whose measurement the job waits for, once it does (None: it ended)."""
    async with asyncio.timeout(30):
        while True:
            job = (await http.get(f"/jobs/{job_id}")).json()
            if job["measurement_for"] is not None:
                return job["measurement_for"]
            if job["state"] in ("done", "failed", "aborted"):
                return None
            await asyncio.sleep(0.01)


def measured_by_the_script(rig, rng, pose: dict, u95: bool) -> dict:
    """What an instrument's software would send: the targets where they are, with noise."""
    points = rig.world.true_holes_mm() + rng.normal(0.0, NOISE_MM, (3, 3))
    body = {"phase": pose["phase"], "index": pose["index"], "points_mm": points.tolist(),
            "time_s": time.time()}
    if u95:
        body["u95_mm"] = [2 * NOISE_MM] * 3
    else:
        body["covariance_mm2"] = [(np.eye(3) * NOISE_MM**2).tolist()] * 3
        body["conditions"] = {"temperature_c": 20.5, "pressure_mbar": 1013.0,
                              "humidity_pct": 45.0}
    return body


async def test_a_script_feeds_a_calibration_job_pose_by_pose(served, rig):
    rng = np.random.default_rng(3)
    async with httpx.AsyncClient(base_url=served, headers=AUTH, timeout=30) as http:
        robot = await external_robot(http, rig)
        job_id = (await http.post("/jobs", json={"robot_id": robot, "kind": "calibration",
                                                 "options": OPTIONS})).json()["id"]
        sent = {}
        while (pose := await wanted(http, job_id)) is not None:
            body = measured_by_the_script(rig, rng, pose, u95=pose["index"] % 2 == 1)
            if pose["index"] == 3:  # refused: a pose the job does not wait for, names the one
                other = await http.post(f"/jobs/{job_id}/measurement",
                                        json={**body, "index": 4})
                assert other.status_code == 409, other.text
                assert "waits for the measurement of cal pose 3, not cal pose 4" in \
                    other.json()["detail"]
                short = await http.post(f"/jobs/{job_id}/measurement",
                                        json={**body, "points_mm": body["points_mm"][:1],
                                              "u95_mm": [0.02]})
                assert short.status_code == 422 and "3 per pose" in short.json()["detail"]
            r = await http.post(f"/jobs/{job_id}/measurement", json=body)
            assert r.status_code == 202, r.text
            again = await http.post(f"/jobs/{job_id}/measurement", json=body)
            assert again.status_code == 200 and "nothing changed" in again.json()["outcome"]
            moved = {**body, "points_mm": (np.array(body["points_mm"]) + 0.5).tolist()}
            other = await http.post(f"/jobs/{job_id}/measurement", json=moved)
            assert other.status_code == 409 and "measured already" in other.json()["detail"]
            sent[pose["index"]] = body
        job = (await http.get(f"/jobs/{job_id}")).json()
        assert job["state"] == "done", job["reason"]
        rows = (await http.get(f"/jobs/{job_id}/measurements")).json()
        assert sorted(r["idx"] for r in rows) == list(range(POSES))  # each once
        for r in rows:
            body = sent[r["idx"]]
            assert r["holes_mm"] == body["points_mm"] and r["measured_at"] == body["time_s"]
            var = np.array(r["covariance_mm2"])[:, 0, 0]
            assert var == pytest.approx([NOISE_MM**2] * 3)  # U95 / 2 squared, or as sent
        assert rows[0]["conditions"]["pressure_mbar"] == 1013.0
        # after the job: the same post is still idempotent, another still refused
        late = await http.post(f"/jobs/{job_id}/measurement", json=sent[0])
        assert late.status_code == 200
        result = (await http.get(f"/jobs/{job_id}/result")).json()
        assert result["estimation"]["residual_after_mm"] < 0.05
        trail = (await http.get("/audit", params={"limit": 1000})).json()
        posts = [e for e in trail if e["action"] == "measurement"]
        outcomes = [e["outcome"] for e in posts]
        assert outcomes.count("taken") == POSES
        assert sum("nothing changed" in o for o in outcomes) == POSES + 1
        assert sum(o == "refused" for o in outcomes) == POSES + 1  # other pose, moved values
        assert all("sha256 " in e["detail"] for e in posts)
        assert (await http.get("/audit/check")).json()["ok"]


async def test_the_measure_command_posts_from_arguments_and_from_a_file(served, rig,
                                                                        tmp_path):
    async with httpx.AsyncClient(base_url=served, headers=AUTH, timeout=30) as http:
        robot = await external_robot(http, rig, targets_mm=[[30.0, 20.0, 40.0]])  # one point
        job_id = (await http.post("/jobs", json={"robot_id": robot, "kind": "calibration",
                                                 "options": OPTIONS})).json()["id"]
        flange_point = np.array([30.0, 20.0, 40.0, 1.0])
        k = 0
        while (pose := await wanted(http, job_id)) is not None:
            assert pose["points"] == 1
            xyz = (rig.world.true_tool0() @ flange_point)[:3]
            common = ["job", "--service", served, "--token", TOKEN, "measure", str(job_id)]
            if k % 3 == 0:  # from arguments, the pose the job waits for
                args = [*common, "--point-mm", *(f"{v:.4f}" for v in xyz), "--u95-mm", "0.02"]
            elif k % 3 == 1:  # a SpatialAnalyzer-style export in metres: semicolons, decimal
                # commas, extra columns, base nests beside the SMR; the SMR chosen by name
                path = tmp_path / f"pose{k}.txt"
                m = [f"{v / 1000:.7f}".replace(".", ",") for v in xyz]
                path.write_text("Collection;Group;Point Name;X;Y;Z;U95;Time\n"
                                "A;Base;NEST1;1,0005;-0,20025;0,0;0,000011;10:00\n"
                                f"A;Robot;SMR1;{';'.join(m)};0,00002;10:01\n", encoding="utf-8")
                args = [*common, "--export", str(path), "--names", "SMR1", "--length-unit", "m"]
            else:  # from a file, the pose named in it
                path = tmp_path / f"pose{k}.json"
                path.write_text(json.dumps({"phase": pose["phase"], "index": pose["index"],
                                            "points_mm": [xyz.round(4).tolist()],
                                            "u95_mm": [0.02], "time_s": time.time()}))
                args = [*common, "--file", str(path)]
            assert await asyncio.to_thread(main, args) == 0
            k += 1
        job = (await http.get(f"/jobs/{job_id}")).json()
        assert job["state"] == "done", job["reason"]
        rows = (await http.get(f"/jobs/{job_id}/measurements")).json()
        assert sorted(r["idx"] for r in rows) == list(range(POSES))
        assert all(r["flange_pose"] == [] for r in rows)  # one point: positions
        for r in rows:  # U95 0.02 mm every way: (U95 / 2)^2 on the diagonal
            assert np.array(r["covariance_mm2"][0]) == pytest.approx(np.eye(3) * 1e-4)
        # the export's metres read as mm: every pose fits the robot (a point off by 1000x or a
        # decimal comma misread would not)
        result = (await http.get(f"/jobs/{job_id}/result")).json()
        assert result["estimation"]["residual_after_mm"] < 0.1
        # the job has ended: the command says what the service refused, exit 2 (refused)
        args = ["job", "--service", served, "--token", TOKEN, "measure", str(job_id),
                "--point-mm", "1", "2", "3"]
        assert await asyncio.to_thread(main, args) != 0


async def test_a_job_waiting_for_a_measurement_aborts_and_then_takes_none(served, rig):
    """Nobody posts: the job waits at its first pose (running, its measurement_for named)
    until the operator aborts it; a post after that is refused (409), nothing committed."""
    async with httpx.AsyncClient(base_url=served, headers=AUTH, timeout=30) as http:
        robot = await external_robot(http, rig)
        job_id = (await http.post("/jobs", json={"robot_id": robot, "kind": "calibration",
                                                 "options": OPTIONS})).json()["id"]
        pose = await wanted(http, job_id)
        assert pose is not None and (pose["phase"], pose["index"]) == ("cal", 0)
        await asyncio.sleep(0.5)  # still waiting, still running
        job = (await http.get(f"/jobs/{job_id}")).json()
        assert job["state"] == "running" and job["measurement_for"]["index"] == 0
        good = measured_by_the_script(rig, np.random.default_rng(1), pose, u95=False)
        negative = [(np.eye(3) * -1e-4).tolist()] * 3
        lopsided = [[[1e-4, 1e-5, 0], [0, 1e-4, 0], [0, 0, 1e-4]]] * 3
        for bad, words in (
                ({"covariance_mm2": negative}, "not a covariance"),
                ({"covariance_mm2": lopsided}, "not symmetric"),
                ({"covariance_mm2": negative[:2]}, "2 covariances for 3 points"),
                ({"u95_mm": [0.02] * 3}, "not both"),
                ({"points_mm": [[0, 0, 0]] * 4}, "at most 3"),
                ({"points_mm": [[1e9, 0, 0]] * 3}, "beyond"),
                ({"time_s": -1}, "greater than 0"),
                ({"conditions": {"temperature_c": 20, "pressure_mbar": 5,
                                 "humidity_pct": 50}}, "pressure_mbar")):
            r = await http.post(f"/jobs/{job_id}/measurement", json={**good, **bad})
            assert r.status_code == 422, (bad, r.text)
            assert words in r.text, (words, r.text)
        nan = await http.post(f"/jobs/{job_id}/measurement",  # not JSON: refused, not a 500
                              content=json.dumps({**good, "time_s": float("nan")}),
                              headers={"Content-Type": "application/json"})
        assert nan.status_code == 422, nan.text
        assert (await http.get(f"/jobs/{job_id}")).json()["measurement_for"]["index"] == 0
        assert (await http.post(f"/jobs/{job_id}/abort")).status_code == 204
        async with asyncio.timeout(20):
            while (job := (await http.get(f"/jobs/{job_id}")).json())["state"] != "aborted":
                await asyncio.sleep(0.02)
        body = measured_by_the_script(rig, np.random.default_rng(0), pose, u95=True)
        late = await http.post(f"/jobs/{job_id}/measurement", json=body)
        assert late.status_code == 409, late.text
        assert (await http.get(f"/jobs/{job_id}/measurements")).json() == []


async def test_only_a_role_with_the_measure_grant_posts_measurements(rig, tmp_path):
    """An instrument's account (role instrument) posts the pose's measurement; a viewer and an
    operator are refused (403), and the audit trail names each."""
    from service.app import create_app
    from service.roles import Role

    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", reconnect_interval_s=0.05,
                                     pose_timeout_s=10.0))
    async with app.router.lifespan_context(app):
        people = app.state.people
        heads = {}
        for name, role in (("erin", Role.ENGINEER), ("sa", Role.INSTRUMENT),
                           ("vera", Role.VIEWER), ("otto", Role.OPERATOR)):
            people.add_user(name, role, "correct horse battery")
            heads[name] = {"Authorization": f"Bearer {people.add_token(name, 't', 3600)[0]}"}
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service", headers=heads["erin"]) as http:
            robot = await external_robot(http, rig)
            job_id = (await http.post("/jobs", json={
                "robot_id": robot, "kind": "calibration", "options": OPTIONS})).json()["id"]
            pose = await wanted(http, job_id)
            body = measured_by_the_script(rig, np.random.default_rng(2), pose, u95=True)
            for who in ("vera", "otto"):
                r = await http.post(f"/jobs/{job_id}/measurement", json=body, headers=heads[who])
                assert r.status_code == 403 and "'measure'" in r.json()["detail"], r.text
            r = await http.post(f"/jobs/{job_id}/measurement", json=body, headers=heads["sa"])
            assert r.status_code == 202, r.text
            await http.post(f"/jobs/{job_id}/abort")
        said = {(e["actor"], e["action"], e["outcome"]) for e in app.state.audit.records(1000)}
        assert {("vera", "POST /jobs/{job_id}/measurement", "403 refused"),
                ("otto", "POST /jobs/{job_id}/measurement", "403 refused"),
                ("sa", "measurement", "taken")} <= said, said
