"""The job store's contract, on SQLite and on a real PostgreSQL server (tests/postgres_server.py):
the rules the database holds, the leases by which several services share one database, and the
migrations from the previous release's schema."""

from __future__ import annotations

import sqlite3
import time

import pytest

from service.database import SQLiteDatabase, open_database
from service.document import ResultDocument
from service.errors import ConflictError, LeaseLostError, SchemaTooNewError, StoreBusyError
from service.migrations import MIGRATIONS, SCHEMA_VERSION
from service.store import Store

HOLES = [[0, 0, 0], [10, 0, 0], [0, 10, 0]]
POSE = ([0.0] * 6, [0.0] * 7, [[0.0] * 3] * 3, [0.0] * 6)


def robot_and_job(store: Store, name: str = "cell") -> tuple[int, int]:
    robot = store.add_robot(name, "127.0.0.1", 4012, "loop://", {"name": "x"}, HOLES)
    return robot.id, store.add_job(robot.id, "calibration", "AUTO", {"cycles": 3}).id


def second_service(db_target, lease_s: float = 10.0) -> Store:
    """Another service on the same database: on SQLite it is refused (one owner per file)."""
    return Store(db_target, lease_s=lease_s)


def test_robots_and_jobs_round_trip_with_their_json(db_target):
    store = Store(db_target)
    robot_id, job_id = robot_and_job(store)
    assert store.robot(robot_id).holes_mm == HOLES
    assert store.robot_named("cell").id == robot_id
    job = store.job(job_id)
    assert (job.state, job.options.cycles, job.phases) == ("queued", 3, {})
    assert store.jobs() == [job] and store.unfinished_jobs() == [job_id]
    store.add_measurement(job_id, "cal", 0, *POSE)
    store.add_measurement(job_id, "perf", 3, *POSE)
    assert store.measured_indices(job_id, "cal") == {0}
    assert store.last_measurement(job_id)["phase"] == "perf"
    assert [m["idx"] for m in store.measurements(job_id)] == [0, 3]
    assert store.schema_version() == SCHEMA_VERSION
    store.close()


def test_the_database_holds_one_unfinished_job_per_robot_and_unique_names(db_target):
    store = Store(db_target)
    robot_id, job_id = robot_and_job(store)
    with pytest.raises(ConflictError, match=f"busy with job {job_id}"):
        store.add_job(robot_id, "calibration", "AUTO", {})
    with pytest.raises(ConflictError, match="names are unique"):
        store.add_robot("cell", "h", 1, "loop://", {"name": "x"}, HOLES)
    store.set_state(job_id, "done", "")
    store.add_job(robot_id, "performance", "AUTO", {})  # a finished job frees the robot
    store.close()


def test_a_pose_is_stored_once_and_a_step_is_claimed_once(db_target):
    store = Store(db_target)
    _, job_id = robot_and_job(store)
    store.add_measurement(job_id, "cal", 0, *POSE)
    with pytest.raises(store.db.integrity_errors):
        store.add_measurement(job_id, "cal", 0, *POSE)
    assert store.claim_step(job_id, "correction") == {}
    assert store.claim_step(job_id, "correction")["correction"].started
    store.finish_step(job_id, "correction", 1.5)
    store.set_state(job_id, "aborted", "by the operator")
    with pytest.raises(ConflictError, match="stale"):
        store.claim_step(job_id, "perf")
    with pytest.raises(ConflictError, match="no longer unfinished"):
        store.set_state(job_id, "running", "")
    store.close()


# -- several services on one database ------------------------------------------------------------
def test_sqlite_keeps_one_service_per_file_and_its_successor_takes_the_jobs_at_once(tmp_path):
    first = Store(tmp_path / "jobs.db", holder="first")
    _, done = robot_and_job(first, "done cell")
    first.set_state(done, "done", "")
    _, job_id = robot_and_job(first)
    with pytest.raises(StoreBusyError):
        second_service(tmp_path / "jobs.db")
    first.close()  # died: the owner lock proves no one else runs the job
    successor = Store(tmp_path / "jobs.db")
    assert successor.lease_of(job_id)[0] is None
    assert successor.adoptable() == [job_id] and successor.take(job_id)
    assert successor.lease_of(done)[0] == "first"  # provenance: who ran the finished job
    successor.release()
    assert successor.lease_of(done)[0] == "first" and successor.lease_of(job_id)[0] is None
    successor.close()


@pytest.fixture
def postgres_url(postgres_server):
    return postgres_server.new_database()


