"""The operator's CLI against a running service: STEP prompts, result table, report; and the
one-command demo."""

import asyncio
import re

import pytest

from screwcal.commands.main import main
from service.demo import service
from service.operator import Operator
from service.result_text import result_table
from service.settings import ServiceSettings
from tests.integration.conftest import FAST, TOKEN


async def _step_job(op: Operator, rig) -> tuple[dict, dict]:
    """A robot cell on the rig and a 12-pose STEP calibration job started on it."""
    host, port = rig.address
    robot = await asyncio.to_thread(op.add_robot, name="cell", controller_host=host,
                                    controller_port=port, arm_url=rig.arm.url)
    job = await asyncio.to_thread(op.start, robot_id=robot["id"], kind="calibration",
                                  mode="STEP", options={**FAST, "calibration_poses": 12})
    return robot, job


async def test_operator_answers_step_prompts_and_reads_the_result(tmp_path, rig):
    settings = ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN, port=0)
    with service(settings) as url, Operator(url, TOKEN) as op:
        robot, job = await _step_job(op, rig)
        prompts, lines = [], []

        def ask(prompt: str) -> str:
            prompts.append(prompt)
            return "y" if len(prompts) <= 12 else "n"

        state = await asyncio.to_thread(op.watch, job["id"], ask, lines.append)
        assert state in ("done", "failed")
        assert len(prompts) == 12
        assert prompts[0].startswith("robot will move to pose 0 of calibration poses")
        assert any("pose 12 of 12" in line for line in lines)
        table = result_table(await asyncio.to_thread(op.result, job["id"]))
        assert "identified" in table and "J2 " in table  # the full model by default

        # Declining a move leaves the robot where it is and the job waiting.
        job2 = await asyncio.to_thread(op.start, robot_id=robot["id"], kind="calibration",
                                       mode="STEP", options=FAST)
        arrivals = rig.emu.world.arrivals
        state = await asyncio.to_thread(op.watch, job2["id"], lambda _: "n", lines.append)
        assert state == "waiting" and rig.emu.world.arrivals == arrivals
        assert (await asyncio.to_thread(op.job, job2["id"]))["waiting_for"]["index"] == 0
        await asyncio.to_thread(op.abort, job2["id"])


def test_watch_says_a_failed_jobs_state_and_reason_as_a_sentence(tmp_path):
    """`job watch` of a job that failed said 'job 1: failed cannot run: ...' (no colon)."""
    from service.store import Store

    db = tmp_path / "jobs.db"
    store = Store(db)
    robot = store.add_robot("old", "127.0.0.1", 4012, "socket://127.0.0.1:1",
                            {"name": "x"}, [[0, 0, 0], [0, 0, 0], [1, 0, 0]])
    job = store.add_job(robot.id, "calibration", "AUTO", {})  # refused when the service starts
    store.close()
    lines: list[str] = []
    with service(ServiceSettings(db_path=db, token=TOKEN, port=0)) as url, \
            Operator(url, TOKEN) as op:
        assert op.watch(job.id, lambda _: "n", lines.append) == "failed"
    assert lines and lines[0].startswith(f"job {job.id}: failed: cannot run: robot {robot.id}: "
                                         "invalid model file"), lines


