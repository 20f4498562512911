"""The client against controllers that misbehave (issue 12, points 7-11): every wrong reply is a
specific error or a time-out, never a hang, never a skipped or duplicated pose accepted; a
failed connect leaves nothing open; what a controller can send unasked is bounded."""

from __future__ import annotations

import asyncio

import pytest

from protocol.client import MAX_UNSOLICITED, ControllerClient, Timeouts
from protocol.errors import (
    ControllerBusyError,
    ControllerError,
    LinkLostError,
    LinkTimeoutError,
    PayloadError,
    SequenceError,
)
from tests.protocol.fake_controller import FakeController, answering, packets, well_behaved

FAST = Timeouts(connect_s=2, reply_s=0.5, pose_s=1, motion_s=1, keepalive_s=30)
Q = [[0.0] * 6, [1.0] * 6, [2.0] * 6]


async def _client(script) -> tuple[FakeController, ControllerClient]:
    """A client linked in memory to a fake controller running `script` (what these tests hold
    is the client's reading of frames: no socket needed; the connect and reconnect tests below
    keep real TCP)."""
    fake = FakeController(script)
    client = ControllerClient("memory", 0, FAST, connect=fake.opener)
    await client.connect()
    return fake, client


def _run_replies(body):
    """A script whose RUN reply is its ACK then `body(seq)` (the rest well-behaved)."""
    return answering("RUN", lambda seq: [f"{seq} ACK RUN", *body(seq)])


RUNS = {
    "a pose after the last": (2, lambda s: [*packets(s, 0, 0), *packets(s, 2, 1),
                                            *packets(s, 2, 2), f"{s} DONE RUN"], "after the last"),
    "two FLAG 2": (3, lambda s: [*packets(s, 2, 0)], "FLAG 2, expected 0"),
    "no FLAG 2": (2, lambda s: [*packets(s, 0, 0), *packets(s, 1, 1), f"{s} DONE RUN"],
                  "FLAG 1, expected 2"),
    "DONE with no pose": (2, lambda s: [f"{s} DONE RUN"], "after 0 of 2"),
    "a skipped pose": (3, lambda s: [*packets(s, 0, 0), *packets(s, 2, 2)], "pose 1 missing"),
    "a repeated pose": (3, lambda s: [*packets(s, 0, 0), *packets(s, 0, 0)], "repeated"),
    "a j packet twice": (2, lambda s: [packets(s, 0, 0)[0]] * 2, "repeated before its p"),
    "a p packet alone": (2, lambda s: [packets(s, 0, 0)[1]], "without its j"),
    "WAIT in AUTO": (2, lambda s: [f"{s} WAIT 0"], "WAIT 0 during an AUTO run"),
    "an ACK in the run": (1, lambda s: [f"{s} ACK LOAD"], "unexpected"),
}


@pytest.mark.parametrize("case", RUNS)
async def test_a_run_that_breaks_its_list_is_a_sequence_error(case):
    n, body, message = RUNS[case]
    fake, client = await _client(_run_replies(body))
    await client.load("CAL", Q[:n])
    got = []
    with pytest.raises(SequenceError, match=message):
        async with asyncio.timeout(5):
            async for pose in client.run("CAL", "AUTO"):
                got.append(pose.idx)
    assert got == list(range(len(got)))  # never a pose accepted out of order or twice
    await client.close()
    await fake.stop()


async def test_a_run_is_held_to_the_length_of_its_load():
    fake, client = await _client(_run_replies(lambda s: []))
    with pytest.raises(SequenceError, match="no CAL list loaded"):
        _ = [p async for p in client.run("CAL")]
    await client.load("CAL", Q[:2])
    with pytest.raises(ValueError, match="count 3"):
        _ = [p async for p in client.run("CAL", count=3)]
    assert "RUN" not in fake.sent_verbs()  # refused before anything was sent
    await client.close()
    await fake.stop()


async def test_step_wait_twice_asks_the_operator_once_and_sends_one_go():
    def script(seq, verb, args):
        if verb == "RUN":
            script.run_seq = seq
            return [f"{seq} ACK RUN", f"{seq} WAIT 0"]
        if verb == "GO":
            return [f"{script.run_seq} WAIT 0"]  # asks again for the pose it was given
        return well_behaved(seq, verb, args)

    fake, client = await _client(script)
    await client.load("CAL", Q[:2])
    asked = []

    async def operator(idx):
        asked.append(idx)

    with pytest.raises(SequenceError, match="WAIT 0 repeated"):
        async with asyncio.timeout(5):
            _ = [p async for p in client.run("CAL", "STEP", on_wait=operator)]
    assert asked == [0] and fake.sent_verbs().count("GO") == 1
    await client.close()
    await fake.stop()


@pytest.mark.parametrize(("body", "message"), [
    (lambda s: [*packets(s, 0, 0)], "before its GO"),  # moved without the go-ahead
    (lambda s: [f"{s} WAIT 1"], "WAIT 1 while pose 0 is next"),  # asks for another pose
])
async def test_a_step_run_out_of_turn_is_refused_before_the_operator_is_asked(body, message):
    fake, client = await _client(_run_replies(body))
    await client.load("CAL", Q[:2])

    async def operator(idx):
        raise AssertionError("never asked")

    with pytest.raises(SequenceError, match=message):
        _ = [p async for p in client.run("CAL", "STEP", on_wait=operator)]
    await client.close()
    await fake.stop()


