"""Hostile and careless requests: every one gets a 4xx with a reason, never a 500, and the
service starts again afterwards (issue 15, points 1, 2, 8, 10, 11)."""


import httpx
import pytest

from screwcal.commands.main import main
from service.app import create_app
from service.manager import JobManager
from service.settings import ServiceSettings
from service.store import Store
from tests.integration.conftest import AUTH, FAST, TOKEN, add_robot

GOOD_ROBOT = {"name": "cell", "controller_host": "127.0.0.1", "controller_port": 4012,
              "arm_url": "socket://127.0.0.1:4013"}
HUGE = 100000000000000000000


@pytest.fixture
async def http(tmp_path):
    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN))
    async with app.router.lifespan_context(app):
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service", headers=AUTH) as client:
            yield client


@pytest.mark.parametrize("robot", [
    {**GOOD_ROBOT, "holes_mm": [[0, 0, 0], [0, 0, 0], [10, 0, 0]]},  # coincident
    {**GOOD_ROBOT, "holes_mm": [[0, 0, 0], [10, 0, 0], [20, 0, 0]]},  # collinear
    {**GOOD_ROBOT, "controller_host": "bad host; rm -rf"},
    {**GOOD_ROBOT, "controller_host": "x" * 300},
    {**GOOD_ROBOT, "arm_url": "socket://a b"},
    {**GOOD_ROBOT, "arm_url": "x" * 500},
    {**GOOD_ROBOT, "controller_port": 0},
    {**GOOD_ROBOT, "name": ""},
])
async def test_bad_robots_are_refused(http, robot):
    r = await http.post("/robots", headers=AUTH, json=robot)
    assert r.status_code == 422, r.text
    assert "detail" in r.json()


async def test_nan_in_a_body_is_a_422_not_a_500(http):
    body = ('{"name": "cell", "arm_url": "socket://h:1", "holes_mm": '
            '[[NaN, 0, 0], [30, 0, 0], [0, 30, 0]]}')
    r = await http.post("/robots", headers={**AUTH, "Content-Type": "application/json"},
                        content=body)
    assert r.status_code == 422 and "holes_mm" in r.text
    robot = (await http.post("/robots", headers=AUTH, json=GOOD_ROBOT)).json()["id"]
    r = await http.post("/jobs", headers={**AUTH, "Content-Type": "application/json"},
                        content=f'{{"robot_id": {robot}, "kind": "procedure", "options": '
                                '{"arm_position_mm": [NaN, 0, 0]}}')
    assert r.status_code == 422


@pytest.mark.parametrize("path", [f"/jobs/{HUGE}", f"/jobs/{HUGE}/events",
                                  f"/jobs/{HUGE}/report", f"/robots/{HUGE}", "/jobs/-1",
                                  f"/jobs/{HUGE}/result", f"/jobs/{HUGE}/model"])
async def test_ids_beyond_sqlite_are_refused(http, path):
    r = await http.get(path)
    assert r.status_code == 422, (path, r.status_code)


async def test_a_job_on_an_unknown_or_huge_robot(http):
    for robot_id in (HUGE, 999):
        r = await http.post("/jobs", headers=AUTH, json={"robot_id": robot_id,
                                                         "kind": "calibration"})
        assert r.status_code in (404, 422), r.text


@pytest.mark.parametrize("options", [{"cube_edge_mm": 2000.0},
                                     {"arm_position_mm": [5000.0, 0.0, 0.0]}])
async def test_impossible_jobs_are_refused_when_posted(http, options):
    robot = (await http.post("/robots", headers=AUTH, json=GOOD_ROBOT)).json()["id"]
    r = await http.post("/jobs", headers=AUTH, json={"robot_id": robot, "kind": "procedure",
                                                     "options": {**FAST, **options}})
    assert r.status_code == 422 and "cannot run" in r.json()["detail"], r.text
    assert (await http.get("/jobs")).json() == []  # nothing queued


