"""The job store's schema, as its history: numbered migrations, each written once for SQLite and
PostgreSQL ({pk}, {int} and {real} are the column types of the database it runs on:
service/database.py). A database records the last one it ran; a newer release adds the next and
never edits one that was released, so a database written by this version opens in the next.
"""

SCHEMA_VERSION = 8
# Each migration is written once for both databases: {pk}, {int} and {real} are the column
# types of the database it runs on (service/database.py). Never edit one that was released:
# add the next.
MIGRATIONS = {
    1: """
    CREATE TABLE robots (
        id {pk}, name TEXT NOT NULL, controller_host TEXT NOT NULL,
        controller_port {int} NOT NULL, arm_url TEXT NOT NULL, model TEXT NOT NULL,
        holes_mm TEXT NOT NULL, created {real} NOT NULL);
    CREATE TABLE jobs (
        id {pk}, robot_id {int} NOT NULL REFERENCES robots(id),
        kind TEXT NOT NULL, mode TEXT NOT NULL, state TEXT NOT NULL, reason TEXT NOT NULL,
        options TEXT NOT NULL, phases TEXT NOT NULL, result TEXT, created {real} NOT NULL,
        updated {real} NOT NULL);
    CREATE TABLE measurements (
        id {pk}, job_id {int} NOT NULL REFERENCES jobs(id),
        phase TEXT NOT NULL, idx {int} NOT NULL, joints_deg TEXT NOT NULL,
        tool0 TEXT NOT NULL, holes_mm TEXT NOT NULL, flange_pose TEXT NOT NULL,
        created {real} NOT NULL, UNIQUE (job_id, phase, idx));
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
    # Version 3: the lease of a job (several services on one database). The jobs of an older
    # database have no holder: the first service to open it takes them.
    3: """
    ALTER TABLE jobs ADD COLUMN holder TEXT;
    ALTER TABLE jobs ADD COLUMN lease_expires {real};
    """,
    # Version 4: a robot's identity (serial number, controller software, tool, payload), and
    # each job's provenance: the software that ran it, the robot's identity when it was made.
    4: """
    ALTER TABLE robots ADD COLUMN serial TEXT NOT NULL DEFAULT '';
    ALTER TABLE robots ADD COLUMN controller_software TEXT NOT NULL DEFAULT '';
    ALTER TABLE robots ADD COLUMN tool TEXT NOT NULL DEFAULT '';
    ALTER TABLE robots ADD COLUMN payload_kg {real};
    ALTER TABLE jobs ADD COLUMN software TEXT NOT NULL DEFAULT '';
    ALTER TABLE jobs ADD COLUMN robot_identity TEXT;
    """,
    # Version 5: who gave which go-ahead, when (a ZERO applied: who confirmed it).
    5: """
    CREATE TABLE confirmations (
        id {pk}, job_id {int} NOT NULL REFERENCES jobs(id), phase TEXT NOT NULL,
        idx {int} NOT NULL, operator TEXT NOT NULL, at {real} NOT NULL);
    """,
    # Version 6: what an emulated robot carries (its realism, one line per effect, JSON); an
    # empty list for a real robot and for the robots of older databases.
    6: """
    ALTER TABLE robots ADD COLUMN emulation TEXT NOT NULL DEFAULT '[]';
    """,
    # Version 7: people (users with a role, their tokens kept as digests) and the audit trail,
    # each record chained to the one before by its hash (service/audit.py).
    7: """
    CREATE TABLE users (
        id {pk}, name TEXT NOT NULL UNIQUE, role TEXT NOT NULL, password_hash TEXT NOT NULL,
        created {real} NOT NULL, disabled {int} NOT NULL DEFAULT 0);
    CREATE TABLE api_tokens (
        id {pk}, user_id {int} NOT NULL REFERENCES users(id), label TEXT NOT NULL,
        digest TEXT NOT NULL UNIQUE, created {real} NOT NULL, expires {real} NOT NULL,
        revoked {int} NOT NULL DEFAULT 0);
    CREATE TABLE audit (
        id {pk}, at {real} NOT NULL, actor TEXT NOT NULL, source TEXT NOT NULL,
        action TEXT NOT NULL, target TEXT NOT NULL, outcome TEXT NOT NULL, detail TEXT NOT NULL,
        prev TEXT NOT NULL UNIQUE, hash TEXT NOT NULL);
    CREATE TABLE audit_head (
        one {int} PRIMARY KEY CHECK (one = 1), last_id {int} NOT NULL, last_hash TEXT NOT NULL);
    INSERT INTO audit_head (one, last_id, last_hash) VALUES
        (1, 0, '0000000000000000000000000000000000000000000000000000000000000000');
    """,
    # Version 8: the instrument of a robot (JSON, service/robot_record.py: arm, tracker or
    # external; NULL for the robots of older databases, whose arm_url names their arm), and of a
    # measurement what the instrument said beside the points (holes_mm): their covariance
    # (mm^2, one 3x3 per point), the conditions (temperature, pressure, humidity) and when it
    # measured; NULL where it did not say (the arm, older rows).
    8: """
    ALTER TABLE robots ADD COLUMN instrument TEXT;
    ALTER TABLE measurements ADD COLUMN covariance_mm2 TEXT;
    ALTER TABLE measurements ADD COLUMN conditions TEXT;
    ALTER TABLE measurements ADD COLUMN measured_at {real};
    """,
}
