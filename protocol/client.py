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
from collections import deque
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from dataclasses import dataclass

from protocol import codec
from protocol.bounded import Mailbox
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
    Stat,
    StatReply,
    Wait,
    Zero,
)
from protocol.errors import (
    ControllerBusyError,
    ControllerError,
    FramingError,
    LinkLostError,
    LinkTimeoutError,
    PayloadError,
    ProtocolError,
    SequenceError,
)
from protocol.memory import Opener
from protocol.replies import MeasuredPose, MotionReplies, MotionVerb, RunReplies


@dataclass(frozen=True)
class Timeouts:
    connect_s: float = 5.0
    reply_s: float = 2.0  # ACK/ERR of an idle controller (1 s by the spec, plus margin)
    pose_s: float = 120.0  # one pose of a running list: motion plus margin
    motion_s: float = 120.0  # DONE of MOVJ / HOME / ZERO
    # STAT after this long without sending, while the controller waits for us (idle, or a
    # STEP/ZERO wait for the operator): its idle time-out (60 s by default) drops a quiet owner.
    keepalive_s: float = 20.0


MAX_UNSOLICITED = 1000  # frames for no pending request, per connection, before the drop
ROUTE_LIMIT = 4 * codec.MAX_LIST + 16  # frames queued unread for one request (a whole run fits)


class _Lost:
    """The marker queued for every pending request when the link is lost."""


_LOST = _Lost()
_Routed = Message | PayloadError | _Lost  # what a request's mailbox holds


