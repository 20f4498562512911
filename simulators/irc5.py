"""An ABB IRC5 emulator: the controller side of the wire protocol (docs/protocol.md)
over real TCP, around a `World`.

Like the RAPID server it stands in for (thesis 4.4, Algorithms 1-2), one client owns it at a
time: another connection gets `0 ERR 16 busy` and is closed; an owner that sends nothing for
`idle_timeout_s` (STAT counts) while the controller waits for it, or that does not read what the
controller sends within `send_timeout_s`, is dropped; it keeps listening after a client leaves.
It handles one request at a time and reads nothing while a move runs (requests wait, decoded
but unhandled, in a bounded inbox until the move ends; beyond it TCP holds the rest); it refuses
targets outside the joint limits before any motion (lists at LOAD time); it reports joints as
its encoders read them and tool0 as the NOMINAL kinematics of those joints (CRobT), rounded like
32-bit nums. Motion is a joint-space move at `speed_deg_s`, scaled by `time_scale` (0: instant).
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass, field

import numpy as np

from protocol import codec
from protocol.bounded import Mailbox
from protocol.codec import (
    ABORTED,
    BAD_ARGUMENTS,
    BUSY,
    LIST_TOO_LONG,
    NOT_ALLOWED,
    OUT_OF_LIMITS,
    VERSION,
    WRONG_STATE,
    Abrt,
    Ack,
    Bye,
    Decoder,
    Done,
    Err,
    Go,
    Helo,
    Home,
    Joints,
    Load,
    Message,
    MovJ,
    Pose,
    Run,
    Stat,
    StatReply,
    Wait,
    Zero,
)
from protocol.errors import FramingError, PayloadError
from screwcal.errors import ScrewcalError
from screwcal.kinematics.ik import closed_form_ik
from screwcal.kinematics.pose import pose_from_transform, transform_from_pose
from simulators.faults import FaultPlan
from simulators.world import World

LOAD_TIMEOUT_S = 5.0
INBOX_LIMIT = 64  # requests read ahead of the one being handled


@dataclass
class EmulatorSettings:
    speed_deg_s: float = 60.0
    time_scale: float = 1.0
    faults: FaultPlan = field(default_factory=FaultPlan)
    # A real IRC5 stops after ZERO (WAIT 0) while a person enters the offsets on the
    # FlexPendant; by default the emulator applies ZERO itself and sends no WAIT.
    zero_wait: bool = False
    idle_timeout_s: float = 60.0  # the owner's silence while the controller waits for it
    send_timeout_s: float = 10.0  # a peer that reads nothing for this long is dropped


class _SessionEndedError(Exception):
    """The session ends (BYE, a dropped link, an injected fault)."""


class IRC5Emulator:
    def __init__(self, world: World, settings: EmulatorSettings | None = None):
        self.world = world
        self.settings = settings or EmulatorSettings()
        self.lists: dict[str, list[np.ndarray]] = {"CAL": [], "PERF": []}
        self.state, self.mode, self.list_name = "IDLE", "AUTO", "NONE"
        self.idx = self.count = self.last_seq = 0
        self.sessions = 0
        self.refused = 0  # connections turned away busy
        self._server: asyncio.base_events.Server | None = None
        self._owner: _Session | None = None

    # -- server ------------------------------------------------------------------------------
    async def start(self, host: str = "127.0.0.1", port: int = 0) -> tuple[str, int]:
        self._server = await asyncio.start_server(self._serve, host, port)
        sock = self._server.sockets[0]
        bound = sock.getsockname()
        return bound[0], bound[1]

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self._owner is not None:  # one owner at a time: the others are told, not queued
            self.refused += 1
            await _refuse(reader, writer)
            return
        self.sessions += 1
        session = self._owner = _Session(self, reader, writer)
        try:
            await session.run()
        finally:
            session.close()
            self._owner = None
            if self.state in ("MOVING", "WAITING"):
                self.state = "IDLE"  # the run stops with the link

    # -- state ---------------------------------------------------------------------------------
    def stat(self, seq: int) -> StatReply:
        return StatReply(seq, self.state, self.mode, self.list_name, self.idx, self.count,
                         self.last_seq)  # type: ignore[arg-type]

    def check_limits(self, q_deg: np.ndarray) -> str | None:
        lim = self.world.nominal.limits_deg
        bad = np.flatnonzero((q_deg < lim[:, 0]) | (q_deg > lim[:, 1]))
        if bad.size:
            j = int(bad[0])
            return f"joint {j + 1} {q_deg[j]:.4f} outside [{lim[j, 0]:g}, {lim[j, 1]:g}]"
        return None

    def joints_for_pose(self, pose: tuple[float, ...], near_deg: np.ndarray) -> np.ndarray | None:
        """The controller's own IK for a task-space target: the valid branch nearest `near`."""
        try:
            sol = closed_form_ik(self.world.nominal, transform_from_pose(np.array([pose])))
            return np.degrees(sol.nearest(np.radians(near_deg))[0])
        except ScrewcalError:
            return None

    def motion_time_s(self, target_deg: np.ndarray) -> float:
        travel = float(np.max(np.abs(target_deg - self.world.q_deg.astype(float))))
        return travel / self.settings.speed_deg_s * self.settings.time_scale


