"""A procedure job with ZERO run by people: the engineer starts it, an operator's go-ahead for
the ZERO is refused, the engineer's is taken and named in the robot's history, and the audit
trail holds who started it, every go-ahead and refusal, and every state change, chained."""

import asyncio

import httpx

from service.app import create_app
from service.history import RobotHistory
from service.roles import Role
from service.settings import ServiceSettings
from tests.integration.conftest import FAST

PASSWORD = "correct horse battery"


async def test_a_zero_procedure_by_people_is_audited_whole(rig, tmp_path):
    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db", reconnect_interval_s=0.05,
                                     arm_timeout_s=3.0, pose_timeout_s=10.0))
    async with app.router.lifespan_context(app):
        people = app.state.people
        tokens = {}
        for name, role in (("erin", Role.ENGINEER), ("otto", Role.OPERATOR)):
            people.add_user(name, role, PASSWORD)
            tokens[name] = {"Authorization": f"Bearer {people.add_token(name, 't', 3600)[0]}"}
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service") as http:
            host, port = rig.address
            robot = (await http.post("/robots", headers=tokens["erin"], json={
                "name": "cell", "controller_host": host, "controller_port": port,
                "arm_url": rig.arm.url})).json()["id"]
            refused = await http.post("/jobs", headers=tokens["otto"], json={
                "robot_id": robot, "kind": "procedure", "options": FAST})
            assert refused.status_code == 403  # an operator does not calibrate
            job = (await http.post("/jobs", headers=tokens["erin"], json={
                "robot_id": robot, "kind": "procedure",
                "options": {**FAST, "correction": "zero+compensate"}})).json()["id"]
            async with asyncio.timeout(120):
                while (w := (await http.get(f"/jobs/{job}", headers=tokens["otto"])).json()
                       ["waiting_for"]) is None or w["phase"] != "correction":
                    await asyncio.sleep(0.02)
            go = {"index": w["index"], "operator": "someone else"}
            r = await http.post(f"/jobs/{job}/go", headers=tokens["otto"], json=go)
            assert r.status_code == 403 and "'zero'" in r.json()["detail"]
            r = await http.post(f"/jobs/{job}/go", headers=tokens["erin"], json=go)
            assert r.status_code == 204
            async with asyncio.timeout(120):
                while (await http.get(f"/jobs/{job}", headers=tokens["erin"])).json()[
                        "state"] not in ("done", "failed", "aborted"):
                    await asyncio.sleep(0.05)
            history = RobotHistory.model_validate((await http.get(
                f"/robots/{robot}/history", headers=tokens["erin"])).json())
        (entry,) = history.entries
        assert [c["operator"] for c in entry.confirmed] == ["erin"]  # the user, not the body
        trail = app.state.audit
        records = trail.records(limit=1000)
        said = [(r["actor"], r["action"], r["outcome"]) for r in records]
        assert ("otto", "POST /jobs", "403 refused") in said
        assert ("erin", "POST /jobs", "202") in said
        assert ("otto", "POST /jobs/{job_id}/go", "403 refused") in said
        assert ("erin", "POST /jobs/{job_id}/go", "204") in said
        states = [r["outcome"] for r in records if r["action"] == "job state"]
        assert states[0].startswith("queued -> running") and states[-1].endswith("-> done")
        assert trail.check()["ok"]
