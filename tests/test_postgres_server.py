"""The tests' PostgreSQL server (tests/postgres_server.py) lives no longer than the process that
started it: a test run killed outright (SIGKILL, a CI timeout) left the postmaster running in
its folder under /tmp, detached by pg_ctl, for good."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.postgres_server import INSTALL, PostgresServer, find_bin_dir

ROOT = Path(__file__).resolve().parents[1]
# A test run in miniature: it starts a server, says where, and waits to be killed
OWNER = """
import sys
from pathlib import Path
from tests.postgres_server import PostgresServer
server = PostgresServer(Path(sys.argv[1]))
server.start()
print(server.folder, flush=True)
sys.stdin.read()
"""


@pytest.fixture
def bin_dir() -> Path:
    found = find_bin_dir()
    if found is None:
        pytest.skip(f"no PostgreSQL server (initdb, pg_ctl, postgres): install it with "
                    f"`{INSTALL}`")
    return found


def _running(pid: int) -> bool:
    """Whether the process runs (a zombie no parent has reaped yet does not)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _postmaster(folder: Path) -> int:
    pid = int((folder / "data" / "postmaster.pid").read_text().split()[0])
    assert _running(pid)
    return pid


def _gone(pid: int, folder: Path, timeout_s: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while _running(pid) or folder.exists():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def test_a_killed_test_run_takes_its_server_and_folder_with_it(bin_dir):
    owner = subprocess.Popen([sys.executable, "-c", OWNER, str(bin_dir)], cwd=ROOT,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        assert owner.stdout is not None
        line = owner.stdout.readline().strip()
        assert line, owner.communicate(timeout=60)[1]
        folder = Path(line)
        pid = _postmaster(folder)
    finally:
        owner.kill()  # as a CI timeout would: no fixture's teardown, no atexit
        owner.communicate(timeout=60)
    assert _gone(pid, folder), f"postmaster {pid} or {folder} outlived the killed test run"


def test_stop_removes_the_server_and_its_folder_halted_or_not(bin_dir):
    for halted in (False, True):
        server = PostgresServer(bin_dir)
        server.start()
        pid = _postmaster(server.folder)
        if halted:
            server.halt()  # as the store's fault tests leave it
            assert not _running(pid)
        server.stop()
        assert _gone(pid, server.folder, timeout_s=0)
