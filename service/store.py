"""The job store: SQLite (one file, the default) or PostgreSQL (several services on one
database), created and migrated by the service itself (service/database.py says what differs).

Every measurement is committed (one transaction) before the robot is allowed to move on; a job's
remaining poses are always derived from what is committed, so a restart after a crash resumes
with nothing lost and nothing measured twice (UNIQUE(job, phase, idx)).

Who may run a job: the service holding its lease (jobs.holder, jobs.lease_expires on the
database's clock). A service takes the jobs it creates, renews its leases while it lives
(`renew`), and adopts an unfinished job whose lease has expired (`take`): a service killed
mid-job is replaced by another after one lease, at the pose the job waits for. Every write of
a runner (claim_step, set_state, finish_step, add_measurement, set_result, fail) is checked
against the lease in its own transaction, so a runner that lost its job (frozen past its
lease) changes nothing and moves nothing more (LeaseLostError); each measurement renews it.

On SQLite one service owns the file besides (flock on `<db>.owner`, released by the OS when the
process dies; a second service refuses to start, naming the holder's pid); holding it, the
service knows every earlier holder is dead and takes their jobs at once.
The database itself holds the rules that a stale or second runner must not break: robot names
are unique, a robot has at most one unfinished job (a partial unique index checked in the very
transaction that inserts the job), and a job's step is claimed by compare-and-set
(`claim_step`), so a step that changes the robot (ZERO) can never be started twice.

Faults: one that passes (a full disk, an I/O error such as a file-size limit, a read-only file,
a lost PostgreSQL connection) is a `StoreUnavailableError` (`StoreFullError` for a full disk):
jobs pause and go on once the store takes their calls again (service/outage.py), nothing
committed is lost, and the database reconnects by itself; a SQLite file deleted or replaced
under the service is a `StoreLostError`, which stops it.
"""

from __future__ import annotations

import json
import os
import socket
import time
import uuid
from pathlib import Path
from typing import TYPE_CHECKING, Any

from screwcal import __version__
from service.audit import Event, record
from service.database import Database, open_database
from service.document import JobRecord, PhaseRecord, ResultDocument
from service.errors import (
    ConflictError,
    LeaseLostError,
    NotFoundError,
    SchemaTooNewError,
)
from service.job_state import UNFINISHED, JobState, check_transition, sql_list
from service.migrations import MIGRATIONS, SCHEMA_VERSION
from service.robot_record import ArmSetup, InstrumentSetup, RobotRecord

if TYPE_CHECKING:
    from service.settings import ServiceSettings

_UNFINISHED_SQL = sql_list(UNFINISHED)  # in queries, not in the migrations (a migration is
# history: it keeps the states it was written with)
DEFAULT_LEASE_S = 10.0
IDENTITY = ("serial", "controller_software", "tool", "payload_kg")  # a robot's, as it changes


def _row(row: dict[str, Any] | None, what: str) -> dict[str, Any]:
    if row is None:
        raise NotFoundError(f"no such {what}")
    out = dict(row)
    for key in ("model", "holes_mm", "options", "phases", "result", "joints_deg", "tool0",
                "flange_pose", "robot_identity", "emulation", "instrument", "covariance_mm2",
                "conditions"):
        if key in out and isinstance(out[key], str):
            out[key] = json.loads(out[key])
    return out


def open_store(settings: ServiceSettings) -> Store:
    """The store the settings name (SQLite file or PostgreSQL URL), with their lease."""
    return Store(settings.db_target, holder=settings.instance or None, lease_s=settings.lease_s)


def instance_name() -> str:
    """This service's name as a lease holder: host, pid and a random part (a pid is reused)."""
    return f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:6]}"