async def _refuse(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    """`0 ERR 16 busy`, then close. What the peer already sent is read and dropped first (a
    close with unread data resets the connection, and the peer would lose the refusal)."""
    writer.write(codec.encode(Err(0, BUSY, "busy")))
    with contextlib.suppress(Exception):
        writer.write_eof()
        async with asyncio.timeout(1.0):
            for _ in range(64):  # at most 256 kB, then it is cut
                if not await reader.read(4096):
                    break
    if reader.at_eof():
        writer.close()
    else:
        writer.transport.abort()


class _Session:
    """One client connection: decoded requests are queued, handled one at a time."""

    def __init__(self, emu: IRC5Emulator, reader: asyncio.StreamReader,
                 writer: asyncio.StreamWriter):
        self.emu, self.reader, self.writer = emu, reader, writer
        self.inbox: Mailbox[Message | Exception] = Mailbox(INBOX_LIMIT)
        self.faults = emu.settings.faults
        self._reader_task = asyncio.create_task(self._read())

    async def _read(self) -> None:
        decoder = Decoder()
        try:
            while data := await self.reader.read(4096):
                while True:  # until every whole frame is handled (errors come one call late)
                    try:
                        for msg in decoder.feed(data):
                            await self.inbox.put(msg)  # full: stop reading (back-pressure)
                    except PayloadError as err:
                        await self.inbox.put(err)
                    data = b""
                    if decoder.pending_bytes < codec.FRAME_LEN:
                        break
        except (FramingError, ConnectionError) as err:
            self.inbox.force(err if isinstance(err, FramingError) else _SessionEndedError())
            return
        self.inbox.force(_SessionEndedError())

    def close(self) -> None:
        self._reader_task.cancel()
        with contextlib.suppress(Exception):
            self.writer.close()

    async def send(self, *messages: Message, garble_first: bool = False) -> None:
        frames = [codec.encode(m) for m in messages]
        if garble_first:
            frames[0] = frames[0].replace(b"#", b" ")
        if self.faults.merge_frames:
            frames = [b"".join(frames)]
        for f in frames:
            if self.faults.split_frames:
                self.writer.write(f[:33])
                await self.writer.drain()
                await asyncio.sleep(0)
                self.writer.write(f[33:])
            else:
                self.writer.write(f)
        try:
            await asyncio.wait_for(self.writer.drain(), self.emu.settings.send_timeout_s)
        except (ConnectionError, TimeoutError):  # gone, or not reading: drop it
            self.writer.transport.abort()
            raise _SessionEndedError() from None

    async def _usable(self, item: Message | Exception) -> Message | None:
        """A request, or None after answering a bad one; a closed link or an untrustworthy
        frame ends the session."""
        if isinstance(item, _SessionEndedError | FramingError):
            raise _SessionEndedError()
        if isinstance(item, PayloadError):
            if item.seq is None:  # no SEQ to answer to: the frame cannot be trusted
                raise _SessionEndedError()
            await self.send(Err(item.seq, item.code, "bad request"))
            return None
        return item  # type: ignore[return-value]

    async def next_request(self) -> Message:
        """The next request; an owner silent for the idle time is dropped (a half frame, or
        nothing at all, holds the controller no longer)."""
        while True:
            try:
                item = await asyncio.wait_for(self.inbox.get(),
                                              self.emu.settings.idle_timeout_s)
            except TimeoutError:
                self.writer.transport.abort()
                raise _SessionEndedError() from None
            if (msg := await self._usable(item)) is not None:
                return msg

    async def run(self) -> None:
        try:
            while True:
                await self.handle(await self.next_request())
        except _SessionEndedError:
            return

    # -- requests --------------------------------------------------------------------------------
    async def handle(self, msg: Message) -> None:
        emu = self.emu
        match msg:
            case Helo():
                if msg.version != codec.PROTOCOL_VERSION:
                    await self.send(Err(msg.seq, VERSION, "version"))
                else:
                    await self.send(Ack(msg.seq, "HELO", (str(codec.PROTOCOL_VERSION),)))
            case Stat():
                await self.send(emu.stat(msg.seq))
            case Load():
                await self.load(msg)
            case Run():
                await self.run_list(msg)
            case MovJ() | Home():
                target = np.zeros(6) if isinstance(msg, Home) else np.array(msg.joints_deg)
                await self.move_request(msg.seq, "MOVJ" if isinstance(msg, MovJ) else "HOME",
                                        target)
            case Zero():
                await self.zero(msg)
            case Abrt():
                await self.send(Ack(msg.seq, "ABRT"))  # nothing running
            case Bye():
                await self.send(Ack(msg.seq, "BYE"))
                raise _SessionEndedError()
            case Go():
                await self.send(Err(msg.seq, WRONG_STATE, "no step waiting"))
            case Joints() | Pose():
                await self.send(Err(msg.seq, WRONG_STATE, "data packet outside LOAD"))
            case _:
                await self.send(Err(msg.seq, NOT_ALLOWED, "controller-side verb"))
        if not isinstance(msg, Joints | Pose | Go | Stat):
            emu.last_seq = msg.seq

    async def load(self, msg: Load) -> None:
        emu = self.emu
        if msg.count > codec.MAX_LIST or msg.count < 1:
            code = LIST_TOO_LONG if msg.count > codec.MAX_LIST else BAD_ARGUMENTS
            await self.send(Err(msg.seq, code, f"list of {msg.count} poses"))
            return
        targets: list[np.ndarray] = []
        problem: tuple[int, str] | None = None
        near = emu.world.q_deg.astype(float)
        for k in range(msg.count):
            try:
                item = await asyncio.wait_for(self.next_request(), LOAD_TIMEOUT_S)
            except TimeoutError:
                await self.send(Err(msg.seq, BAD_ARGUMENTS, f"list incomplete at {k}"))
                return
            expected_flag = codec.flag_of(k, msg.count)
            if not isinstance(item, Joints | Pose):
                # Any other request mid-LOAD: refused, the partial list discarded, nothing
                # moves (never run the request: it could start a list or a move).
                await self.send(Err(item.seq, WRONG_STATE, "LOAD incomplete"))
                await self.send(Err(msg.seq, WRONG_STATE, f"LOAD discarded at packet {k}"))
                return
            if item.seq != msg.seq or item.idx != k or item.flag != expected_flag:
                problem = problem or (BAD_ARGUMENTS, f"packet {k} out of order")
                continue
            q = np.array(item.values) if isinstance(item, Joints) else \
                emu.joints_for_pose(item.values, near)
            if q is None:
                problem = problem or (OUT_OF_LIMITS, f"pose {k} unreachable")
                continue
            reason = emu.check_limits(q)
            if reason:
                problem = problem or (OUT_OF_LIMITS, f"pose {k} {reason}")
            targets.append(q)
            near = q
        if problem:
            await self.send(Err(msg.seq, problem[0], problem[1][:60]))
            return
        emu.lists[msg.list] = targets
        await self.send(Ack(msg.seq, "LOAD"))

    async def move(self, target: np.ndarray) -> None:
        emu = self.emu
        emu.state = "MOVING"
        emu.world.moving = True
        t = emu.motion_time_s(target)
        if t > 0:
            await asyncio.sleep(t)  # a single RAPID task: nothing is read meanwhile
        await emu.world.set_joints(target)
        emu.state = "IDLE"

    def packets(self, seq: int, flag: int, idx: int) -> tuple[Joints, Pose]:
        q = tuple(float(v) for v in self.emu.world.q_deg)
        pose = pose_from_transform(self.emu.world.nominal_tool0()).astype(np.float32)
        return (Joints(seq, flag, idx, q),  # type: ignore[arg-type]
                Pose(seq, flag, idx, tuple(float(v) for v in pose)))  # type: ignore[arg-type]

    async def move_request(self, seq: int, verb: str, target: np.ndarray) -> None:
        reason = self.emu.check_limits(target)
        if reason:
            await self.send(Err(seq, OUT_OF_LIMITS, reason[:60]))
            return
        await self.send(Ack(seq, verb))
        await self.move(target)
        await self.send(*self.packets(seq, 2, 0))
        await self.send(Done(seq, verb))

    async def zero(self, msg: Zero) -> None:
        target = np.array(msg.joints_deg)
        reason = self.emu.check_limits(target)
        if reason:
            await self.send(Err(msg.seq, OUT_OF_LIMITS, reason[:60]))
            return
        await self.send(Ack(msg.seq, "ZERO"))
        await self.move(target)
        if self.emu.settings.zero_wait:  # the operator enters the offsets, then GO 0
            self.emu.state = "WAITING"
            await self.send(Wait(msg.seq, 0))
            if not await self.wait_go(0, msg.seq):
                return
        self.emu.world.set_zero(target)
        self.emu.state = "IDLE"
        await self.send(Done(msg.seq, "ZERO"))

    async def wait_go(self, idx: int, run_seq: int) -> bool:
        """Wait for GO idx; False when aborted (ERR 22 sent)."""
        while True:
            req = await self.next_request()
            if isinstance(req, Go) and req.idx == idx:
                return True
            if not await self._during_run(req, run_seq, f"waiting for GO {idx}"):
                return False

    async def _during_run(self, req: Message, run_seq: int, busy: str) -> bool:
        """A request while a list runs: ABRT ends it (False), STAT is answered, the rest
        refused."""
        if isinstance(req, Abrt):
            await self.send(Err(run_seq, ABORTED, "aborted"), Ack(req.seq, "ABRT"))
            self.emu.state = "IDLE"
            return False
        if isinstance(req, Stat):
            await self.send(self.emu.stat(req.seq))
        else:
            await self.send(Err(req.seq, WRONG_STATE, busy))
        return True

    async def between_moves(self, run_seq: int) -> bool:
        """Requests that arrived during the move: STAT is answered, ABRT stops the run."""
        while not self.inbox.empty():
            req = await self._usable(self.inbox.get_nowait())
            if req is not None and not await self._during_run(req, run_seq, "a run is active"):
                return False
        return True

    async def run_list(self, msg: Run) -> None:
        emu = self.emu
        targets = emu.lists[msg.list]
        if not targets:
            await self.send(Err(msg.seq, WRONG_STATE, f"no {msg.list} list loaded"))
            return
        emu.mode, emu.list_name, emu.idx, emu.count = msg.mode, msg.list, 0, len(targets)
        await self.send(Ack(msg.seq, "RUN"))
        n = len(targets)
        for k, target in enumerate(targets):
            if not await self.between_moves(msg.seq):
                emu.state = "IDLE"
                return
            if msg.mode == "STEP":
                emu.state = "WAITING"
                await self.send(Wait(msg.seq, k))
                if not await self.wait_go(k, msg.seq):
                    return
            if self.faults.take("stall_at_pose", k):
                await asyncio.sleep(self.faults.stall_s)
            await self.move(target)
            if self.faults.take("drop_at_pose", k):
                self.writer.transport.abort()
                raise _SessionEndedError()
            flag = codec.flag_of(k, n)
            await self.send(*self.packets(msg.seq, flag, k),
                            garble_first=self.faults.take("garble_at_pose", k))
            emu.idx = k + 1
        emu.state = "IDLE"
        await self.send(Done(msg.seq, "RUN"))
