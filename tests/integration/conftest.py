"""Service, client and emulators together: the emulators in-process on port 0 (tests may wire
them; the service itself never imports them), the service through httpx's ASGI transport."""

from __future__ import annotations

import asyncio
import contextlib
import sqlite3

import httpx
import pytest

from service.app import create_app
from service.settings import ServiceSettings
from simulators.arm import ArmEmulator
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.realism import IDEAL, Realism
from simulators.truth import make_world

TOKEN = "test-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
ARM_POSITION = (500.0, 0.0, 600.0)
FAST = {"calibration_poses": 30, "cycles": 2, "cube_edge_mm": 250.0,
        "arm_position_mm": ARM_POSITION}


class Rig:
    """A robot cell: the IRC5 and arm emulators around one true robot."""

    def __init__(self, emu: IRC5Emulator, arm: ArmEmulator):
        self.emu, self.arm = emu, arm

    async def restart_controller(self) -> None:
        host, port = self.address
        await self.emu.stop()
        await self.emu.start(host, port)

    @property
    def address(self) -> tuple[str, int]:
        return self.emu.address

    @property
    def world(self):
        """The true robot both emulators serve (simulators/truth.py), its observers too."""
        return self.emu.world


async def start_rig(time_scale: float = 0.0, realism: Realism = IDEAL, seed: int | None = None
                    ) -> Rig:
    """An emulated cell on free ports (stop it with stop_rig): the Table 11 robot, or the robot
    of `seed`, with its `realism` (simulators/realism.py)."""
    world = make_world(None, seed, realism=realism)
    emu = IRC5Emulator(world, EmulatorSettings(time_scale=time_scale))
    emu.address = await emu.start("127.0.0.1", 0)
    arm = ArmEmulator(world, seed=7 if seed is None else seed)
    host, port = await arm.start("127.0.0.1", 0)
    arm.url = f"socket://{host}:{port}"
    return Rig(emu, arm)


async def stop_rig(rig: Rig) -> None:
    await rig.arm.stop()
    with contextlib.suppress(Exception):
        await rig.emu.stop()


@pytest.fixture
async def rig():
    cell = await start_rig()
    yield cell
    await stop_rig(cell)


@contextlib.asynccontextmanager
async def serving(db_path, **settings):
    """The service on a database, its client through ASGI; `settings`: other values than the
    tests' (a 3 s wait for the arm's holes, 10 s for a pose)."""
    app = create_app(ServiceSettings(**{"db_path": db_path, "token": TOKEN,
                                        "reconnect_interval_s": 0.05, "arm_timeout_s": 3.0,
                                        "pose_timeout_s": 10.0, **settings}))
    async with app.router.lifespan_context(app):
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=app),
                                     base_url="http://service", headers=AUTH) as http:
            yield http


@pytest.fixture
async def service(tmp_path):
    async with serving(tmp_path / "jobs.db") as http:
        yield http


async def finished(http, job_id: int, timeout_s: float = 300.0) -> dict:
    """The job once it has ended (done, failed or aborted)."""
    async with asyncio.timeout(timeout_s):
        while True:
            job = (await http.get(f"/jobs/{job_id}")).json()
            if job["state"] in ("done", "failed", "aborted"):
                return job
            await asyncio.sleep(0.2)


async def add_robot(http, rig, **record) -> int:
    """The rig's robot added to the service; `record`: more fields of its record."""
    host, port = rig.address
    r = await http.post("/robots", headers=AUTH, json={
        "name": "IRB 1600 (emulated)", "controller_host": host, "controller_port": port,
        "arm_url": rig.arm.url, **record})
    assert r.status_code == 201, r.text
    return r.json()["id"]


def peek(db_target, sql: str, args: tuple = ()) -> list[tuple]:
    """Rows read straight from a service's database (SQLite file or PostgreSQL URL) while the
    service runs, beside it (a Store would take the SQLite owner lock); `?` placeholders."""
    if isinstance(db_target, str) and db_target.startswith("postgresql://"):
        import psycopg

        with psycopg.connect(db_target) as con:
            return [tuple(r) for r in con.execute(sql.replace("?", "%s"), args).fetchall()]
    con = sqlite3.connect(db_target)
    try:
        return [tuple(r) for r in con.execute(sql, args).fetchall()]
    finally:
        con.close()