class Store:
    """`target`: a SQLite file path, or a postgresql:// URL. `holder`: this service's name on
    the leases it takes (unique per process by default); `lease_s`: how long a lease lasts
    unrenewed, i.e. how soon another service adopts the jobs of one that died."""

    def __init__(self, target: str | Path, holder: str | None = None,
                 lease_s: float = DEFAULT_LEASE_S):
        self.holder = holder or instance_name()
        self.lease_s = float(lease_s)
        self.db: Database = open_database(target)
        self.path = getattr(self.db, "path", None)
        try:
            self._migrate()
            if self.db.holders_gone():
                with self.db.tx() as db:
                    db.execute("UPDATE jobs SET holder = NULL, lease_expires = NULL WHERE "
                               f"holder IS NOT NULL AND state IN {_UNFINISHED_SQL}")
        except BaseException:
            self.db.close()
            raise

    @property
    def label(self) -> str:
        return self.db.label

    def close(self) -> None:
        self.db.close()

    def check_file(self) -> None:
        """StoreLostError when the database can no longer be written (a SQLite file deleted
        or replaced since it was opened: what this service writes would go nowhere)."""
        self.db.check()

    def _migrate(self) -> None:
        version = self.db.schema_version()
        if version > SCHEMA_VERSION:
            raise SchemaTooNewError(
                f"the database {self.db.label} has schema version {version}, newer than this "
                f"release's {SCHEMA_VERSION}: a newer screwcal wrote it; upgrade this one")
        self.db.migrate(MIGRATIONS, SCHEMA_VERSION)

    def schema_version(self) -> int:
        return self.db.schema_version()

    # -- robots --------------------------------------------------------------------------------
    def add_robot(self, name: str, controller_host: str, controller_port: int,
                  instrument: InstrumentSetup | str, model: dict, holes_mm: list,
                  identity: dict | None = None, emulation: list[str] | None = None
                  ) -> RobotRecord:
        """A robot cell measured by `instrument` (service/robot_record.py; a string: the
        measuring arm's address); `identity` its serial number, controller software, tool and
        payload (IDENTITY: each optional); `emulation` what an emulated robot carries (its
        realism, one line per effect), none for a real robot."""
        setup = ArmSetup(url=instrument) if isinstance(instrument, str) else instrument
        ident = self._identity(identity or {})
        try:
            with self.db.tx() as db:
                rid = db.execute(
                    "INSERT INTO robots (name, controller_host, controller_port, arm_url, model, "
                    "holes_mm, created, serial, controller_software, tool, payload_kg, "
                    "emulation, instrument) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) "
                    "RETURNING id",
                    (name, controller_host, controller_port,
                     setup.url if isinstance(setup, ArmSetup) else "", json.dumps(model),
                     json.dumps(holes_mm), time.time(), *ident.values(),
                     json.dumps(emulation or []), setup.model_dump_json())).fetchone()["id"]
        except self.db.integrity_errors:
            other = self.robot_named(name)
            raise ConflictError(f"a robot named {name!r} exists already (robot {other.id}): "
                                "robot names are unique") from None
        return self.robot(int(rid))

    @staticmethod
    def _identity(identity: dict) -> dict:
        unknown = set(identity) - set(IDENTITY)
        if unknown:
            raise ValueError(f"not a robot identity field: {', '.join(sorted(unknown))} "
                             f"(fields: {', '.join(IDENTITY)})")
        return {k: identity.get(k, None if k == "payload_kg" else "") for k in IDENTITY}

    def set_identity(self, robot_id: int, identity: dict) -> RobotRecord:
        """Change a robot's identity (a new controller software, tool or payload): the jobs
        made before keep the identity they were made with."""
        self.robot(robot_id)
        fields = {k: v for k, v in self._identity(identity).items() if k in identity}
        if fields:
            cols = ", ".join(f"{k} = ?" for k in fields)
            with self.db.tx() as db:
                db.execute(f"UPDATE robots SET {cols} WHERE id = ?", (*fields.values(), robot_id))
        return self.robot(robot_id)

    def robot(self, robot_id: int) -> RobotRecord:
        return RobotRecord.model_validate(_row(self.db.row(
            "SELECT * FROM robots WHERE id = ?", (robot_id,)), f"robot {robot_id}"))

    def robot_named(self, name: str) -> RobotRecord:
        return RobotRecord.model_validate(_row(self.db.row(
            "SELECT * FROM robots WHERE name = ?", (name,)), f"robot named {name!r}"))

    def robots(self) -> list[RobotRecord]:
        return [RobotRecord.model_validate(_row(r, "robot"))
                for r in self.db.rows("SELECT * FROM robots ORDER BY id")]

    # -- jobs ----------------------------------------------------------------------------------
    def add_job(self, robot_id: int, kind: str, mode: str, options: dict) -> JobRecord:
        """A new queued job, held by this service; ConflictError when the robot has an
        unfinished job (the database's unique index decides, in the inserting transaction: no
        race between services)."""
        identity = self.robot(robot_id).model_dump(include=set(IDENTITY))
        now = time.time()
        try:
            with self.db.tx() as db:
                jid = db.execute(
                    "INSERT INTO jobs (robot_id, kind, mode, state, reason, options, phases, "
                    "created, updated, holder, lease_expires, software, robot_identity) VALUES "
                    f"(?, ?, ?, ?, '', ?, '{{}}', ?, ?, ?, {self.db.now_sql} + ?, ?, ?) "
                    "RETURNING id",
                    (robot_id, kind, mode, JobState.QUEUED.value, json.dumps(options), now, now,
                     self.holder,
                     self.lease_s, f"screwcal {__version__}", json.dumps(identity))
                ).fetchone()["id"]
        except self.db.integrity_errors:
            busy = self.unfinished_job(robot_id)
            raise ConflictError(f"robot {robot_id} is busy with job {busy}: wait for it to end "
                                f"or abort it (screwcal job abort {busy})") from None
        return self.job(int(jid))

    def unfinished_job(self, robot_id: int) -> int | None:
        row = self.db.row(
            f"SELECT id FROM jobs WHERE robot_id = ? AND state IN {_UNFINISHED_SQL}",
            (robot_id,))
        return None if row is None else int(row["id"])

    def unfinished_jobs(self) -> list[int]:
        """The ids of every unfinished job, oldest first."""
        return [int(r["id"]) for r in self.db.rows(
            f"SELECT id FROM jobs WHERE state IN {_UNFINISHED_SQL} ORDER BY id")]

    # -- leases --------------------------------------------------------------------------------
    def take(self, job_id: int) -> bool:
        """Hold this unfinished job when nobody does or its holder's lease has expired (or it
        is ours already): True when this service holds it now."""
        with self.db.tx() as db:
            cur = db.execute(
                f"UPDATE jobs SET holder = ?, lease_expires = {self.db.now_sql} + ? "
                f"WHERE id = ? AND state IN {_UNFINISHED_SQL} AND (holder IS NULL OR "
                f"holder = ? OR lease_expires < {self.db.now_sql})",
                (self.holder, self.lease_s, job_id, self.holder))
            return bool(cur.rowcount)

    def renew(self) -> set[int]:
        """Extend the leases of every unfinished job this service holds; their ids (a job
        missing from them is held by another service now, or ended)."""
        with self.db.tx() as db:
            rows = db.execute(
                f"UPDATE jobs SET lease_expires = {self.db.now_sql} + ? WHERE holder = ? AND "
                f"state IN {_UNFINISHED_SQL} RETURNING id", (self.lease_s, self.holder)
            ).fetchall()
        return {int(r["id"]) for r in rows}

    def release(self) -> None:
        """Let go of every job this service holds (a clean stop: another service may adopt
        them at once instead of after the lease)."""
        with self.db.tx() as db:  # a finished job keeps its holder: the service that ran it
            db.execute("UPDATE jobs SET holder = NULL, lease_expires = NULL WHERE holder = ? "
                       f"AND state IN {_UNFINISHED_SQL}", (self.holder,))

    def adoptable(self) -> list[int]:
        """The unfinished jobs nobody holds: no holder, or the holder's lease expired."""
        return [int(r["id"]) for r in self.db.rows(
            f"SELECT id FROM jobs WHERE state IN {_UNFINISHED_SQL} AND (holder IS NULL OR "
            f"lease_expires < {self.db.now_sql}) ORDER BY id")]

    def held_elsewhere(self, job_ids: list[int]) -> set[int]:
        """Of these unfinished jobs, those this service no longer holds."""
        if not job_ids:
            return set()
        marks = ", ".join("?" * len(job_ids))
        return {int(r["id"]) for r in self.db.rows(
            f"SELECT id FROM jobs WHERE id IN ({marks}) AND state IN {_UNFINISHED_SQL} AND "
            "(holder IS NULL OR holder <> ?)", (*job_ids, self.holder))}

    def lease_of(self, job_id: int) -> tuple[str | None, float]:
        """Who holds the job and for how many more seconds (negative: expired)."""
        row = _row(self.db.row(
            f"SELECT holder, lease_expires - {self.db.now_sql} AS left_s FROM jobs WHERE id = ?",
            (job_id,)), f"job {job_id}")
        return row["holder"], float(row["left_s"] if row["left_s"] is not None else -1.0)

    def _check_held(self, db: Database, job_id: int) -> str:
        """Inside a transaction: the job's state, locked for update; LeaseLostError when another
        service holds it, ConflictError when it has ended."""
        row = db.execute(f"SELECT state, holder, phases FROM jobs WHERE id = ?"
                         f"{self.db.for_update}", (job_id,)).fetchone()
        if row is None:
            raise NotFoundError(f"no such job {job_id}")
        if row["holder"] != self.holder:
            raise LeaseLostError(f"job {job_id} is held by the service {row['holder']} now, not "
                                 f"this one ({self.holder}): this runner is stale and changes "
                                 "nothing")
        return row["phases"]

    def claim_step(self, job_id: int, step: str) -> dict[str, PhaseRecord]:
        """Mark `step` started, in one transaction that re-reads the job's phases: returns the
        phases as they were before (a runner decides from these, never from its own copy).
        ConflictError when the job is no longer unfinished (another runner ended it) or another
        service holds it."""
        with self.db.tx() as db:
            row = db.execute(f"SELECT state FROM jobs WHERE id = ?{self.db.for_update}",
                             (job_id,)).fetchone()
            if row is None:
                raise NotFoundError(f"no such job {job_id}")
            if JobState(row["state"]).finished:
                raise ConflictError(f"job {job_id} is {row['state']}: this runner is stale")
            phases = json.loads(self._check_held(db, job_id))
            if not phases.get(step, {}).get("done"):
                new = {**phases, step: {**phases.get(step, {}), "started": True}}
                db.execute("UPDATE jobs SET phases = ?, updated = ? WHERE id = ?",
                           (json.dumps(new), time.time(), job_id))
        return {k: PhaseRecord.model_validate(v) for k, v in phases.items()}

    def job(self, job_id: int) -> JobRecord:
        return JobRecord.model_validate(_row(self.db.row(
            "SELECT * FROM jobs WHERE id = ?", (job_id,)), f"job {job_id}"))

    def robot_jobs(self, robot_id: int) -> list[tuple[JobRecord, dict[str, Any]]]:
        """A robot's jobs, oldest first, each with its provenance as stored (software,
        robot_identity, holder: the service that ran it last) and its poses per phase."""
        poses: dict[int, dict[str, int]] = {}
        for r in self.db.rows(
                "SELECT m.job_id, m.phase, count(*) AS n FROM measurements m JOIN jobs j ON "
                "j.id = m.job_id WHERE j.robot_id = ? GROUP BY m.job_id, m.phase", (robot_id,)):
            poses.setdefault(int(r["job_id"]), {})[r["phase"]] = int(r["n"])
        out = []
        for r in self.db.rows("SELECT * FROM jobs WHERE robot_id = ? ORDER BY id", (robot_id,)):
            row = _row(r, "job")
            extra = {"software": row["software"], "robot_identity": row["robot_identity"],
                     "service": row["holder"], "poses": poses.get(int(row["id"]), {})}
            out.append((JobRecord.model_validate(row), extra))
        return out

    def jobs(self) -> list[JobRecord]:
        return [JobRecord.model_validate(_row(r, "job"))
                for r in self.db.rows("SELECT * FROM jobs ORDER BY id")]

    def set_result(self, job_id: int, result: ResultDocument) -> JobRecord:
        """Store the job's result document (the sections set in it), only while this service
        holds the job."""
        with self.db.tx() as db:
            self._check_held(db, job_id)
            db.execute("UPDATE jobs SET result = ?, updated = ? WHERE id = ?",
                       (json.dumps(result.document()), time.time(), job_id))
        return self.job(job_id)

    def fail(self, job_id: int, reason: str) -> None:
        """A job that cannot run (its records cannot make a runner), only while this service
        holds it."""
        self.set_state(job_id, JobState.FAILED, reason)

    def set_state(self, job_id: int, state: JobState | str, reason: str) -> JobRecord:
        """A runner's state change, only while this service holds the job and along the table
        of service/job_state.py: JobStateError when another runner (or service) has ended it,
        so a stale runner never revives a finished job."""
        for attempt in range(3):  # the audit's link taken by another service: once more
            try:
                with self.db.tx() as db:
                    self._check_held(db, job_id)
                    old = db.execute(f"SELECT state FROM jobs WHERE id = ?{self.db.for_update}",
                                     (job_id,)).fetchone()["state"]
                    new = check_transition(job_id, old, state)
                    db.execute("UPDATE jobs SET state = ?, reason = ?, updated = ? WHERE id = ?",
                               (new.value, reason, time.time(), job_id))
                    record(db, Event(f"service {self.holder}", "the service", "job state",
                                     f"job {job_id}", f"{old} -> {new.value}", reason))
                break
            except self.db.integrity_errors:
                if attempt == 2:
                    raise
        return self.job(job_id)

    def finish_step(self, job_id: int, step: str, seconds: float) -> None:
        """Mark `step` done, merged into the phases as stored now."""
        with self.db.tx() as db:
            phases = {**json.loads(self._check_held(db, job_id)),
                      step: {"done": True, "seconds": seconds}}
            db.execute("UPDATE jobs SET phases = ?, updated = ? WHERE id = ?",
                       (json.dumps(phases), time.time(), job_id))

    def add_confirmation(self, job_id: int, phase: str, idx: int, operator: str) -> None:
        """An operator's go-ahead for a pose of a job (a ZERO's included), kept as provenance."""
        with self.db.tx() as db:
            db.execute("INSERT INTO confirmations (job_id, phase, idx, operator, at) VALUES "
                       "(?, ?, ?, ?, ?)", (job_id, phase, idx, operator, time.time()))

    def confirmations(self, job_id: int) -> list[dict]:
        return self.db.rows("SELECT phase, idx, operator, at FROM confirmations WHERE job_id = ? "
                            "ORDER BY id", (job_id,))

    # -- measurements ----------------------------------------------------------------------------
    def add_measurement(self, job_id: int, phase: str, idx: int, joints_deg: list,
                        tool0: list, holes_mm: list, flange_pose: list,
                        covariance_mm2: list | None = None, conditions: dict | None = None,
                        measured_at: float | None = None) -> None:
        """Commit one pose (its own transaction), renewing the job's lease: LeaseLostError when
        another service holds the job (the robot must not be moved on), an integrity error when
        the pose is stored already. `holes_mm`: the points the instrument measured (the arm's
        holes, the SMRs, ...), `flange_pose` the tool0 pose from three of them (empty: one
        point, positions only); what the instrument said beside: each point's covariance,
        the conditions, when it measured."""
        with self.db.tx() as db:
            self._check_held(db, job_id)
            db.execute(f"UPDATE jobs SET lease_expires = {self.db.now_sql} + ? WHERE id = ?",
                       (self.lease_s, job_id))
            db.execute(
                "INSERT INTO measurements (job_id, phase, idx, joints_deg, tool0, holes_mm, "
                "flange_pose, created, covariance_mm2, conditions, measured_at) VALUES "
                "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (job_id, phase, idx, json.dumps(joints_deg), json.dumps(tool0),
                 json.dumps(holes_mm), json.dumps(flange_pose), time.time(),
                 None if covariance_mm2 is None else json.dumps(covariance_mm2),
                 None if conditions is None else json.dumps(conditions), measured_at))

    def measurements(self, job_id: int, phase: str | None = None) -> list[dict]:
        sql = "SELECT * FROM measurements WHERE job_id = ?"
        args: tuple = (job_id,)
        if phase is not None:
            sql += " AND phase = ?"
            args += (phase,)
        return [_row(r, "measurement") for r in self.db.rows(sql + " ORDER BY phase, idx", args)]

    def last_measurement(self, job_id: int) -> dict | None:
        """The pose this job committed last (in any phase), or None."""
        row = self.db.row("SELECT * FROM measurements WHERE job_id = ? ORDER BY id DESC LIMIT 1",
                          (job_id,))
        return None if row is None else _row(row, "measurement")

    def measured_indices(self, job_id: int, phase: str) -> set[int]:
        return {int(r["idx"]) for r in self.db.rows(
            "SELECT idx FROM measurements WHERE job_id = ? AND phase = ?", (job_id, phase))}

    def phase_progress(self, job_id: int, phase: str) -> tuple[int, float | None, int]:
        """Of `phase`: the poses committed, when its last one was (s, time.time()), and how
        many poses of the job's other phases were committed after it (all of them when none)."""
        row = self.db.row("SELECT count(*) AS n, max(created) AS at, max(id) AS last FROM "
                          "measurements WHERE job_id = ? AND phase = ?", (job_id, phase)) or {}
        since = self.db.row("SELECT count(*) AS n FROM measurements WHERE job_id = ? AND "
                            "phase <> ? AND id > ?", (job_id, phase, row.get("last") or 0)) or {}
        at = row.get("at")
        return int(row.get("n") or 0), None if at is None else float(at), int(since.get("n") or 0)
