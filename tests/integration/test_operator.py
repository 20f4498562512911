"""The operator's CLI against a running service: STEP prompts, result table, report; and the
one-command demo."""

import asyncio
import re

from screwcal.commands.main import main
from service.cli import Operator, result_table
from service.demo import service
from service.settings import ServiceSettings
from tests.integration.conftest import FAST, TOKEN


async def test_operator_answers_step_prompts_and_reads_the_result(tmp_path, rig):
    settings = ServiceSettings(db_path=tmp_path / "jobs.db", token=TOKEN, port=0)
    with service(settings) as url, Operator(url, TOKEN) as op:
        host, port = rig.address
        robot = await asyncio.to_thread(op.add_robot, name="cell", controller_host=host,
                                        controller_port=port, arm_url=rig.arm.url)
        job = await asyncio.to_thread(op.start, robot_id=robot["id"], kind="calibration",
                                      mode="STEP", options={**FAST, "calibration_poses": 12})
        prompts, lines = [], []

        def ask(prompt: str) -> str:
            prompts.append(prompt)
            return "y" if len(prompts) <= 12 else "n"

        state = await asyncio.to_thread(op.watch, job["id"], ask, lines.append)
        assert state in ("done", "failed")
        assert len(prompts) == 12 and prompts[0].startswith("robot will move to cal pose 0")
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


def test_demo_runs_the_whole_procedure(tmp_path, capsys):
    assert main(["demo", "--cycles", "2", "--poses", "30", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    m = re.search(r"position accuracy AP, mean\s+([\d.]+) mm\s+([\d.]+) mm", out)
    assert m and float(m.group(1)) > 10 * float(m.group(2)), out
    assert (tmp_path / "report.html").stat().st_size > 10_000
    assert (tmp_path / "accuracy_per_point.png").exists()
    assert (tmp_path / "straightness.png").exists()
