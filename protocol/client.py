"""An asyncio client of the controller (the PC side of thesis 4.4), a thin layer over the codec.

Every request gets its own SEQ; a reader task routes whatever the controller sends to that
request's queue. Every wait has a time limit (`LinkTimeoutError`); a dropped link fails every
pending wait with `LinkLostError`; the client never re-sends a motion request by itself. After a
drop, `reconnect()` retries with exponential back-off, says HELO and asks STAT, so the caller
learns what finished (moves are not idempotent).

    async with ControllerClient("127.0.0.1", 4012) as robot:
        await robot.load("CAL", joint_targets_deg)
        async for pose in robot.run("CAL", "AUTO"):
            ...  # pose.idx, pose.joints_deg, pose.tool0 (x, y, z mm, rx, ry, rz deg)
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import socket
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from dataclasses import dataclass
from typing import Any

from protocol import codec
from protocol.codec import (
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
    Six,
    Stat,
    StatReply,
    Wait,
    Zero,
)
from protocol.errors import (
    ControllerError,
    FramingError,
    LinkLostError,
    LinkTimeoutError,
    PayloadError,
    ProtocolError,
    SequenceError,
)


@dataclass(frozen=True)
class MeasuredPose:
    """What the controller reported after reaching pose `idx` of a list."""

    idx: int
    flag: int
    joints_deg: Six
    tool0: Six  # x, y, z (mm), rx, ry, rz (deg), nominal, base frame


@dataclass(frozen=True)
class Timeouts:
    connect_s: float = 5.0
    reply_s: float = 2.0  # ACK/ERR of an idle controller (1 s by the spec, plus margin)
    pose_s: float = 120.0  # one pose of a running list: motion plus margin
    motion_s: float = 120.0  # DONE of MOVJ / HOME / ZERO


_LOST = object()


class ControllerClient:
    def __init__(self, host: str, port: int, timeouts: Timeouts | None = None):
        self.host, self.port = host, port
        self.timeouts = timeouts or Timeouts()
        self._seq = itertools.count(1)
        self._routes: dict[int, asyncio.Queue[Any]] = {}
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._reader_task: asyncio.Task[None] | None = None
        self.lost: ProtocolError | None = None
        self.unexpected: list[Message] = []  # frames for no pending request

    # -- connection ------------------------------------------------------------------------------
    async def connect(self) -> None:
        """Open the link and say HELO."""
        try:
            self._reader, self._writer = await asyncio.wait_for(
                asyncio.open_connection(self.host, self.port), self.timeouts.connect_s)
        except (TimeoutError, OSError) as err:
            raise LinkLostError(f"cannot connect to the controller at {self.host}:{self.port}: "
                                f"{err or 'timed out'}") from None
        self._routes.clear()
        sock = self._writer.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        self.lost = None
        self._reader_task = asyncio.create_task(self._read_loop())
        seq = self._next_seq()
        reply = await self._request(Helo(seq), seq, self.timeouts.reply_s)
        self._expect_ack(reply, "HELO")

    async def close(self) -> None:
        """Close the link; every pending wait fails with LinkLostError."""
        if self.lost is None:
            self._fail(LinkLostError("the link was closed"))
        if self._reader_task is not None:
            self._reader_task.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._reader_task
        if self._writer is not None:
            self._writer.close()
            with contextlib.suppress(Exception):
                await self._writer.wait_closed()
        self._writer = None

    async def __aenter__(self) -> ControllerClient:
        await self.connect()
        return self

    async def __aexit__(self, *exc: object) -> None:
        if self.lost is None and self._writer is not None:
            with contextlib.suppress(ProtocolError):
                await self.bye()
        await self.close()

    async def reconnect(self, attempts: int = 8, first_delay_s: float = 0.05,
                        max_delay_s: float = 5.0) -> StatReply:
        """After a drop: connect again with exponential back-off, HELO, then STAT. The
        interrupted request stays failed; nothing is re-sent."""
        await self.close()
        delay = first_delay_s
        last: ProtocolError | None = None
        for _ in range(attempts):
            try:
                await self.connect()
                return await self.stat()
            except ProtocolError as err:
                last = err
                await self.close()
                await asyncio.sleep(delay)
                delay = min(delay * 2, max_delay_s)
        raise LinkLostError(f"controller unreachable after {attempts} attempts: {last}")

    def _next_seq(self) -> int:
        seq = next(self._seq)
        if seq > codec.MAX_SEQ:
            self._seq = itertools.count(2)
            seq = 1
        return seq

    async def _read_loop(self) -> None:
        decoder = Decoder()
        assert self._reader is not None
        try:
            while data := await self._reader.read(4096):
                while True:  # until every whole frame is handled (errors come one call late)
                    try:
                        for msg in decoder.feed(data):
                            self._route(msg)
                    except PayloadError as err:  # the controller sent nonsense: not fatal
                        self.unexpected.append(Err(err.seq or 1, err.code, str(err)[:40]))
                    data = b""
                    if decoder.pending_bytes < codec.FRAME_LEN:
                        break
            self._fail(LinkLostError("the controller closed the connection"))
        except FramingError as err:
            self._fail(LinkLostError(f"bad frame from the controller ({err}); link dropped"))
            if self._writer is not None:
                self._writer.transport.abort()
        except (ConnectionError, OSError) as err:
            self._fail(LinkLostError(f"connection lost: {err}"))

    def _route(self, msg: Message) -> None:
        queue = self._routes.get(msg.seq)
        if queue is None:
            self.unexpected.append(msg)
        else:
            queue.put_nowait(msg)

    def _fail(self, err: ProtocolError) -> None:
        self.lost = err
        for queue in self._routes.values():
            queue.put_nowait(_LOST)

    async def _send(self, *messages: Message) -> None:
        if self.lost is not None or self._writer is None:
            raise self.lost or LinkLostError("not connected")
        self._writer.write(b"".join(codec.encode(m) for m in messages))
        try:
            await self._writer.drain()
        except (ConnectionError, OSError) as err:
            self._fail(LinkLostError(f"connection lost: {err}"))
            raise self.lost from None  # type: ignore[misc]

    async def _get(self, seq: int, timeout_s: float, what: str) -> Message:
        queue = self._routes[seq]
        try:
            item = await asyncio.wait_for(queue.get(), timeout_s)
        except TimeoutError:
            raise LinkTimeoutError(f"no {what} for request {seq} within {timeout_s:g} s") from None
        if item is _LOST:
            raise self.lost or LinkLostError("link lost")
        return item

    async def _request(self, msg: Message, seq: int, timeout_s: float) -> Message:
        self._routes[seq] = asyncio.Queue()
        try:
            await self._send(msg)
            return await self._get(seq, timeout_s, "reply")
        finally:
            self._routes.pop(seq, None)

    @staticmethod
    def _expect_ack(reply: Message, verb: str) -> None:
        if isinstance(reply, Err):
            raise ControllerError(reply.code, reply.text, reply.seq)
        if not (isinstance(reply, Ack) and reply.verb == verb):
            raise SequenceError(f"expected ACK {verb}, got {reply}")

    # -- requests --------------------------------------------------------------------------------
    async def stat(self) -> StatReply:
        seq = self._next_seq()
        reply = await self._request(Stat(seq), seq, self.timeouts.reply_s)
        if isinstance(reply, Err):
            raise ControllerError(reply.code, reply.text, reply.seq)
        if not isinstance(reply, StatReply):
            raise SequenceError(f"expected STAT reply, got {reply}")
        return reply

    async def load(self, list_name: codec.Lists,
                   joints_deg: Sequence[Sequence[float]] | None = None, *,
                   poses: Sequence[Sequence[float]] | None = None) -> None:
        """Replace a list with joint targets (`j` packets) or task-space targets (`p`)."""
        if (joints_deg is None) == (poses is None):
            raise ValueError("give either joint targets or task-space poses")
        items = list(joints_deg if joints_deg is not None else poses)  # type: ignore[arg-type]
        kind = Joints if joints_deg is not None else Pose
        n = len(items)
        if not 1 <= n <= codec.MAX_LIST:
            raise ValueError(f"a list holds 1..{codec.MAX_LIST} poses, got {n}")
        seq = self._next_seq()
        packets = [kind(seq, 2 if k == n - 1 else (0 if k == 0 else 1), k,
                        tuple(float(v) for v in item))  # type: ignore[arg-type]
                   for k, item in enumerate(items)]
        self._routes[seq] = asyncio.Queue()
        try:
            await self._send(Load(seq, list_name, n), *packets)
            self._expect_ack(await self._get(seq, self.timeouts.reply_s + 0.01 * n, "ACK LOAD"),
                             "LOAD")
        finally:
            self._routes.pop(seq, None)

    async def run(self, list_name: codec.Lists, mode: codec.Modes = "AUTO",
                  on_wait: Callable[[int], Awaitable[None]] | None = None,
                  count: int | None = None) -> AsyncIterator[MeasuredPose]:
        """Run a loaded list; yields each pose as its `j` and `p` packets arrive, checking
        FLAG and IDX. In STEP mode `on_wait(idx)` is awaited before GO is sent for each pose (it
        raises to refuse). `count`, when known, also checks the last FLAG."""
        if mode == "STEP" and on_wait is None:
            raise ValueError("STEP mode needs on_wait: the operator's go-ahead")
        seq = self._next_seq()
        self._routes[seq] = asyncio.Queue()
        try:
            await self._send(Run(seq, list_name, mode))
            self._expect_ack(await self._get(seq, self.timeouts.reply_s, "ACK RUN"), "RUN")
            expected, pending = 0, None
            while True:
                msg = await self._get(seq, self.timeouts.pose_s, f"pose {expected}")
                if isinstance(msg, Wait):
                    if msg.idx != expected:
                        raise SequenceError(f"WAIT {msg.idx} while pose {expected} is next")
                    assert on_wait is not None
                    await on_wait(msg.idx)
                    await self._send(Go(self._next_seq(), msg.idx))
                elif isinstance(msg, Joints):
                    self._check_packet(msg, expected, count)
                    if pending is not None:
                        raise SequenceError(f"j packet {msg.idx} repeated before its p packet")
                    pending = msg
                elif isinstance(msg, Pose):
                    if pending is None or pending.idx != msg.idx or pending.flag != msg.flag:
                        raise SequenceError(f"p packet {msg.idx} without its j packet")
                    yield MeasuredPose(msg.idx, msg.flag, pending.values, msg.values)
                    expected, pending = expected + 1, None
                elif isinstance(msg, Done) and msg.verb == "RUN":
                    if count is not None and expected != count:
                        raise SequenceError(f"run ended after {expected} of {count} poses")
                    return
                elif isinstance(msg, Err):
                    raise ControllerError(msg.code, msg.text, msg.seq)
                else:
                    raise SequenceError(f"unexpected {msg} during the run")
        finally:
            self._routes.pop(seq, None)

    @staticmethod
    def _check_packet(msg: Joints, expected: int, count: int | None) -> None:
        if msg.idx < expected:
            raise SequenceError(f"pose {msg.idx} repeated (expected {expected})")
        if msg.idx > expected:
            raise SequenceError(f"pose {expected} missing (got {msg.idx})")
        first = msg.idx == 0
        last = count is not None and msg.idx == count - 1
        want = 2 if last else (0 if first else 1)
        if count is None and msg.flag == 2:
            return  # the last pose of a list whose length the caller did not give
        if msg.flag != want:
            raise SequenceError(f"pose {msg.idx} has FLAG {msg.flag}, expected {want}")

    async def heartbeat(self, interval_s: float = 5.0) -> None:
        """Send STAT whenever the link has been idle for `interval_s` (the spec's heartbeat);
        run it as a task. It returns (and the link is marked lost) when a STAT fails."""
        while self.lost is None:
            await asyncio.sleep(interval_s)
            if self._routes:  # a request is pending: the link is not idle
                continue
            try:
                await self.stat()
            except ProtocolError as err:
                if self.lost is None:
                    self._fail(LinkLostError(f"heartbeat failed: {err}"))
                return

    async def go(self, idx: int) -> None:
        await self._send(Go(self._next_seq(), idx))

    async def _motion(self, msg: MovJ | Home | Zero, verb: str,
                      on_wait: Callable[[int], Awaitable[None]] | None = None
                      ) -> MeasuredPose | None:
        seq = msg.seq
        self._routes[seq] = asyncio.Queue()
        try:
            await self._send(msg)
            self._expect_ack(await self._get(seq, self.timeouts.reply_s, f"ACK {verb}"), verb)
            joints, result = None, None
            while True:
                reply = await self._get(seq, self.timeouts.motion_s, f"DONE {verb}")
                if isinstance(reply, Joints):
                    joints = reply
                elif isinstance(reply, Pose) and joints is not None:
                    result = MeasuredPose(reply.idx, reply.flag, joints.values, reply.values)
                elif isinstance(reply, Wait) and on_wait is not None:
                    await on_wait(reply.idx)
                    await self._send(Go(self._next_seq(), reply.idx))
                elif isinstance(reply, Wait):
                    raise SequenceError(f"{verb} waits for the operator; give on_wait")
                elif isinstance(reply, Done) and reply.verb == verb:
                    return result
                elif isinstance(reply, Err):
                    raise ControllerError(reply.code, reply.text, reply.seq)
                else:
                    raise SequenceError(f"unexpected {reply} during {verb}")
        finally:
            self._routes.pop(seq, None)

    async def movj(self, joints_deg: Sequence[float]) -> MeasuredPose:
        result = await self._motion(MovJ(self._next_seq(), tuple(joints_deg)), "MOVJ")  # type: ignore[arg-type]
        if result is None:
            raise SequenceError("MOVJ finished without reporting the pose")
        return result

    async def home(self) -> MeasuredPose:
        result = await self._motion(Home(self._next_seq()), "HOME")
        if result is None:
            raise SequenceError("HOME finished without reporting the pose")
        return result

    async def zero(self, joints_deg: Sequence[float],
                   on_wait: Callable[[int], Awaitable[None]] | None = None) -> None:
        """The correction: move there and make it the joints' new zero (thesis 4.5)."""
        await self._motion(Zero(self._next_seq(), tuple(joints_deg)), "ZERO", on_wait)  # type: ignore[arg-type]

    async def abort(self) -> None:
        seq = self._next_seq()
        reply = await self._request(Abrt(seq), seq, self.timeouts.motion_s)
        self._expect_ack(reply, "ABRT")

    async def bye(self) -> None:
        seq = self._next_seq()
        self._expect_ack(await self._request(Bye(seq), seq, self.timeouts.reply_s), "BYE")
