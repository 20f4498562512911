"""The job store: a SQLite file, created and migrated by the service itself.

Every measurement is committed (one transaction) before the robot is allowed to move on; a job's
remaining poses are always derived from what is committed, so a restart after a crash resumes
with nothing lost and nothing measured twice (UNIQUE(job, phase, idx)).

One owner: a service holds an exclusive lock on `<db>.owner` (flock: the OS releases it when the
process dies) and a second service on the same file refuses to start, naming the holder's pid.
The database itself holds the rules that a stale or second runner must not break: robot names
are unique, a robot has at most one unfinished job (a partial unique index checked in the very
transaction that inserts the job), and a job's step is claimed by compare-and-set
(`claim_step`), so a step that changes the robot (ZERO) can never be started twice.

Faults of the disk: SQLITE_FULL is a `StoreFullError` (jobs pause, nothing committed is lost); a
database file deleted or replaced under the service is a `StoreLostError` before any write.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from service.document import JobRecord, PhaseRecord, ResultDocument
from service.errors import (
    ConflictError,
    NotFoundError,
    StoreBusyError,
    StoreError,
    StoreFullError,
    StoreLostError,
)

SCHEMA_VERSION = 2
UNFINISHED = ("queued", "running", "paused")
_UNFINISHED_SQL = "(" + ", ".join(f"'{s}'" for s in UNFINISHED) + ")"  # in queries, not in
# the migrations (a migration is history: it keeps the states it was written with)
_MIGRATIONS = {
    1: """
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
    """,
    # Version 2: the rules the database itself holds (a database of version 1 is brought to them:
    # a repeated robot name gets its id appended, and of several unfinished jobs of one robot
    # only the newest stays unfinished).
    2: """
    UPDATE robots SET name = name || ' #' || id
        WHERE id NOT IN (SELECT MIN(id) FROM robots GROUP BY name);
    CREATE UNIQUE INDEX robots_unique_name ON robots(name);
    UPDATE jobs SET state = 'failed',
        reason = 'another unfinished job of the same robot was newer (database upgrade)'
        WHERE state IN ('queued', 'running', 'paused') AND id NOT IN (
            SELECT MAX(id) FROM jobs WHERE state IN ('queued', 'running', 'paused')
            GROUP BY robot_id);
    CREATE UNIQUE INDEX jobs_one_unfinished_per_robot ON jobs(robot_id)
        WHERE state IN ('queued', 'running', 'paused');
    """,
}


def _row(row: sqlite3.Row | None, what: str) -> dict[str, Any]:
    if row is None:
        raise NotFoundError(f"no such {what}")
    out = dict(row)
    for key in ("model", "holes_mm", "options", "phases", "result", "joints_deg", "tool0",
                "flange_pose"):
        if key in out and isinstance(out[key], str):
            out[key] = json.loads(out[key])
    return out


def _row_id(cursor: sqlite3.Cursor) -> int:
    """The id SQLite gave the row an INSERT just added."""
    if cursor.lastrowid is None:  # only when the statement inserted nothing
        raise StoreError("the database inserted no row")
    return int(cursor.lastrowid)


def _hold_owner_lock(path: Path) -> int:
    """An exclusive flock on `<db>.owner` with this process's pid in it; StoreBusyError naming
    the holder when another live process has it."""
    lock_path = path.with_name(path.name + ".owner")
    fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
        os.close(fd)
        raise StoreBusyError(
            f"the database {path} is in use by another screwcal service (pid {holder}): stop "
            "it, or give this one its own --db") from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    return fd


def _identity(path: Path) -> tuple[int, int]:
    st = os.stat(path)
    return st.st_dev, st.st_ino


class Store:
    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._lock = threading.Lock()
        self._owner_fd = _hold_owner_lock(self.path)
        try:
            self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
            self._db.row_factory = sqlite3.Row
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")  # a committed measurement survives SIGKILL
            self._db.execute("PRAGMA foreign_keys=ON")
            self._file = _identity(self.path)
            self._migrate()
        except BaseException:
            os.close(self._owner_fd)
            raise

    def close(self) -> None:
        self._db.close()
        with contextlib.suppress(OSError):
            os.close(self._owner_fd)

    def check_file(self) -> None:
        """StoreLostError when the database file was deleted or replaced since it was opened
        (what this service writes would go nowhere, or into another file)."""
        try:
            same = _identity(self.path) == self._file
        except FileNotFoundError:
            raise StoreLostError(f"the database file {self.path} was deleted while the service "
                                 "ran: nothing more can be committed; the service stops") from None
        if not same:
            raise StoreLostError(f"the database file {self.path} was replaced while the service "
                                 "ran: nothing more can be committed; the service stops")

    def _migrate(self) -> None:
        version = self._db.execute("PRAGMA user_version").fetchone()[0]
        for v in range(version + 1, SCHEMA_VERSION + 1):
            # executescript commits by itself: the script carries its own transaction.
            with self._lock:
                self._db.executescript(f"BEGIN IMMEDIATE; {_MIGRATIONS[v]} "
                                       f"PRAGMA user_version={v}; COMMIT;")

    @contextmanager
    def _tx(self) -> Iterator[sqlite3.Connection]:
        with self._lock:
            self.check_file()
            try:
                self._db.execute("BEGIN IMMEDIATE")
                try:
                    yield self._db
                    self._db.execute("COMMIT")
                except BaseException:
                    # SQLite may have rolled back by itself (SQLITE_FULL): a second ROLLBACK
                    # would raise "no transaction is active" and hide the real cause.
                    if self._db.in_transaction:
                        self._db.execute("ROLLBACK")
                    raise
            except sqlite3.OperationalError as err:
                if getattr(err, "sqlite_errorcode", None) == sqlite3.SQLITE_FULL:
                    raise StoreFullError(
                        f"the disk holding {self.path} is full (SQLite: {err}): free space, "
                        "then restart the service; the job resumes where it stopped") from err
                raise

    # -- robots --------------------------------------------------------------------------------
    def add_robot(self, name: str, controller_host: str, controller_port: int, arm_url: str,
                  model: dict, holes_mm: list) -> dict:
        try:
            with self._tx() as db:
                cur = db.execute(
                    "INSERT INTO robots (name, controller_host, controller_port, arm_url, model, "
                    "holes_mm, created) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    (name, controller_host, controller_port, arm_url, json.dumps(model),
                     json.dumps(holes_mm), time.time()))
                rid = _row_id(cur)
        except sqlite3.IntegrityError:
            other = self.robot_named(name)
            raise ConflictError(f"a robot named {name!r} exists already (robot {other['id']}): "
                                "robot names are unique") from None
        return self.robot(rid)

    def robot(self, robot_id: int) -> dict:
        return _row(self._db.execute("SELECT * FROM robots WHERE id = ?", (robot_id,))
                    .fetchone(), f"robot {robot_id}")

    def robot_named(self, name: str) -> dict:
        return _row(self._db.execute("SELECT * FROM robots WHERE name = ?", (name,)).fetchone(),
                    f"robot named {name!r}")

    def robots(self) -> list[dict]:
        return [_row(r, "robot") for r in self._db.execute("SELECT * FROM robots ORDER BY id")]

    # -- jobs ----------------------------------------------------------------------------------
    def add_job(self, robot_id: int, kind: str, mode: str, options: dict) -> JobRecord:
        """A new queued job; ConflictError when the robot has an unfinished job (the database's
        unique index decides, in the inserting transaction: no race between services)."""
        self.robot(robot_id)
        now = time.time()
        try:
            with self._tx() as db:
                cur = db.execute(
                    "INSERT INTO jobs (robot_id, kind, mode, state, reason, options, phases, "
                    "created, updated) VALUES (?, ?, ?, 'queued', '', ?, '{}', ?, ?)",
                    (robot_id, kind, mode, json.dumps(options), now, now))
                jid = _row_id(cur)
        except sqlite3.IntegrityError:
            busy = self.unfinished_job(robot_id)
            raise ConflictError(f"robot {robot_id} is busy with job {busy}: wait for it to end "
                                f"or abort it (screwcal job abort {busy})") from None
        return self.job(jid)

    def unfinished_job(self, robot_id: int) -> int | None:
        row = self._db.execute(
            f"SELECT id FROM jobs WHERE robot_id = ? AND state IN {_UNFINISHED_SQL}",
            (robot_id,)).fetchone()
        return None if row is None else int(row[0])

    def unfinished_jobs(self) -> list[int]:
        """The ids of every unfinished job, oldest first."""
        return [int(r[0]) for r in self._db.execute(
            f"SELECT id FROM jobs WHERE state IN {_UNFINISHED_SQL} ORDER BY id")]

    def claim_step(self, job_id: int, step: str) -> dict[str, PhaseRecord]:
        """Mark `step` started, in one transaction that re-reads the job's phases: returns the
        phases as they were before (a runner decides from these, never from its own copy).
        ConflictError when the job is no longer unfinished (another runner ended it)."""
        with self._tx() as db:
            row = db.execute("SELECT state, phases FROM jobs WHERE id = ?", (job_id,)).fetchone()
            if row is None:
                raise NotFoundError(f"no such job {job_id}")
            if row["state"] not in UNFINISHED:
                raise ConflictError(f"job {job_id} is {row['state']}: this runner is stale")
            phases = json.loads(row["phases"])
            if not phases.get(step, {}).get("done"):
                new = {**phases, step: {**phases.get(step, {}), "started": True}}
                db.execute("UPDATE jobs SET phases = ?, updated = ? WHERE id = ?",
                           (json.dumps(new), time.time(), job_id))
        return {k: PhaseRecord.model_validate(v) for k, v in phases.items()}

    def job(self, job_id: int) -> JobRecord:
        return JobRecord.model_validate(_row(self._db.execute(
            "SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone(), f"job {job_id}"))

    def jobs(self) -> list[JobRecord]:
        rows = self._db.execute("SELECT * FROM jobs ORDER BY id").fetchall()
        return [JobRecord.model_validate(_row(r, "job")) for r in rows]

    def set_result(self, job_id: int, result: ResultDocument) -> JobRecord:
        """Store the job's result document (the sections set in it)."""
        with self._tx() as db:
            db.execute("UPDATE jobs SET result = ?, updated = ? WHERE id = ?",
                       (json.dumps(result.document()), time.time(), job_id))
        return self.job(job_id)

    def fail(self, job_id: int, reason: str) -> None:
        """A job that cannot run, whatever its state (its records cannot make a runner)."""
        with self._tx() as db:
            db.execute("UPDATE jobs SET state = 'failed', reason = ?, updated = ? WHERE id = ?",
                       (reason, time.time(), job_id))

    def set_state(self, job_id: int, state: str, reason: str) -> JobRecord:
        """A runner's state change, only while the job is unfinished: ConflictError when another
        runner (or service) has ended it, so a stale runner never revives a finished job."""
        with self._tx() as db:
            cur = db.execute(
                f"UPDATE jobs SET state = ?, reason = ?, updated = ? WHERE id = ? AND state IN "
                f"{_UNFINISHED_SQL}", (state, reason, time.time(), job_id))
            if cur.rowcount == 0:
                raise ConflictError(f"job {job_id} is no longer unfinished: this runner is "
                                    "stale and changes nothing")
        return self.job(job_id)

    def finish_step(self, job_id: int, step: str, seconds: float) -> None:
        """Mark `step` done, merged into the phases as stored now."""
        with self._tx() as db:
            row = db.execute("SELECT phases FROM jobs WHERE id = ?", (job_id,)).fetchone()
            phases = {**json.loads(row["phases"]), step: {"done": True, "seconds": seconds}}
            db.execute("UPDATE jobs SET phases = ?, updated = ? WHERE id = ?",
                       (json.dumps(phases), time.time(), job_id))

    # -- measurements ----------------------------------------------------------------------------
    def add_measurement(self, job_id: int, phase: str, idx: int, joints_deg: list,
                        tool0: list, holes_mm: list, flange_pose: list) -> None:
        """Commit one pose (its own transaction). A pose already stored is an error."""
        with self._tx() as db:
            db.execute(
                "INSERT INTO measurements (job_id, phase, idx, joints_deg, tool0, holes_mm, "
                "flange_pose, created) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (job_id, phase, idx, json.dumps(joints_deg), json.dumps(tool0),
                 json.dumps(holes_mm), json.dumps(flange_pose), time.time()))

    def measurements(self, job_id: int, phase: str | None = None) -> list[dict]:
        sql = "SELECT * FROM measurements WHERE job_id = ?"
        args: tuple = (job_id,)
        if phase is not None:
            sql += " AND phase = ?"
            args += (phase,)
        return [_row(r, "measurement") for r in self._db.execute(sql + " ORDER BY phase, idx",
                                                                 args)]

    def last_measurement(self, job_id: int) -> dict | None:
        """The pose this job committed last (in any phase), or None."""
        row = self._db.execute("SELECT * FROM measurements WHERE job_id = ? ORDER BY id DESC "
                               "LIMIT 1", (job_id,)).fetchone()
        return None if row is None else _row(row, "measurement")

    def measured_indices(self, job_id: int, phase: str) -> set[int]:
        return {r[0] for r in self._db.execute(
            "SELECT idx FROM measurements WHERE job_id = ? AND phase = ?", (job_id, phase))}