def test_a_second_service_cannot_run_a_job_the_first_holds(postgres_url):
    a = Store(postgres_url, holder="A", lease_s=30)
    b = Store(postgres_url, holder="B", lease_s=30)
    robot_id, job_id = robot_and_job(a)
    assert b.adoptable() == [] and not b.take(job_id)
    with pytest.raises(ConflictError):  # nor start another on the robot
        b.add_job(robot_id, "calibration", "AUTO", {})
    for write in (lambda: b.claim_step(job_id, "cal"), lambda: b.set_state(job_id, "done", ""),
                  lambda: b.finish_step(job_id, "cal", 1.0),
                  lambda: b.set_result(job_id, ResultDocument()),
                  lambda: b.fail(job_id, "cannot run"),
                  lambda: b.add_measurement(job_id, "cal", 0, *POSE)):
        with pytest.raises(LeaseLostError, match="held by the service A"):
            write()
    assert b.measurements(job_id) == [] and a.job(job_id).phases == {}
    assert a.renew() == {job_id} and b.renew() == set()
    a.close()
    b.close()


def test_an_expired_lease_passes_the_job_on_and_the_old_holder_changes_nothing(postgres_url):
    a = Store(postgres_url, holder="A", lease_s=0.3)
    b = Store(postgres_url, holder="B", lease_s=30)
    _, job_id = robot_and_job(a)
    a.claim_step(job_id, "cal")
    a.add_measurement(job_id, "cal", 0, *POSE)  # renews: still A's
    assert not b.take(job_id)
    time.sleep(0.5)  # A froze past its lease
    assert b.adoptable() == [job_id] and b.take(job_id)
    with pytest.raises(LeaseLostError, match="held by the service B"):
        a.add_measurement(job_id, "cal", 1, *POSE)  # A must not move the robot on
    assert a.renew() == set()
    b.add_measurement(job_id, "cal", 1, *POSE)
    assert b.measured_indices(job_id, "cal") == {0, 1}
    b.release()  # a clean stop: the next service need not wait
    assert a.take(job_id)
    a.close()
    b.close()


def test_the_lease_is_on_the_database_clock_not_the_hosts(postgres_url):
    a = Store(postgres_url, holder="A", lease_s=5)
    _, job_id = robot_and_job(a)
    holder, left_s = a.lease_of(job_id)
    assert holder == "A" and 4.0 < left_s <= 5.0
    now_db = a.db.row(f"SELECT {a.db.now_sql} AS t")["t"]
    assert abs(now_db - time.time()) < 5  # the same epoch seconds as time.time()
    a.close()


# -- migrations -----------------------------------------------------------------------------------
# The schema of the previous release (schema 2) exactly as it wrote it, independent of the code
# that migrates it now.
PREVIOUS_RELEASE_SQLITE = """
CREATE TABLE robots (
    id INTEGER PRIMARY KEY, name TEXT NOT NULL, controller_host TEXT NOT NULL,
    controller_port INTEGER NOT NULL, arm_url TEXT NOT NULL, model TEXT NOT NULL,
    holes_mm TEXT NOT NULL, created REAL NOT NULL);
CREATE TABLE jobs (
    id INTEGER PRIMARY KEY, robot_id INTEGER NOT NULL REFERENCES robots(id),
    kind TEXT NOT NULL, mode TEXT NOT NULL, state TEXT NOT NULL, reason TEXT NOT NULL,
    options TEXT NOT NULL, phases TEXT NOT NULL, result TEXT, created REAL NOT NULL,
    updated REAL NOT NULL);
CREATE TABLE measurements (
    id INTEGER PRIMARY KEY, job_id INTEGER NOT NULL REFERENCES jobs(id),
    phase TEXT NOT NULL, idx INTEGER NOT NULL, joints_deg TEXT NOT NULL,
    tool0 TEXT NOT NULL, holes_mm TEXT NOT NULL, flange_pose TEXT NOT NULL,
    created REAL NOT NULL, UNIQUE (job_id, phase, idx));
CREATE UNIQUE INDEX robots_unique_name ON robots(name);
CREATE UNIQUE INDEX jobs_one_unfinished_per_robot ON jobs(robot_id)
    WHERE state IN ('queued', 'running', 'paused');
INSERT INTO robots VALUES (1, 'cell', '127.0.0.1', 4012, 'loop://', '{"name": "x"}',
    '[[0, 0, 0], [10, 0, 0], [0, 10, 0]]', 1.0);
INSERT INTO jobs VALUES (1, 1, 'calibration', 'AUTO', 'done', '', '{}', '{"cal": {"done": true}}',
    '{"rms": 0.1}', 1.0, 2.0);
INSERT INTO jobs VALUES (2, 1, 'calibration', 'AUTO', 'running', '', '{}',
    '{"cal": {"started": true}}', NULL, 3.0, 4.0);
INSERT INTO measurements VALUES (1, 2, 'cal', 0, '[0]', '[0]', '[[0]]', '[0]', 3.5);
PRAGMA user_version = 2;
"""


