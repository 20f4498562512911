"""The two databases the job store runs on, behind one small interface: SQLite (the default, one
file, one service) and PostgreSQL (several services on one database, e.g. a cell PC each).

The store writes its SQL once, in the portable subset both speak (`?` placeholders, `RETURNING`,
partial unique indexes, `FOR UPDATE` where PostgreSQL needs it); what differs lives here and
nowhere else: how a connection is opened and a transaction begun, the schema version's home
(SQLite's `PRAGMA user_version`, a one-row table on PostgreSQL), the column types a migration
creates, the database's clock (a lease's expiry is read on the database's clock, never on a
host's), and which driver errors mean "full", "lost" or "a rule was broken".

Why psycopg beside sqlite3 and not SQLAlchemy Core: the store is some twenty hand-written
statements, and what makes it safe is dialect-specific anyway (SQLite's owner flock, WAL and
`SQLITE_FULL`, PostgreSQL's `FOR UPDATE`, advisory lock and SQLSTATE 53100); an expression layer
would translate the portable statements and still leave those here, for a large dependency.

Faults that pass (StoreUnavailableError: a full disk, an I/O error such as a file-size limit, a
read-only file, a lost PostgreSQL connection) leave the database object usable: the next call
opens the connection again where it needs to (PostgreSQL: a server restarted; SQLite: a file
that was read-only), so a service outlives its database's outage without a restart.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import sqlite3
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, ClassVar

from screwcal._lazy import optional_import
from service.errors import StoreBusyError, StoreFullError, StoreLostError, StoreUnavailableError

POSTGRES_SCHEMES = ("postgresql://", "postgres://")
_MIGRATION_LOCK = 28_0528  # the advisory lock key under which PostgreSQL migrations run


def is_postgres_url(target: str | Path) -> bool:
    return isinstance(target, str) and target.startswith(POSTGRES_SCHEMES)


def redact(url: str) -> str:
    """A database URL fit for a log line: its password replaced."""
    head, sep, tail = url.partition("@")
    if not sep or ":" not in head.split("//", 1)[-1]:
        return url
    scheme, _, cred = head.partition("//")
    return f"{scheme}//{cred.split(':', 1)[0]}:***@{tail}"


class Database:
    """One connection, used by one service's threads in turn (an RLock around every use)."""

    kind: str
    types: ClassVar[dict[str, str]]  # the column types a migration names: {pk}, {int}, {real}
    now_sql: str  # the database's clock, seconds since the epoch
    for_update: str  # appended to a SELECT that a transaction will update
    integrity_errors: tuple[type[BaseException], ...]
    label: str

    def __init__(self) -> None:
        self.lock = threading.RLock()

    # -- what each database says its own way -----------------------------------------------------
    def _run(self, sql: str, args: Sequence[Any]) -> Any: ...

    def _begin(self) -> None: ...

    def _end(self, commit: bool) -> None: ...

    def _translate(self, err: Exception) -> Exception | None:
        """The store's error for a driver error, or None to let it through."""
        return None

    def check(self) -> None:
        """StoreLostError when the database can no longer be written (SQLite: its file gone)."""

    def _ensure(self) -> None:
        """Before a use, under the lock: open the connection again when a fault closed it
        (StoreUnavailableError while it cannot be)."""

    def schema_version(self) -> int:
        raise NotImplementedError

    def migrate(self, scripts: dict[int, str], target: int) -> None: ...

    def close(self) -> None: ...

    def holders_gone(self) -> bool:
        """True when no other service can hold a job of this database (SQLite's owner lock)."""
        return False

    # -- the same for both ---------------------------------------------------------------------
    def rows(self, sql: str, args: Sequence[Any] = ()) -> list[dict[str, Any]]:
        with self.lock:
            self._ensure()
            return [dict(r) for r in self._guarded(sql, args).fetchall()]

    def row(self, sql: str, args: Sequence[Any] = ()) -> dict[str, Any] | None:
        with self.lock:
            self._ensure()
            r = self._guarded(sql, args).fetchone()
        return None if r is None else dict(r)

    def execute(self, sql: str, args: Sequence[Any] = ()) -> Any:
        """A statement inside `tx()`; the driver's cursor (rowcount, fetchone)."""
        return self._guarded(sql, args)

    def _guarded(self, sql: str, args: Sequence[Any]) -> Any:
        try:
            return self._run(sql, args)
        except Exception as err:
            mapped = self._translate(err)
            if mapped is None:
                raise
            raise mapped from err

    @contextmanager
    def tx(self) -> Iterator[Database]:
        """One transaction, committed when the block ends, rolled back when it raises."""
        with self.lock:
            self._ensure()
            self.check()
            try:
                self._begin()
                try:
                    yield self
                    self._end(commit=True)
                except BaseException:
                    self._end(commit=False)
                    raise
            except Exception as err:
                mapped = self._translate(err)
                if mapped is None or mapped is err:
                    raise
                raise mapped from err