MOTIONS = {
    "a j packet twice": lambda s: [f"{s} ACK MOVJ", packets(s, 2, 0)[0], packets(s, 2, 0)[0]],
    "a mis-flagged packet": lambda s: [f"{s} ACK MOVJ", *packets(s, 0, 0)],
    "a p packet twice": lambda s: [f"{s} ACK MOVJ", *packets(s, 2, 0), packets(s, 2, 0)[1]],
    "DONE without the pose": lambda s: [f"{s} ACK MOVJ", f"{s} DONE MOVJ"],
    "a WAIT": lambda s: [f"{s} ACK MOVJ", f"{s} WAIT 0"],
    "another verb's DONE": lambda s: [f"{s} ACK MOVJ", f"{s} DONE RUN"],
}


@pytest.mark.parametrize("case", MOTIONS)
async def test_a_movj_reply_out_of_shape_is_a_sequence_error(case):
    fake, client = await _client(answering("MOVJ", MOTIONS[case]))
    with pytest.raises(SequenceError):
        async with asyncio.timeout(5):
            await client.movj([0] * 6)
    await client.close()
    await fake.stop()


async def test_zero_reports_no_pose_and_waits_once():
    fake, client = await _client(
        answering("ZERO", lambda seq: [f"{seq} ACK ZERO", f"{seq} WAIT 0", f"{seq} WAIT 0"]))
    asked = []

    async def operator(idx):
        asked.append(idx)

    with pytest.raises(SequenceError, match="WAIT 0"):
        await client.zero([0] * 6, on_wait=operator)
    assert asked == [0]
    with pytest.raises(SequenceError, match="give on_wait"):  # only an operator answers it
        await client.zero([0] * 6)
    await client.close()
    await fake.stop()


async def test_a_flood_of_unsolicited_frames_is_bounded_and_drops_the_controller():
    fake, client = await _client(answering("STAT", lambda seq: [
        b"".join(_frames(f"{900000 + k} ACK STAT" for k in range(5000))),
        f"{seq} STAT IDLE AUTO NONE 0 0 0"]))
    with pytest.raises(LinkLostError, match="answer no request"):
        await client.stat()
    assert client.unexpected_count == MAX_UNSOLICITED + 1 and len(client.unexpected) <= 50
    await asyncio.wait_for(fake.client_closed.wait(), 2)
    await client.close()
    await fake.stop()


async def test_frames_flooding_a_pending_request_drop_the_controller():
    fake, client = await _client(_run_replies(lambda seq: [
        f"{seq} WAIT 0", b"".join(_frames(f"{seq} DONE MOVJ" for _ in range(3000)))]))
    await client.load("CAL", Q[:1])

    async def slow_operator(idx):
        await asyncio.sleep(0.3)

    with pytest.raises(LinkLostError, match="frames for request"):
        _ = [p async for p in client.run("CAL", "STEP", on_wait=slow_operator)]
    assert "GO" not in fake.sent_verbs()  # the go-ahead never reached a flooding controller
    await client.close()
    await fake.stop()


@pytest.mark.parametrize(("helo", "error"), [([], LinkTimeoutError),
                                             (["{seq} ERR 15 version"], ControllerError),
                                             (["0 ERR 16 busy"], ControllerBusyError)])
async def test_a_failed_connect_leaves_nothing_open(helo, error):
    fake = FakeController(answering("HELO", lambda seq: [r.format(seq=seq) for r in helo]))
    address = await fake.start()
    client = ControllerClient(*address, FAST)
    with pytest.raises(error):
        await client.connect()
    await asyncio.wait_for(fake.client_closed.wait(), 2)  # the socket was closed
    assert client._reader_task is None and client._keepalive_task is None
    fake.client_closed.clear()
    with pytest.raises(error):
        async with ControllerClient(*address, FAST):
            raise AssertionError("never entered")
    await asyncio.wait_for(fake.client_closed.wait(), 2)
    await fake.stop()


async def test_busy_is_a_lost_link_that_reconnect_retries():
    def script(seq, verb, args):
        if verb == "HELO":
            script.helos += 1
            if script.helos < 3:
                return ["0 ERR 16 busy"]
        return well_behaved(seq, verb, args)

    script.helos = 0
    fake = FakeController(script)
    client = ControllerClient(*await fake.start(), FAST)
    with pytest.raises(LinkLostError, match="busy"):
        await client.connect()
    stat = await client.reconnect(first_delay_s=0.01)
    assert stat.state == "IDLE" and fake.connections == 3
    await client.close()
    await fake.stop()


async def test_a_malformed_reply_to_a_pending_request_says_so():
    fake, client = await _client(
        answering("STAT", lambda seq: [f"{seq} STAT IDLE AUTO NONE 0 0 x"]))
    with pytest.raises(PayloadError, match="malformed reply to request"):
        await client.stat()
    assert client.lost is None  # the link goes on: the frame was whole
    await client.close()
    await fake.stop()


def _frames(payloads):
    from protocol.codec import frame
    return (frame(p) for p in payloads)


@pytest.mark.parametrize(("verb", "reply", "message"), [
    ("STAT", "{seq} ACK STAT", "expected STAT reply"),
    ("BYE", "{seq} DONE BYE", "expected ACK BYE"),
    ("ABRT", "{seq} ACK BYE", "expected ACK ABRT"),
])
async def test_a_reply_of_the_wrong_kind_is_a_sequence_error(verb, reply, message):
    fake, client = await _client(answering(verb, lambda seq: [reply.format(seq=seq)]))
    call = {"STAT": client.stat, "BYE": client.bye, "ABRT": client.abort}[verb]
    with pytest.raises(SequenceError, match=message):
        await call()
    await client.close()
    await fake.stop()