class ControllerClient:
    """`connect`: what opens the link (default: TCP to host:port); a test pairs the client
    with a fake controller in memory by giving protocol.memory's opener."""

    def __init__(self, host: str, port: int, timeouts: Timeouts | None = None, *,
                 connect: Opener | None = None):
        self.host, self.port = host, port
        self.timeouts = timeouts or Timeouts()
        self._open: Opener = connect or (lambda: asyncio.open_connection(host, port))
        self._seq = itertools.count(1)
        self._routes: dict[int, Mailbox[_Routed]] = {}
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._reader_task: asyncio.Task[None] | None = None
        self._keepalive_task: asyncio.Task[None] | None = None
        self._loaded: dict[str, int] = {}  # list -> length this connection LOADed
        self._last_send = 0.0
        self._operator_waits = 0
        self.lost: ProtocolError | None = None
        self.unexpected: deque[Message] = deque(maxlen=50)  # the latest frames for no request
        self.unexpected_count = 0

    # -- connection ------------------------------------------------------------------------------
    async def connect(self) -> None:
        """Open the link and say HELO. On any failure nothing is left open (a stale socket
        would hold the controller's one session)."""
        await self.close()
        try:
            reader, writer = await asyncio.wait_for(self._open(), self.timeouts.connect_s)
        except (TimeoutError, OSError) as err:
            raise LinkLostError(f"cannot connect to the controller at {self.host}:{self.port}: "
                                f"{err or 'timed out'}") from None
        self._reader, self._writer = reader, writer
        self._routes.clear()
        self._loaded.clear()
        self.unexpected.clear()
        self.unexpected_count = 0
        sock = writer.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        self.lost = None
        self._reader_task = asyncio.create_task(self._read_loop())
        try:
            seq = self._next_seq()
            reply = await self._request(Helo(seq), seq, self.timeouts.reply_s)
            self._expect_ack(reply, "HELO")
        except BaseException:
            await self.close()
            raise
        self._keepalive_task = asyncio.create_task(self._keep_alive())

    async def close(self) -> None:
        """Close the link; every pending wait fails with LinkLostError."""
        self._fail(LinkLostError("the link was closed"))
        current = asyncio.current_task()
        for task in (self._keepalive_task, self._reader_task):
            if task is not None and task is not current:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError, Exception):
                    await task
        self._keepalive_task = self._reader_task = None
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
        """After a drop: connect again with exponential back-off (also while the controller
        still says busy: it may not have noticed the old link's end yet), HELO, then STAT. The
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
                while self.lost is None:  # until every whole frame is handled
                    try:
                        for msg in decoder.feed(data):
                            self._route(msg)
                            if self.lost is not None:
                                break
                    except PayloadError as err:  # the controller sent nonsense
                        self._malformed(err)
                    data = b""
                    if decoder.pending_bytes < codec.FRAME_LEN:
                        break
                if self.lost is not None:
                    return  # dropped (a flood): read no more
            self._fail(LinkLostError("the controller closed the connection"))
        except FramingError as err:  # what came before the bad frame is still delivered
            self._fail(LinkLostError(f"bad frame from the controller ({err}); link dropped"))
            if self._writer is not None:
                self._writer.transport.abort()
        except (ConnectionError, OSError) as err:
            self._fail(LinkLostError(f"connection lost: {err}"))

    def _route(self, msg: Message) -> None:
        if msg.seq == 0 and isinstance(msg, Err) and msg.code == codec.BUSY:
            self._drop(ControllerBusyError(msg.text))
            return
        queue = self._routes.get(msg.seq)
        if queue is None:
            self._unsolicited(msg)
        elif not queue.offer(msg):
            self._drop(LinkLostError(f"the controller sent over {ROUTE_LIMIT} frames for "
                                     f"request {msg.seq}; link dropped"))

    def _malformed(self, err: PayloadError) -> None:
        """A well-framed payload that is no valid message: the pending request it names fails
        with the cause; otherwise it counts as unsolicited."""
        if err.seq is not None and err.seq in self._routes:
            self._routes[err.seq].force(err)
        else:
            self._unsolicited(Err(err.seq or 0, err.code, str(err)[:40]))

    def _unsolicited(self, msg: Message) -> None:
        self.unexpected.append(msg)
        self.unexpected_count += 1
        if self.unexpected_count > MAX_UNSOLICITED:
            self._drop(LinkLostError(f"the controller sent over {MAX_UNSOLICITED} frames that "
                                     "answer no request; link dropped"))

    def _fail(self, err: ProtocolError, distrust: bool = False) -> None:
        """The link is lost (the first cause is kept): every pending wait fails with it, after
        what already arrived unless the controller is not to be trusted."""
        if self.lost is not None:
            return
        self.lost = err
        for queue in self._routes.values():
            while distrust and not queue.empty():
                queue.get_nowait()
            queue.force(_LOST)

    def _drop(self, err: ProtocolError) -> None:
        """Fail the link and cut the connection (a controller that cannot be trusted)."""
        self._fail(err, distrust=True)
        if self._writer is not None:
            self._writer.transport.abort()

    async def _send(self, *messages: Message) -> None:
        if self.lost is not None or self._writer is None:
            raise self.lost or LinkLostError("not connected")
        self._writer.write(b"".join(codec.encode(m) for m in messages))
        self._last_send = asyncio.get_running_loop().time()
        try:
            await self._writer.drain()
        except (ConnectionError, OSError) as err:
            lost = LinkLostError(f"connection lost: {err}")
            self._fail(lost)
            raise (self.lost or lost) from None

    async def _get(self, seq: int, timeout_s: float, what: str) -> Message:
        queue = self._routes[seq]
        try:
            item = await asyncio.wait_for(queue.get(), timeout_s)
        except TimeoutError:
            raise LinkTimeoutError(f"no {what} for request {seq} within {timeout_s:g} s") from None
        if isinstance(item, _Lost):
            raise self.lost or LinkLostError("link lost")
        if isinstance(item, PayloadError):
            raise PayloadError(f"malformed reply to request {seq} (waiting for {what}): {item}",
                               item.code, seq)
        return item

    def _open_route(self, seq: int) -> None:
        self._routes[seq] = Mailbox(ROUTE_LIMIT)

    async def _request(self, msg: Message, seq: int, timeout_s: float) -> Message:
        self._open_route(seq)
        try:
            await self._send(msg)
            return await self._get(seq, timeout_s, "reply")
        finally:
            self._routes.pop(seq, None)

    async def _operator_go(self, on_wait: Callable[[int], Awaitable[None]], idx: int) -> None:
        """The operator's go-ahead for `idx` (keep-alive STATs go on meanwhile), then GO."""
        self._operator_waits += 1
        try:
            await on_wait(idx)
        finally:
            self._operator_waits -= 1
        await self._send(Go(self._next_seq(), idx))

    async def _keep_alive(self) -> None:
        """STAT whenever nothing was sent for `keepalive_s` and the controller waits for us
        (idle, or waiting for the operator); not while it moves (it reads nothing then, and its
        idle clock stops). A failed STAT marks the link lost."""
        interval = self.timeouts.keepalive_s
        loop = asyncio.get_running_loop()
        while self.lost is None:
            quiet = loop.time() - self._last_send
            if quiet < interval:
                await asyncio.sleep(interval - quiet)
            elif self._routes and not self._operator_waits:
                await asyncio.sleep(interval / 4)  # a request runs: the controller is busy
            else:
                try:
                    await self.stat()
                except ProtocolError as err:
                    self._drop(LinkLostError(f"keep-alive STAT failed: {err}"))
                    return

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
        """Replace a list with joint targets (`j` packets) or task-space targets (`p`). The
        client remembers its length: `run` holds the controller to it."""
        targets = joints_deg if joints_deg is not None else poses
        if targets is None or (joints_deg is not None and poses is not None):
            raise ValueError("give either joint targets or task-space poses")
        joints = joints_deg is not None
        items = list(targets)
        n = len(items)
        if not 1 <= n <= codec.MAX_LIST:
            raise ValueError(f"a list holds 1..{codec.MAX_LIST} poses, got {n}")
        seq = self._next_seq()
        packets = [(Joints if joints else Pose)(seq, codec.flag_of(k, n), k,
                                                codec.six_of(item, f"target {k}"))
                   for k, item in enumerate(items)]
        self._loaded.pop(list_name, None)  # unknown until the ACK
        self._open_route(seq)
        try:
            await self._send(Load(seq, list_name, n), *packets)
            self._expect_ack(await self._get(seq, self.timeouts.reply_s + 0.01 * n, "ACK LOAD"),
                             "LOAD")
            self._loaded[list_name] = n
        finally:
            self._routes.pop(seq, None)

    async def run(self, list_name: codec.Lists, mode: codec.Modes = "AUTO",
                  on_wait: Callable[[int], Awaitable[None]] | None = None,
                  count: int | None = None) -> AsyncIterator[MeasuredPose]:
        """Run the list this connection loaded; yields each pose as its `j` and `p` packets
        arrive. The run must report exactly the loaded poses, in order, each once, with the
        FLAGs of its length (0 first, 1 between, 2 last), then DONE: anything else is a
        SequenceError. In STEP mode `on_wait(idx)` is awaited before GO is sent for each pose
        (it raises to refuse), and a pose reported before its GO is a SequenceError. `count`,
        if given, must be the loaded length."""
        if mode == "STEP" and on_wait is None:
            raise ValueError("STEP mode needs on_wait: the operator's go-ahead")
        loaded = self._loaded.get(list_name)
        if loaded is None:
            raise SequenceError(f"no {list_name} list loaded on this connection: load() it "
                                "first (the run is held to the length of its LOAD)")
        if count is not None and count != loaded:
            raise ValueError(f"count {count} is not the loaded {list_name} list's {loaded}")
        seq = self._next_seq()
        self._open_route(seq)
        try:
            await self._send(Run(seq, list_name, mode))
            self._expect_ack(await self._get(seq, self.timeouts.reply_s, "ACK RUN"), "RUN")
            replies = RunReplies(loaded, operator=on_wait is not None, step=mode == "STEP")
            while True:
                event = replies.feed(await self._get(seq, self.timeouts.pose_s,
                                                     f"pose {replies.expected}"))
                if isinstance(event, Wait):
                    assert on_wait is not None  # RunReplies refuses a WAIT without one
                    await self._operator_go(on_wait, event.idx)
                elif isinstance(event, MeasuredPose):
                    yield event
                elif isinstance(event, Done):
                    return
        finally:
            self._routes.pop(seq, None)

    async def go(self, idx: int) -> None:
        await self._send(Go(self._next_seq(), idx))

    async def _motion(self, msg: MovJ | Home | Zero, verb: MotionVerb,
                      on_wait: Callable[[int], Awaitable[None]] | None = None
                      ) -> MeasuredPose | None:
        """Send a motion request and follow its replies (`MotionReplies`)."""
        seq = msg.seq
        self._open_route(seq)
        try:
            await self._send(msg)
            self._expect_ack(await self._get(seq, self.timeouts.reply_s, f"ACK {verb}"), verb)
            replies = MotionReplies(verb, operator=on_wait is not None)
            while True:
                event = replies.feed(await self._get(seq, self.timeouts.motion_s, f"DONE {verb}"))
                if isinstance(event, Wait):
                    assert on_wait is not None  # MotionReplies refuses a WAIT without one
                    await self._operator_go(on_wait, event.idx)
                elif isinstance(event, Done):
                    return replies.result
        finally:
            self._routes.pop(seq, None)

    async def movj(self, joints_deg: Sequence[float]) -> MeasuredPose:
        target = codec.six_of(joints_deg, "the MOVJ target")
        result = await self._motion(MovJ(self._next_seq(), target), "MOVJ")
        assert result is not None  # _motion checked it
        return result

    async def home(self) -> MeasuredPose:
        result = await self._motion(Home(self._next_seq()), "HOME")
        assert result is not None  # _motion checked it
        return result

    async def zero(self, joints_deg: Sequence[float],
                   on_wait: Callable[[int], Awaitable[None]] | None = None) -> None:
        """The correction: move there and make it the joints' new zero (thesis 4.5)."""
        target = codec.six_of(joints_deg, "the ZERO target")
        await self._motion(Zero(self._next_seq(), target), "ZERO", on_wait)

    async def abort(self) -> None:
        seq = self._next_seq()
        reply = await self._request(Abrt(seq), seq, self.timeouts.motion_s)
        self._expect_ack(reply, "ABRT")

    async def bye(self) -> None:
        seq = self._next_seq()
        self._expect_ack(await self._request(Bye(seq), seq, self.timeouts.reply_s), "BYE")