# -- SQLite ------------------------------------------------------------------------------------
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


class SQLiteDatabase(Database):
    """One file, one service (the owner flock): WAL, FULL sync (a committed measurement survives
    SIGKILL), a file deleted or replaced under the service is noticed before any write."""

    kind = "sqlite"
    types: ClassVar[dict[str, str]] = {
        "pk": "INTEGER PRIMARY KEY", "int": "INTEGER", "real": "REAL"}
    now_sql = "((julianday('now') - 2440587.5) * 86400.0)"
    for_update = ""  # BEGIN IMMEDIATE holds the one write lock already
    integrity_errors = (sqlite3.IntegrityError,)

    def __init__(self, path: Path):
        super().__init__()
        self.path = path
        self.label = str(path)
        self._owner_fd = _hold_owner_lock(path)
        self._reopen = False  # set by a fault that the connection itself may carry
        try:
            self._db = self._connect()
            self._file = _identity(path)
        except BaseException:
            os.close(self._owner_fd)
            raise

    def _connect(self) -> sqlite3.Connection:
        db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        db.row_factory = sqlite3.Row
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=FULL")
        db.execute("PRAGMA foreign_keys=ON")
        return db

    def _ensure(self) -> None:
        # a file opened while it was read-only stays read-only for that connection
        if not self._reopen:
            return
        self.check()  # the same file, not one put in its place meanwhile
        with contextlib.suppress(sqlite3.Error):
            self._db.close()
        try:
            self._db = self._connect()
        except sqlite3.Error as err:
            raise self._translate(err) or StoreUnavailableError(
                f"cannot open the database file {self.path} again (SQLite: {err})") from err
        self._reopen = False

    def _run(self, sql: str, args: Sequence[Any]) -> Any:
        return self._db.execute(sql, tuple(args))

    def _begin(self) -> None:
        self._db.execute("BEGIN IMMEDIATE")

    def _end(self, commit: bool) -> None:
        if commit:
            self._db.execute("COMMIT")
        elif self._db.in_transaction:
            # SQLite may have rolled back by itself (SQLITE_FULL): a second ROLLBACK would
            # raise "no transaction is active" and hide the real cause.
            self._db.execute("ROLLBACK")

    def _translate(self, err: Exception) -> Exception | None:
        if not isinstance(err, sqlite3.Error):
            return None
        code = getattr(err, "sqlite_errorcode", None)
        primary = None if code is None else code & 0xFF  # the extended code's family
        if primary == sqlite3.SQLITE_FULL:
            return StoreFullError(
                f"the disk holding {self.path} is full (SQLite: {err}): free space; the job "
                "goes on where it stopped")
        if primary == sqlite3.SQLITE_IOERR:
            return StoreUnavailableError(
                f"the database file {self.path} cannot be written (SQLite: {err}; a file-size "
                "limit, ulimit -f, or a failing disk): the job waits and goes on where it "
                "stopped once the file can grow again")
        if primary in (sqlite3.SQLITE_READONLY, sqlite3.SQLITE_CANTOPEN):
            self._reopen = True
            return StoreUnavailableError(
                f"the database file {self.path} cannot be written (SQLite: {err}): make it "
                "and its folder writable for the service's user; the job goes on where it "
                "stopped")
        return None

    def check(self) -> None:
        try:
            same = _identity(self.path) == self._file
        except FileNotFoundError:
            raise StoreLostError(f"the database file {self.path} was deleted while the service "
                                 "ran: nothing more can be committed; the service stops") from None
        if not same:
            raise StoreLostError(f"the database file {self.path} was replaced while the service "
                                 "ran: nothing more can be committed; the service stops")

    def schema_version(self) -> int:
        with self.lock:
            return int(self._db.execute("PRAGMA user_version").fetchone()[0])

    def migrate(self, scripts: dict[int, str], target: int) -> None:
        for v in range(self.schema_version() + 1, target + 1):
            # executescript commits by itself: the script carries its own transaction.
            with self.lock:
                self._db.executescript(f"BEGIN IMMEDIATE; {scripts[v].format(**self.types)} "
                                       f"PRAGMA user_version={v}; COMMIT;")

    def holders_gone(self) -> bool:
        return True  # this process holds the owner lock: whoever held a job before is dead

    def close(self) -> None:
        self._db.close()
        with contextlib.suppress(OSError):
            os.close(self._owner_fd)


