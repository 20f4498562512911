"""A real PostgreSQL server for the tests: initdb and pg_ctl in a temporary folder, listening on
a private Unix socket only (no TCP port), run as an unprivileged user when the tests run as root
(PostgreSQL refuses root; CI runs as root). Each test gets a fresh database on it."""

from __future__ import annotations

import glob
import itertools
import os
import pwd
import shutil
import subprocess
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

    def _run(self, *args: str) -> None:
        cmd = [str(self.bin_dir / args[0]), *args[1:]]
        if self.user is not None:
            cmd = ["runuser", "-u", self.user, "--", *cmd]
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
        self._run("pg_ctl", "-D", str(self.data), "-m", "immediate", "-w", "stop")

    def stop(self) -> None:
        try:
            self._run("pg_ctl", "-D", str(self.data), "-m", "immediate", "-w", "stop")
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)

    def url(self, dbname: str = "postgres") -> str:
        return f"postgresql://screwcal@/{dbname}?host={self.socket_dir}"

    def new_database(self) -> str:
        """A fresh, empty database on this server: its URL."""
        import psycopg

        name = f"t{os.getpid()}_{next(_counter)}"
        with psycopg.connect(self.url(), autocommit=True) as con:
            con.execute(f"CREATE DATABASE {name}")
        return self.url(name)