def test_a_database_of_the_previous_release_opens_and_migrates(tmp_path):
    path = tmp_path / "previous.db"
    with sqlite3.connect(path) as con:
        con.executescript(PREVIOUS_RELEASE_SQLITE)
    con.close()
    store = Store(path)
    assert store.schema_version() == SCHEMA_VERSION
    assert store.job(1).result.document() == {"rms": 0.1} and store.job(2).state == "running"
    assert store.robot(1).serial == "" and store.robot(1).payload_kg is None
    assert store.robot(1).emulation == []  # an older robot states no emulation
    _, provenance = store.robot_jobs(1)[0]  # made before provenance was kept: said so
    assert provenance["software"] == "" and provenance["robot_identity"] is None
    assert store.adoptable() == [2] and store.take(2)  # its running job goes on, no holder
    store.add_measurement(2, "cal", 1, *POSE)
    assert store.measured_indices(2, "cal") == {0, 1}
    with pytest.raises(ConflictError):  # the old rules hold on
        store.add_job(1, "calibration", "AUTO", {})
    store.close()
    Store(path).close()  # and opens again, migrated once


def test_a_schema_2_database_migrates_on_either_database(db_target):
    db = open_database(db_target)
    db.migrate(MIGRATIONS, 2)  # as the previous release left it
    with db.tx():
        db.execute("INSERT INTO robots (name, controller_host, controller_port, arm_url, model, "
                   "holes_mm, created) VALUES ('cell', 'h', 1, 'loop://', '{}', '[]', 1.0)")
        db.execute("INSERT INTO jobs (robot_id, kind, mode, state, reason, options, phases, "
                   "created, updated) VALUES (1, 'calibration', 'AUTO', 'paused', 'link', '{}', "
                   "'{}', 1.0, 1.0)")
    db.close()
    store = Store(db_target)
    assert store.schema_version() == SCHEMA_VERSION
    assert store.adoptable() == [1] and store.take(1)
    store.set_state(1, "running", "")
    store.close()


def test_a_database_of_a_newer_release_is_refused(db_target):
    Store(db_target).close()
    db = open_database(db_target)
    if isinstance(db, SQLiteDatabase):
        db.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    else:
        db.execute("INSERT INTO screwcal_schema (version) VALUES (?)", (SCHEMA_VERSION + 1,))
    db.close()
    with pytest.raises(SchemaTooNewError, match="newer"):
        Store(db_target)


def test_services_starting_together_migrate_once(postgres_url):
    import threading

    errors: list[BaseException] = []

    def open_close() -> None:
        try:
            Store(postgres_url).close()
        except BaseException as err:  # collected: the assertion below says which
            errors.append(err)

    threads = [threading.Thread(target=open_close) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    db = open_database(postgres_url)
    assert [r["version"] for r in db.rows("SELECT version FROM screwcal_schema ORDER BY 1")] == \
        list(range(1, SCHEMA_VERSION + 1))
    db.close()


def test_a_busy_event_loop_does_not_let_a_live_services_leases_lapse(postgres_url):
    """Found by benchmarks/plant.py: 20 jobs on a loaded host kept two live services' event
    loops busy past a 2 s lease, and their jobs passed back and forth between them. The leases
    are renewed from a thread of the service's own."""
    from service.manager import LeaseRenewer

    a = Store(postgres_url, holder="A", lease_s=0.3)
    b = Store(postgres_url, holder="B", lease_s=0.3)
    _, job_id = robot_and_job(a)
    renewer = LeaseRenewer(a)
    renewer.start()
    try:
        time.sleep(1.0)  # the loop busy (here: this thread) for three leases
        assert not b.take(job_id) and b.adoptable() == []
        assert renewer.held == {job_id} and renewer.error is None
    finally:
        renewer.stop()
    time.sleep(0.5)  # the service died: its lease lapses
    assert b.take(job_id)
    a.close()
    b.close()