# -- PostgreSQL --------------------------------------------------------------------------------
class PostgresDatabase(Database):
    """A server shared by several services: each holds its jobs by lease (service/store.py);
    migrations run under an advisory lock, so services starting together migrate once."""

    kind = "postgresql"
    types: ClassVar[dict[str, str]] = {
        "pk": "BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY", "int": "BIGINT",
        "real": "DOUBLE PRECISION"}
    now_sql = "extract(epoch from clock_timestamp())::double precision"
    for_update = " FOR UPDATE"

    def __init__(self, url: str):
        psycopg = optional_import("psycopg", "postgres",
                                  f"a PostgreSQL job store ({redact(url)})")
        super().__init__()
        self._psycopg = psycopg
        self._url = url
        self.integrity_errors = (psycopg.IntegrityError,)
        self.label = redact(url)
        try:
            self._db = self._open()
        except psycopg.OperationalError as err:
            raise StoreLostError(f"cannot connect to the database {self.label}: "
                                 f"{str(err).strip()}") from None
        self._tx: Any = None

    def _run(self, sql: str, args: Sequence[Any]) -> Any:
        if not args:
            return self._db.execute(sql)
        return self._db.execute(sql.replace("%", "%%").replace("?", "%s"), tuple(args))

    def _begin(self) -> None:
        self._tx = self._db.transaction()
        self._tx.__enter__()

    def _end(self, commit: bool) -> None:
        tx, self._tx = self._tx, None
        if tx is None:  # the commit itself failed: psycopg has ended the transaction
            return
        if commit:
            tx.__exit__(None, None, None)
        else:
            with contextlib.suppress(self._psycopg.Error):
                tx.__exit__(Exception, Exception("rolled back"), None)

    def _translate(self, err: Exception) -> Exception | None:
        errors = self._psycopg.errors
        if isinstance(err, errors.DiskFull):
            return StoreFullError(f"the disk of the database {self.label} is full "
                                  f"(PostgreSQL: {str(err).strip()}): free space; the job goes "
                                  "on where it stopped")
        if isinstance(err, self._psycopg.OperationalError) and \
                (self._db.closed or self._db.broken):
            return StoreUnavailableError(
                f"the connection to the database {self.label} was lost ({str(err).strip()}): "
                "the jobs wait, and go on where they stopped once it is back")
        return None

    def _ensure(self) -> None:
        if not (self._db.closed or self._db.broken):
            return
        with contextlib.suppress(self._psycopg.Error):
            self._db.close()
        self._tx = None
        try:
            self._db = self._open()
        except self._psycopg.OperationalError as err:
            raise StoreUnavailableError(
                f"cannot reach the database {self.label} ({str(err).strip()}): the jobs wait, "
                "and go on where they stopped once it is back") from None

    def _open(self) -> Any:
        dict_row = self._psycopg.rows.dict_row
        return self._psycopg.connect(self._url, autocommit=True, row_factory=dict_row,
                                     connect_timeout=10)

    def schema_version(self) -> int:
        with self.lock:
            if self._value("SELECT to_regclass('screwcal_schema') AS v") is None:
                return 0
            return int(self._value("SELECT max(version) AS v FROM screwcal_schema") or 0)

    def migrate(self, scripts: dict[int, str], target: int) -> None:
        # Services starting together: one migrates, the others wait for it on the advisory
        # lock, then find the work done (even the version table's creation races otherwise).
        with self.lock, self._db.transaction():
            self._db.execute("SELECT pg_advisory_xact_lock(%s)", (_MIGRATION_LOCK,))
            self._db.execute("CREATE TABLE IF NOT EXISTS screwcal_schema (version INTEGER NOT "
                             "NULL)")
            done = int(self._value("SELECT max(version) AS v FROM screwcal_schema") or 0)
            for v in range(done + 1, target + 1):
                self._db.execute(scripts[v].format(**self.types))  # DDL is transactional here
                self._db.execute("INSERT INTO screwcal_schema (version) VALUES (%s)", (v,))

    def _value(self, sql: str) -> Any:
        """Column `v` of a SELECT that returns one row (an aggregate's)."""
        row = self._db.execute(sql).fetchone()
        if row is None:
            raise StoreLostError(f"the database {self.label} returned no row for {sql!r}")
        return row["v"]

    def close(self) -> None:
        self._db.close()


def open_database(target: str | Path) -> Database:
    """PostgreSQL for a postgresql:// URL, else the SQLite file at this path."""
    if is_postgres_url(target):
        return PostgresDatabase(str(target))
    return SQLiteDatabase(Path(target))
