"""People, not tokens: every route walked with every role (allowed exactly where the table of
service/roles.py says, 403 elsewhere), job kinds and the ZERO go-ahead by role, tokens revoked
and roles changed at once, signing in limited per source, and the audit trail chained so that an
edit or a deletion in the database is found."""

import sqlite3

import httpx
import pytest

from service.app import create_app
from service.audit import AuditTrail, Event
from service.roles import GRANT_OF, ROUTES, Role, may
from service.settings import ServiceSettings

PASSWORD = "correct horse battery"
IDS = {"robot_id": "1", "job_id": "1", "name": "nobody", "token_id": "999"}


@pytest.fixture
async def cell(tmp_path):
    """The app on a fresh database, a user and a token per role, and a client without a
    token."""
    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db"))
    async with app.router.lifespan_context(app):
        people = app.state.people
        tokens = {}
        for role in Role:
            people.add_user(f"{role.value}-user", role, PASSWORD)
            tokens[role], _ = people.add_token(f"{role.value}-user", "test", 3600.0)
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service") as http:
            yield app, http, tokens


def _auth(token):
    return {"Authorization": f"Bearer {token}"}


def test_every_route_of_the_app_declares_its_grant(tmp_path):
    app = create_app(ServiceSettings(db_path=tmp_path / "jobs.db"))
    served = {(m, r.path) for r in app.routes for m in getattr(r, "methods", ()) or ()
              if m != "HEAD" and not r.path.startswith(("/docs", "/openapi", "/static"))}
    assert served <= set(GRANT_OF), served - set(GRANT_OF)


async def test_each_role_is_allowed_exactly_where_the_table_says(cell):
    app, http, tokens = cell
    for route in ROUTES:
        if route.grant is None or (route.method, route.path) not in {
                (m, r.path) for r in app.routes for m in getattr(r, "methods", ()) or ()}:
            continue
        path = route.path.format(**IDS)
        for role, token in tokens.items():
            r = await http.request(route.method, path, headers=_auth(token), json={},
                                   timeout=10.0)
            if may(role, route.grant):
                assert r.status_code not in (401, 403), (route, role, r.text)
            else:
                assert r.status_code == 403, (route, role, r.status_code)
                assert "lacks the grant" in r.json()["detail"]


async def test_no_token_is_401_and_an_unknown_one_403(cell):
    _, http, _ = cell
    assert (await http.get("/jobs")).status_code == 401
    assert (await http.get("/jobs", headers=_auth("scw_nothing"))).status_code == 403


async def test_calibrating_needs_an_engineer(cell):
    _, http, tokens = cell
    body = {"robot_id": 1, "kind": "calibration"}
    r = await http.post("/jobs", headers=_auth(tokens[Role.OPERATOR]), json=body)
    assert r.status_code == 403 and "calibrate" in r.json()["detail"]
    r = await http.post("/jobs", headers=_auth(tokens[Role.ENGINEER]), json=body)
    assert r.status_code not in (401, 403)
    r = await http.post("/jobs", headers=_auth(tokens[Role.OPERATOR]),
                        json={**body, "kind": "performance"})
    assert r.status_code not in (401, 403)


async def test_a_revoked_token_and_a_changed_role_hold_at_once(cell):
    app, http, tokens = cell
    people = app.state.people
    token, record = people.add_token("engineer-user", "laptop", 3600.0)
    assert (await http.get("/jobs", headers=_auth(token))).status_code == 200
    r = await http.delete(f"/tokens/{record['id']}", headers=_auth(token))  # one's own
    assert r.status_code == 200 and r.json()["revoked"]
    assert (await http.get("/jobs", headers=_auth(token))).status_code == 403
    r = await http.put("/users/engineer-user/role", headers=_auth(tokens[Role.ADMINISTRATOR]),
                       json={"role": "viewer"})
    assert r.status_code == 200
    r = await http.post("/robots", headers=_auth(tokens[Role.ENGINEER]), json={})
    assert r.status_code == 403  # the same token, its user a viewer now


async def test_signing_in_gives_a_token_and_is_limited_per_source(cell):
    app, http, _ = cell
    r = await http.post("/session", json={"name": "operator-user", "password": PASSWORD})
    assert r.status_code == 200 and r.json()["role"] == "operator"
    assert (await http.get("/jobs", headers=_auth(r.json()["token"]))).status_code == 200
    for _ in range(12):  # an attacker at one address
        r = await http.post("/session", json={"name": "operator-user", "password": "wrong"})
    assert r.status_code == 429
    assert "try again in" in r.json()["detail"] and int(r.headers["Retry-After"]) > 0
    # the operator, from another address, is not locked out (no timing here: the figure is
    # in the closing note)
    async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app,
                                                               client=("10.0.0.7", 4321)),
                                 base_url="http://service") as other:
        r = await other.post("/session", json={"name": "operator-user", "password": PASSWORD})
    assert r.status_code == 200