async def test_a_second_job_on_a_busy_robot_is_refused(tmp_path, rig):
    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN,
                                     reconnect_interval_s=0.05))
    rig.emu.settings.time_scale = 0.05  # the first job is still measuring
    async with app.router.lifespan_context(app):
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service", headers=AUTH) as http:
            robot = await add_robot(http, rig)
            first = await http.post("/jobs", headers=AUTH, json={
                "robot_id": robot, "kind": "calibration", "options": FAST})
            assert first.status_code == 202
            second = await http.post("/jobs", headers=AUTH, json={
                "robot_id": robot, "kind": "calibration", "options": FAST})
            assert second.status_code == 409 and "busy" in second.json()["detail"]
            await http.post(f"/jobs/{first.json()['id']}/abort", headers=AUTH)


async def test_a_bad_stored_record_fails_its_job_and_the_service_still_starts(tmp_path):
    """A robot stored before its holes were validated: its job fails with the reason on
    start-up instead of stopping the service."""
    db = tmp_path / "jobs.db"
    store = Store(db)
    robot = store.add_robot("old", "127.0.0.1", 4012, "socket://127.0.0.1:1",
                            {"name": "x"}, [[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    job = store.add_job(robot.id, "calibration", "AUTO", {})
    store.close()
    app = create_app(ServiceSettings(db_path=db, token=TOKEN))
    async with app.router.lifespan_context(app):
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service", headers=AUTH) as http:
            state = (await http.get(f"/jobs/{job.id}")).json()
    assert state["state"] == "failed" and "cannot run" in state["reason"]
    assert JobManager  # the manager's start() is what refused it


@pytest.mark.parametrize(("argv", "message"), [
    (["job", "--token", "t", "robot-add", "--name", "c", "--controller", "127.0.0.1",
      "--arm", "socket://h:1"], "HOST:PORT"),
    (["job", "--token", "", "result", "1"], "no token"),
])
def test_careless_cli_use_gets_a_message_not_a_traceback(argv, message, capsys, monkeypatch):
    monkeypatch.delenv("SCREWCAL_TOKEN", raising=False)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_report_to_a_folder_that_does_not_exist(capsys, monkeypatch):
    monkeypatch.setattr("service.operator.Operator.report", lambda self, job_id: "<html/>")
    assert main(["job", "--token", "t", "report", "1", "--out", "/nonexistent/r.html"]) == 2
    err = capsys.readouterr().err  # refused before the service is asked (issue 38)
    assert "/nonexistent/r.html" in err and "/nonexistent does not exist" in err, err


async def test_reads_need_a_token_too(tmp_path):
    """Hosts, arm URLs and every measurement are not for anyone on the network: reads need
    the service's token or the read-only one, which may not change anything."""
    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN,
                                     read_token="reader"))
    async with app.router.lifespan_context(app):
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service") as http:
            assert (await http.post("/robots", headers=AUTH, json=GOOD_ROBOT)).status_code == 201
            for path in ("/robots", "/robots/1", "/jobs"):
                assert (await http.get(path)).status_code == 401
                assert (await http.get(path, headers={"Authorization": "Bearer x"})
                        ).status_code == 403
                reader = {"Authorization": "Bearer reader"}
                assert (await http.get(path, headers=reader)).status_code == 200
            assert (await http.post("/robots", headers=reader, json=GOOD_ROBOT)
                    ).status_code == 403


def test_a_poor_fit_or_a_worse_robot_is_a_warning_not_a_silent_done():
    from service.analysis import job_warnings
    from service.document import ResultDocument

    result = ResultDocument.model_validate({
        "estimation": {"parameters": [], "rank": 30, "condition_number": 50.0,
                       "chi2_reduced": 40.0, "converged": True, "warnings": ["poses rejected"],
                       "residual_before_mm": 2.0, "residual_after_mm": 0.5},
        "performance": {"perf_before": {"overall": {"ap_mm_mean": 2.47}},
                        "perf_after": {"overall": {"ap_mm_mean": 3.73}}}})
    warnings = job_warnings(result)
    assert any("poor fit" in w for w in warnings)
    assert any("got worse" in w and "2.470 -> 3.730" in w for w in warnings)
    assert any("poses rejected" in w for w in warnings)
