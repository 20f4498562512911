"""A real PostgreSQL server for the tests: initdb and pg_ctl in a temporary folder, listening on
a private Unix socket only (no TCP port), run as an unprivileged user when the tests run as root
(PostgreSQL refuses root; CI runs as root). Each test gets a fresh database on it.

The server lives no longer than the process that made it. pg_ctl detaches the postmaster (its
own session), so a test run killed (SIGKILL, a CI timeout) left it running with its folder; now
a watchdog, this file run as a script in a session of its own (Ctrl-C does not reach it), holds
the read end of a pipe whose write end only the owner has. The kernel closes that end when the
owner ends, however it ends; the watchdog then stops the server and removes the folder.
"""

from __future__ import annotations

import glob
import itertools
import json
import os
import pwd
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

INSTALL = "apt-get install -y postgresql"
_BINARIES = ("initdb", "pg_ctl", "postgres")
_counter = itertools.count()


def find_bin_dir() -> Path | None:
    """Where initdb, pg_ctl and postgres are: on PATH, else Debian's /usr/lib/postgresql/N/bin."""
    on_path = [shutil.which(b) for b in _BINARIES]
    if all(on_path):
        return Path(on_path[0]).parent  # type: ignore[arg-type]
    for d in sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True):
        if all((Path(d) / b).is_file() for b in _BINARIES):
            return Path(d)
    return None


class PostgresServer:
    def __init__(self, bin_dir: Path):
        self.bin_dir = bin_dir
        self.folder = Path(tempfile.mkdtemp(prefix="screwcal-pg-"))
        self.data = self.folder / "data"
        self.socket_dir = self.folder / "socket"
        self.socket_dir.mkdir()
        self.user: str | None = None
        if os.geteuid() == 0:  # PostgreSQL will not run as root: as nobody, in its own folder
            self.user = "nobody"
            entry = pwd.getpwnam(self.user)
            os.chmod(self.folder, 0o755)
            for p in (self.folder, self.socket_dir):
                os.chown(p, entry.pw_uid, entry.pw_gid)
        # before anything runs: whatever happens next, the server and the folder go with us
        self._watchdog = subprocess.Popen(
            [sys.executable, "-I", __file__, json.dumps(self._stop_command()), str(self.folder)],
            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True)

    def _stop_command(self) -> list[str]:
        """pg_ctl's immediate stop (every connection cut), as the server's user."""
        return self._command("pg_ctl", "-D", str(self.data), "-m", "immediate", "-w", "stop")

    def _command(self, *args: str) -> list[str]:
        cmd = [str(self.bin_dir / args[0]), *args[1:]]
        if self.user is not None:
            cmd = ["runuser", "-u", self.user, "--", *cmd]
        return cmd

    def _run(self, *args: str) -> None:
        self._done(self._command(*args))

    def _done(self, cmd: list[str]) -> None:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=120,
                              cwd=self.folder)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed: {done.stdout}{done.stderr}")

    def start(self) -> None:
        self._run("initdb", "-D", str(self.data), "-A", "trust", "-U", "screwcal", "-N",
                  "-E", "UTF8", "--locale=C")
        self.resume()

    def resume(self) -> None:
        """Start the server on its data (again, after `halt`), on the same socket."""
        self._run("pg_ctl", "-D", str(self.data), "-l", str(self.folder / "log"), "-w",
                  "-t", "60", "-o",
                  f"-k {self.socket_dir} -c listen_addresses='' -c max_connections=200 "
                  "-c fsync=off -c full_page_writes=off", "start")

    def halt(self) -> None:
        """Stop the server as a crash would (every connection cut), keeping its data."""
        self._done(self._stop_command())

    def stop(self) -> None:
        """Stop the server and remove its folder: the watchdog's work, told by the pipe's end."""
        assert self._watchdog.stdin is not None
        self._watchdog.stdin.close()
        if self._watchdog.wait(timeout=120) != 0:
            raise RuntimeError(f"the PostgreSQL server in {self.folder} did not stop")

    def url(self, dbname: str = "postgres") -> str:
        return f"postgresql://screwcal@/{dbname}?host={self.socket_dir}"

    def new_database(self) -> str:
        """A fresh, empty database on this server: its URL."""
        import psycopg

        name = f"t{os.getpid()}_{next(_counter)}"
        with psycopg.connect(self.url(), autocommit=True) as con:
            con.execute(f"CREATE DATABASE {name}")
        return self.url(name)


def _watch(stop: list[str], folder: Path) -> int:
    """The watchdog: wait for the owner's end of the pipe to close (its stop(), or its death),
    then stop the server (if it runs) and remove its folder. 0 when nothing is left."""
    sys.stdin.buffer.read()
    running = (folder / "data" / "postmaster.pid").exists()
    done = subprocess.run(stop, capture_output=True, timeout=120, cwd="/") if running else None
    shutil.rmtree(folder, ignore_errors=True)
    return 1 if (done is not None and done.returncode != 0) or folder.exists() else 0


if __name__ == "__main__":
    sys.exit(_watch(json.loads(sys.argv[1]), Path(sys.argv[2])))