async def test_changes_and_refusals_are_audited_and_tampering_found(cell, tmp_path):
    app, http, tokens = cell
    await http.post("/robots", headers=_auth(tokens[Role.VIEWER]), json={})  # refused
    await http.put("/users/viewer-user/role", headers=_auth(tokens[Role.ADMINISTRATOR]),
                   json={"role": "operator"})
    await http.delete("/tokens/999", headers=_auth(tokens[Role.ADMINISTRATOR]))  # a 404
    records = app.state.audit.records()
    assert len(records) == 3
    assert any(r["actor"] == "viewer-user" and r["action"] == "POST /robots"
               and r["outcome"] == "403 refused" for r in records)
    assert any(r["actor"] == "administrator-user" and r["action"] == "PUT /users/{name}/role"
               and r["target"] == "name viewer-user" and r["outcome"] == "200"
               for r in records)
    r = await http.get("/audit/check", headers=_auth(tokens[Role.ADMINISTRATOR]))
    assert r.json()["ok"] and r.json()["records"] == len(records)
    db = sqlite3.connect(tmp_path / "jobs.db")
    second = records[1]["id"]
    db.execute("UPDATE audit SET actor = 'somebody else' WHERE id = ?", (second,))
    db.commit()
    assert app.state.audit.records()[1]["actor"] == "somebody else"
    check = (await http.get("/audit/check", headers=_auth(tokens[Role.ADMINISTRATOR]))).json()
    assert check["ok"] is False and check["first_broken"] == second, (check, records[:3])
    db.execute("UPDATE audit SET actor = ? WHERE id = ?", (records[1]["actor"], second))
    db.execute("DELETE FROM audit WHERE id = ?", (second,))
    db.commit()
    db.close()
    check = app.state.audit.check()
    assert check["ok"] is False and check["first_broken"] == records[2]["id"]
    assert "deleted or changed" in check["why"]
    db = sqlite3.connect(tmp_path / "jobs.db")  # the last record cut: the head shows it
    db.execute("DELETE FROM audit WHERE id > ?", (records[0]["id"],))
    db.commit()
    db.close()
    check = app.state.audit.check()
    assert check["ok"] is False and "cut from its end" in check["why"]


def test_the_chain_takes_appends_in_turn(tmp_path):
    from service.database import open_database
    from service.migrations import MIGRATIONS, SCHEMA_VERSION

    db = open_database(tmp_path / "a.db")
    db.migrate(MIGRATIONS, SCHEMA_VERSION)
    trail = AuditTrail(db)
    ids = [trail.append(Event("ana", "10.0.0.1", "POST /jobs", "job 1", "202"))
           for _ in range(5)]
    check = trail.check()
    assert ids == sorted(ids) and check["ok"] and check["records"] == 5
    db.close()


def test_the_docs_print_the_grants_table():
    from pathlib import Path

    from service.roles import routes_table

    docs = (Path(__file__).resolve().parents[2] / "docs" / "service.md").read_text()
    assert routes_table() in docs


def test_every_state_change_of_a_job_is_audited_with_it(db_target):
    """A runner's state change and its audit record stand or fall together (one transaction),
    on both databases."""
    from service.store import Store
    from tests.service.test_store import robot_and_job

    store = Store(db_target)
    _, job_id = robot_and_job(store)
    store.set_state(job_id, "running", "")
    store.set_state(job_id, "paused", "the controller's link was lost")
    store.set_state(job_id, "running", "")
    store.set_state(job_id, "done", "")
    trail = AuditTrail(store.db)
    changes = [(r["target"], r["outcome"], r["detail"]) for r in trail.records()
               if r["action"] == "job state"]
    assert changes == [(f"job {job_id}", "queued -> running", ""),
                       (f"job {job_id}", "running -> paused", "the controller's link was lost"),
                       (f"job {job_id}", "paused -> running", ""),
                       (f"job {job_id}", "running -> done", "")]
    assert trail.check()["ok"]
    store.close()


async def test_a_role_taken_away_stops_that_users_next_go_ahead(cell):
    app, http, tokens = cell
    go = {"index": 0}
    r = await http.post("/jobs/1/go", headers=_auth(tokens[Role.OPERATOR]), json=go)
    assert r.status_code not in (401, 403)  # allowed (no such job here: 404)
    app.state.people.set_role("operator-user", Role.VIEWER)  # mid-job, by an administrator
    r = await http.post("/jobs/1/go", headers=_auth(tokens[Role.OPERATOR]), json=go)
    assert r.status_code == 403 and "lacks the grant 'go-ahead'" in r.json()["detail"]