def test_demo_runs_the_whole_procedure(tmp_path, capsys):
    assert main(["demo", "--cycles", "2", "--out", str(tmp_path)]) == 0  # 80 poses
    out = capsys.readouterr().out
    m = re.search(r"position accuracy AP, mean\s+([\d.]+) mm\s+([\d.]+) mm", out)
    assert m and float(m.group(1)) > 10 * float(m.group(2)), out
    # the typical robot by default: what it carries, what was identified of it, and our route
    # beside the geometric-only one on the same robot and the oracle floor
    assert "realism typical" in out and "backlash (lost motion): J1 0.006 deg" in out, out
    assert re.search(r"identified: joint compliance J2 [\d.]+ ± [\d.]+", out), out
    ours = re.search(r"ours \(geometry[^)]*\)\s+([\d.]+) mm", out)
    geo = re.search(r"geometric only \(compliance none, lag none\)\s+([\d.]+) mm", out)
    floor = re.search(r"oracle floor\s+([\d.]+) mm", out)
    assert ours and geo and floor, out
    assert float(geo.group(1)) > float(ours.group(1)) >= float(floor.group(1)) * 0.9, out
    page = (tmp_path / "report.html").read_text()
    assert page.count("<svg class='chart'") >= 4  # AP, RP, orientation, residual, straightness
    first = page[:page.index("<table class='summary'")]  # the first screen (issue 38)
    assert "class='verdict'" in first and "On the same emulated robot" in first
    assert "geometric errors only" in first and "the floor" in first
    # issue 38: what it writes is what the next commands take, and it says which takes which
    for name in ("report.html", "result.json", "measurements.csv", "job.json"):
        assert re.search(rf"^    {re.escape(name)} +\S", out, re.M), out
    joints = tmp_path / "joints.csv"
    joints.write_text("q1,q2,q3,q4,q5,q6\n0,10,10,0,30,0\n")
    assert main(["predict", "--result", str(tmp_path / "result.json"), "--joints", str(joints),
                 "--out", str(tmp_path / "predicted.csv")]) == 0
    assert main(["robot", "export", str(tmp_path / "result.json"), "--format", "urdf",
                 "--out", str(tmp_path / "robot.urdf")]) == 0
    assert main(["calibrate", "--robot", "irb1600", "--data", str(tmp_path / "measurements.csv"),
                 "--out", str(tmp_path / "again.json")]) == 0
    capsys.readouterr()
    assert main(["predict", "--result", str(tmp_path / "job.json"), "--joints", str(joints),
                 "--out", str(tmp_path / "predicted.csv")]) == 2
    assert "result.json" in capsys.readouterr().err


async def test_watch_reattaches_to_a_step_job_at_the_pose_it_waits_for(tmp_path, rig):
    """A second `job watch` prompts for the pose the job waits for, not pose 0 of the
    history (it exited on 409 before)."""
    settings = ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN, port=0)
    with service(settings) as url, Operator(url, TOKEN) as op:
        _, job = await _step_job(op, rig)
        answers = iter(["y", "y", "y", "n"])
        state = await asyncio.to_thread(op.watch, job["id"], lambda _: next(answers),
                                        lambda _: None)
        assert state == "waiting"
        prompts: list[str] = []

        def ask(prompt: str) -> str:
            prompts.append(prompt)
            return "y"

        state = await asyncio.to_thread(op.watch, job["id"], ask, lambda _: None)
        assert state == "done"
        assert prompts[0].startswith("robot will move to pose 3 of calibration poses")
        assert len(prompts) == 9  # poses 3..11, each once


async def test_events_carry_ids_and_resume_after_the_last_one(service, rig):
    from tests.integration.conftest import AUTH, add_robot
    from tests.integration.test_jobs import wait_state

    robot = await add_robot(service, rig)
    job_id = (await service.post("/jobs", headers=AUTH, json={
        "robot_id": robot, "kind": "calibration", "options": FAST})).json()["id"]
    await wait_state(service, job_id)

    async def read(headers: dict) -> list[tuple[str | None, dict]]:
        out, last_id = [], None
        async with service.stream("GET", f"/jobs/{job_id}/events", headers=headers) as r:
            async for line in r.aiter_lines():
                if line.startswith("id: "):
                    last_id = line[4:]
                elif line.startswith("data: "):
                    import json

                    out.append((last_id, json.loads(line[6:])))
                    last_id = None
        return out

    every = await read({})
    assert every[0][1]["kind"] == "state" and every[0][1]["state"] == "done"
    assert every[-1][1]["kind"] == "end"
    ids = [i for i, _ in every if i is not None]
    assert len(ids) == len(set(ids)) >= 30  # every event has its own id
    middle = ids[len(ids) // 2]
    resumed = await read({"Last-Event-ID": middle})
    assert resumed[0][1]["kind"] == "state"
    assert [i for i, _ in resumed if i is not None] == ids[len(ids) // 2 + 1:]


@pytest.mark.slow
def test_the_same_seed_prints_the_same_table(tmp_path, capsys):
    def table() -> str:
        assert main(["demo", "--seed", "5", "--cycles", "2", "--poses", "30", "--out",
                     str(tmp_path)]) == 0
        out = capsys.readouterr().out
        return out[out.index("\n  ISO 9283"):out.index("files in")]  # the table, not a phase

    assert table() == table()
