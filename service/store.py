"""The job store: a SQLite file, created and migrated by the service itself.

Every measurement is committed (one transaction) before the robot is allowed to move on; a job's
remaining poses are always derived from what is committed, so a restart after a crash resumes
with nothing lost and nothing measured twice (UNIQUE(job, phase, idx)).
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from service.errors import NotFoundError

SCHEMA_VERSION = 1
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


class Store:
    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._lock = threading.Lock()
        self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        self._db.row_factory = sqlite3.Row
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=FULL")  # a committed measurement survives SIGKILL
        self._db.execute("PRAGMA foreign_keys=ON")
        self._migrate()

    def close(self) -> None:
        self._db.close()

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
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield self._db
                self._db.execute("COMMIT")
            except BaseException:
                self._db.execute("ROLLBACK")
                raise

    # -- robots --------------------------------------------------------------------------------
    def add_robot(self, name: str, controller_host: str, controller_port: int, arm_url: str,
                  model: dict, holes_mm: list) -> dict:
        with self._tx() as db:
            cur = db.execute(
                "INSERT INTO robots (name, controller_host, controller_port, arm_url, model, "
                "holes_mm, created) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (name, controller_host, controller_port, arm_url, json.dumps(model),
                 json.dumps(holes_mm), time.time()))
            rid = cur.lastrowid
        return self.robot(int(rid))  # type: ignore[arg-type]

    def robot(self, robot_id: int) -> dict:
        return _row(self._db.execute("SELECT * FROM robots WHERE id = ?", (robot_id,))
                    .fetchone(), f"robot {robot_id}")

    def robots(self) -> list[dict]:
        return [_row(r, "robot") for r in self._db.execute("SELECT * FROM robots ORDER BY id")]

    # -- jobs ----------------------------------------------------------------------------------
    def add_job(self, robot_id: int, kind: str, mode: str, options: dict) -> dict:
        self.robot(robot_id)
        now = time.time()
        with self._tx() as db:
            cur = db.execute(
                "INSERT INTO jobs (robot_id, kind, mode, state, reason, options, phases, created,"
                " updated) VALUES (?, ?, ?, 'queued', '', ?, '{}', ?, ?)",
                (robot_id, kind, mode, json.dumps(options), now, now))
            jid = cur.lastrowid
        return self.job(int(jid))  # type: ignore[arg-type]

    def job(self, job_id: int) -> dict:
        return _row(self._db.execute("SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone(),
                    f"job {job_id}")

    def jobs(self, states: tuple[str, ...] | None = None) -> list[dict]:
        rows = self._db.execute("SELECT * FROM jobs ORDER BY id").fetchall()
        out = [_row(r, "job") for r in rows]
        return [j for j in out if states is None or j["state"] in states]

    def set_job(self, job_id: int, **fields: Any) -> dict:
        for key in ("phases", "result", "options"):
            if key in fields:
                fields[key] = json.dumps(fields[key])
        fields["updated"] = time.time()
        cols = ", ".join(f"{k} = ?" for k in fields)
        with self._tx() as db:
            db.execute(f"UPDATE jobs SET {cols} WHERE id = ?", (*fields.values(), job_id))
        return self.job(job_id)

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

    def measured_indices(self, job_id: int, phase: str) -> set[int]:
        return {r[0] for r in self._db.execute(
            "SELECT idx FROM measurements WHERE job_id = ? AND phase = ?", (job_id, phase))}
