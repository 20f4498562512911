"""A measuring-arm emulator (thesis 4.1: FARO arm, 1200 mm reach, 0.013 mm): it probes the three
flange holes of the true robot each time the robot arrives at a pose (or when a client sends a
line such as `MEASURE`), and streams them as `$PT` lines over TCP (open it as
`socket://host:port`) and over a pty (a real serial device path). Holes beyond the reach are not
measured: the stream says so with a `$NM` line.

A real arm line is not that kind: `ArmFaults` makes the emulator send some triples twice (the copy
0.12 s later), some late, and some stale (a fresh probe of a pose the robot has left, sent at a
random moment later, e.g. between the next go-ahead and the arrival), each at random from a seed.

The robot's state comes from a `HoleSource`: the shared `World` in one process, or the world
file that `screwcal emulator irc5 --world FILE` keeps up to date, from another.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np

from protocol.arm import HOLE_LABELS, encode_not_measured, encode_point
from screwcal.instrument import POSITION_NOISE_MM
from screwcal.instrument import REACH_MM as INSTRUMENT_REACH_MM
from screwcal.kinematics.se3 import Array
from simulators.world import World

REACH_MM = INSTRUMENT_REACH_MM
NOISE_MM = POSITION_NOISE_MM


@dataclass(frozen=True)
class ArmFaults:
    """What a careless arm line does, each with its probability per arrival (0: never)."""

    duplicate: float = 0.0  # the triple sent again, same numbers, new SEQs, `duplicate_s` later
    late: float = 0.0  # the triple sent `late_s` after the arrival instead of at once
    stale: float = 0.0  # a fresh probe of this pose sent 0.05-`stale_s` s later (robot gone)
    duplicate_s: float = 0.12
    late_s: float = 0.4
    stale_s: float = 0.6

    def __post_init__(self) -> None:
        for name in ("duplicate", "late", "stale"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"arm fault {name}: a probability in [0, 1], "
                                 f"not {getattr(self, name)}")

    @classmethod
    def parse(cls, text: str) -> ArmFaults:
        """`duplicate=0.2,late=0.1,stale=0.1` (the CLI's form)."""
        values: dict[str, float] = {}
        for item in filter(None, (t.strip() for t in text.split(","))):
            name, _, value = item.partition("=")
            if name not in ("duplicate", "late", "stale"):
                raise ValueError(f"arm fault {name!r}: one of duplicate, late, stale")
            try:
                values[name] = float(value)
            except ValueError:
                raise ValueError(f"arm fault {name}: {value!r} is not a number") from None
        return cls(**values)


class HoleSource(Protocol):
    async def wait_arrival(self, after: int) -> int: ...

    def true_holes_mm(self) -> Array | None: ...  # None: no robot known yet


class WorldFileWriter:
    """Keeps a JSON file with the true holes up to date (for an arm emulator in another
    process); call it after every arrival."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.run = uuid.uuid4().hex  # a restarted emulator counts its arrivals from 0 again

    def __call__(self, world: World) -> None:
        doc = {"run": self.run, "arrivals": world.arrivals,
               "holes_mm": world.true_holes_mm().tolist(),
               # for a tracker emulator in another process: the SMR and what hides it
               "tool0": world.true_tool0().tolist(),
               "skeleton_mm": world.true_skeleton_mm().tolist(),
               "base": world.truth.base.tolist()}
        tmp = self.path.with_suffix(".tmp")
        tmp.write_text(json.dumps(doc))
        os.replace(tmp, self.path)


class WorldFileSource:
    """A HoleSource reading the file a `WorldFileWriter` keeps. Its arrival count only grows:
    when the irc5 emulator is restarted alone (a new run in the file, counting from 0 again),
    the new run's arrivals are added to what this arm has seen, so it never waits for a count
    the new run will not reach."""

    def __init__(self, path: str | Path, poll_s: float = 0.02):
        self.path, self.poll_s = Path(path), poll_s
        self._doc: dict = {"arrivals": 0, "holes_mm": None}
        self._run: str | None = None
        self._base = 0  # arrivals seen in earlier runs
        self._count = 0

    def _read(self) -> None:
        with contextlib.suppress(FileNotFoundError, json.JSONDecodeError):
            self._doc = json.loads(self.path.read_text())
        run = self._doc.get("run")
        if run != self._run:
            if self._run is not None:
                self._base = self._count
            self._run = run
        self._count = self._base + int(self._doc["arrivals"])

    async def wait_arrival(self, after: int) -> int:
        while True:
            self._read()
            if self._count > after:
                return self._count
            await asyncio.sleep(self.poll_s)

    def true_holes_mm(self) -> Array | None:
        self._read()
        holes = self._doc["holes_mm"]
        return None if holes is None else np.asarray(holes, dtype=float)

    def true_frames(self) -> tuple[Array, Array, Array] | None:
        """tool0 (4, 4), the robot's skeleton (n + 1, 3) and its base (4, 4), world frame;
        None: no robot yet (or a file of an older writer)."""
        self._read()
        names = ("tool0", "skeleton_mm", "base")
        if any(self._doc.get(name) is None for name in names):
            return None
        tool0, skeleton, base = (np.asarray(self._doc[name], dtype=float) for name in names)
        return tool0, skeleton, base


class ArmEmulator:
    def __init__(self, source: HoleSource, *, noise_mm: float = NOISE_MM,
                 reach_mm: float = REACH_MM, seed: int | None = None,
                 faults: ArmFaults | None = None):
        self.source = source
        self.faults = faults or ArmFaults()
        self.fault_rng = np.random.default_rng(None if seed is None else seed + 1)
        self.sent_faults: dict[str, int] = {"duplicate": 0, "late": 0, "stale": 0}
        self.noise_mm, self.reach_mm = noise_mm, reach_mm
        self.rng = np.random.default_rng(seed)
        self._clients: dict[asyncio.StreamWriter, int] = {}  # writer -> last SEQ sent
        self._pty_seq = 0
        self._pty_master: int | None = None
        self.pty_path: str | None = None
        self._server: asyncio.base_events.Server | None = None
        self._watch: asyncio.Task[None] | None = None

    def probe(self) -> list[tuple[str, Array | None]]:
        """The three holes as the arm sees them now: noisy points, or None out of reach."""
        holes = self.source.true_holes_mm()
        if holes is None:
            return [(label, None) for label in HOLE_LABELS]
        out: list[tuple[str, Array | None]] = []
        for label, p in zip(HOLE_LABELS, holes, strict=True):
            if np.linalg.norm(p) > self.reach_mm:
                out.append((label, None))
            else:
                out.append((label, p + self.rng.normal(0.0, self.noise_mm, 3)))
        return out

    def lines(self, probe: list[tuple[str, Array | None]], first_seq: int) -> bytes:
        reason = ""  # asked of the source only for a hole not measured
        out = b""
        for k, (label, p) in enumerate(probe):
            seq = first_seq + k
            if p is None and not reason:
                reason = "OUT_OF_REACH" if self.source.true_holes_mm() is not None \
                    else "NO_ROBOT"
            out += encode_not_measured(seq, label, reason) if p is None else \
                encode_point(seq, label, [float(v) for v in p])
        return out

    # -- serving -----------------------------------------------------------------------------
    async def start(self, host: str = "127.0.0.1", port: int = 0, pty: bool = False
                    ) -> tuple[str, int]:
        self._server = await asyncio.start_server(self.serve, host, port, limit=1024)
        if pty:
            master, slave = os.openpty()
            os.set_blocking(master, False)
            self._pty_master, self.pty_path = master, os.ttyname(slave)
            asyncio.get_running_loop().add_reader(master, self._pty_request)
        self._watch = asyncio.create_task(self._follow())
        addr = self._server.sockets[0].getsockname()
        return addr[0], addr[1]

    async def stop(self) -> None:
        if self._watch is not None:
            self._watch.cancel()
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()
        if self._pty_master is not None:
            asyncio.get_running_loop().remove_reader(self._pty_master)
            os.close(self._pty_master)
            self._pty_master = None  # a fault's copy due later must not write to a reused fd

    async def _follow(self) -> None:
        """Probe and stream every time the robot arrives somewhere."""
        seen = 0
        loop = asyncio.get_running_loop()
        f = self.faults
        while True:
            seen = await self.source.wait_arrival(seen)
            probe = self.probe()
            draw = self.fault_rng.random(4)
            delay = f.late_s if draw[0] < f.late else 0.0
            self.sent_faults["late"] += bool(delay)
            loop.call_later(delay, self._broadcast, probe)
            if draw[1] < f.duplicate:  # the very same numbers again
                self.sent_faults["duplicate"] += 1
                loop.call_later(delay + f.duplicate_s, self._broadcast, probe)
            if draw[2] < f.stale:  # this pose probed again once the robot may have left
                self.sent_faults["stale"] += 1
                stale = self.probe()
                loop.call_later(delay + 0.05 + draw[3] * (f.stale_s - 0.05),
                                self._broadcast, stale)

    def _broadcast(self, probe: list[tuple[str, Array | None]]) -> None:
        for writer in list(self._clients):
            if not writer.is_closing():
                self._send(writer, probe)
        self._send_pty(probe)

    def _send(self, writer: asyncio.StreamWriter, probe: list[tuple[str, Array | None]]) -> None:
        first = self._clients[writer] + 1
        self._clients[writer] = first + len(probe) - 1
        with contextlib.suppress(ConnectionError):
            writer.write(self.lines(probe, first))

    def _send_pty(self, probe: list[tuple[str, Array | None]]) -> None:
        if self._pty_master is None:
            return
        data = self.lines(probe, self._pty_seq + 1)
        self._pty_seq += len(probe)
        with contextlib.suppress(BlockingIOError, OSError):
            os.write(self._pty_master, data)

    def _pty_request(self) -> None:
        if self._pty_master is None:  # closed: the reader is removed with it
            return
        with contextlib.suppress(BlockingIOError, OSError):
            if b"\n" in os.read(self._pty_master, 1024):
                self._send_pty(self.probe())

    async def serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        """One client's connection (TCP from `start`, or a link in memory: protocol.memory)."""
        self._clients[writer] = 0
        try:
            while await reader.readline():  # any line asks for a probe now
                self._send(writer, self.probe())
                await writer.drain()
        except (ConnectionError, ValueError):  # gone, or a line beyond the stream's limit:
            pass  # not a request, the peer is dropped
        finally:
            self._clients.pop(writer, None)
            writer.close()
