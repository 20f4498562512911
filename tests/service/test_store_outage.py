"""The store outlives its database's outages (service/database.py): a fault that passes is a
StoreUnavailableError naming its cause, and the next call after it works again, the connection
opened anew where it must be."""

from __future__ import annotations

import os
import sqlite3

import pytest

from service.errors import StoreUnavailableError
from service.store import Store
from tests.service.test_store import POSE, robot_and_job


def test_a_read_only_database_pauses_and_the_connection_is_opened_anew(tmp_path):
    store = Store(tmp_path / "jobs.db")
    _, job_id = robot_and_job(store)
    store.db.execute("PRAGMA query_only = ON")  # this connection may no longer write
    with pytest.raises(StoreUnavailableError, match=r"jobs\.db cannot be written.*readonly"):
        store.add_measurement(job_id, "cal", 0, *POSE)
    store.add_measurement(job_id, "cal", 0, *POSE)  # a new connection: written
    assert store.measured_indices(job_id, "cal") == {0}
    store.close()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes a read-only file all the same")
def test_a_file_made_read_only_is_written_again_once_writable(tmp_path):
    path = tmp_path / "jobs.db"
    store = Store(path)
    _, job_id = robot_and_job(store)
    os.chmod(path, 0o444)
    store.db.execute("PRAGMA query_only = ON")  # the fault that makes it open the file anew
    for _ in range(2):  # read-only as long as the file is
        with pytest.raises(StoreUnavailableError, match="cannot be written"):
            store.add_measurement(job_id, "cal", 0, *POSE)
    os.chmod(path, 0o644)
    store.add_measurement(job_id, "cal", 0, *POSE)
    assert store.measured_indices(job_id, "cal") == {0}
    store.close()


def test_a_file_size_limit_is_said_as_such(tmp_path):
    store = Store(tmp_path / "jobs.db")
    err = store.db._translate(sqlite3.OperationalError("disk I/O error"))
    assert err is None  # no code: not ours to name
    failure = sqlite3.OperationalError("disk I/O error")
    failure.sqlite_errorcode = sqlite3.SQLITE_IOERR_WRITE
    said = store.db._translate(failure)
    assert isinstance(said, StoreUnavailableError) and "file-size limit" in str(said)
    store.close()


def test_a_restarted_postgresql_server_is_reconnected_to(postgres_server):
    url = postgres_server.new_database()
    store = Store(url)
    _, job_id = robot_and_job(store)
    postgres_server.halt()
    try:
        with pytest.raises(StoreUnavailableError, match="database"):
            store.add_measurement(job_id, "cal", 0, *POSE)
        with pytest.raises(StoreUnavailableError, match="cannot reach the database"):
            store.job(job_id)
    finally:
        postgres_server.resume()
    store.add_measurement(job_id, "cal", 0, *POSE)  # the same store: reconnected
    assert store.measured_indices(job_id, "cal") == {0}
    store.close()
