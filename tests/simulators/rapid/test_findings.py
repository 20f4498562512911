"""Issue 24's ten findings in the RAPID module, each run in the interpreter: every test passes
on the shipped module and fails on the module as it was before the issue
(ScrewcalServer_before_issue24.mod), which `before` runs to prove it."""

from __future__ import annotations

import asyncio
import contextlib
import socket
from pathlib import Path

import numpy as np
import pytest

from protocol.client import ControllerClient, Timeouts
from protocol.codec import FRAME_LEN, frame
from protocol.errors import ControllerError
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.pose import pose_from_transform
from simulators.irc5 import EmulatorSettings, IRC5Emulator, ProgramStoppedError
from simulators.truth import make_world
from tests.simulators.conftest import targets

BEFORE = Path(__file__).with_name("ScrewcalServer_before_issue24.mod")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.asynccontextmanager
async def controller(program: Path | None, **settings):
    """The emulator on a fixed free port (the module's PORT: a rebind stays on it)."""
    emu = IRC5Emulator(make_world(None, None),
                       EmulatorSettings(time_scale=0.0, program=program, **settings))
    await emu.start("127.0.0.1", free_port())
    try:
        yield emu
    finally:
        await emu.stop()


async def client_of(emu: IRC5Emulator, **timeouts) -> ControllerClient:
    c = ControllerClient(*emu.address, Timeouts(reply_s=2.0, pose_s=5.0, motion_s=5.0,
                                                **timeouts))
    await asyncio.wait_for(c.reconnect(first_delay_s=0.01), 5)
    return c


async def exchange(emu: IRC5Emulator, payloads: list[bytes | str], replies: int,
                   timeout: float = 3.0) -> list[str]:
    """Raw frames in, up to `replies` payloads out (fewer if the controller closes)."""
    reader, writer = await asyncio.open_connection(*emu.address)
    try:
        writer.write(b"".join(p if isinstance(p, bytes) else frame(p) for p in payloads))
        await writer.drain()
        out = []
        with contextlib.suppress(asyncio.IncompleteReadError, ConnectionError, TimeoutError):
            async with asyncio.timeout(timeout):
                for _ in range(replies):
                    out.append((await reader.readexactly(FRAME_LEN)).decode().split("#")[0])
        return out
    finally:
        writer.close()


def running(emu: IRC5Emulator) -> bool:
    return emu.running and emu.task is not None and emu.task.state == "running"


both = pytest.mark.parametrize("program", [None, BEFORE], ids=["shipped", "before"])


# 1. BYE (the server closes first: TIME_WAIT) must not stop the program -------------------------
@both
async def test_1_a_session_the_controller_closes_does_not_stop_it(program):
    # on a stack that holds a port whose connection it closed first (TIME_WAIT) for a minute:
    # the shipped module keeps its listening socket, the old one closed and bound it again
    async with controller(program, time_wait_s=60.0) as emu:
        reader, writer = await asyncio.open_connection(*emu.address)
        writer.write(frame("1 HELO 1") + frame("2 BYE"))
        await reader.readexactly(2 * FRAME_LEN)
        await asyncio.sleep(0.2)  # the controller closes first: its side is in TIME_WAIT
        writer.close()
        good = running(emu)
        if good:
            c = await client_of(emu)
            assert (await c.stat()).state == "IDLE"
            await c.close()
        else:
            assert "ERR_SOCK_ADDR_INUSE" in emu.task.stop_reason
    assert good == (program is None)


# 2. unbounded client input must not build strings past 80 characters ---------------------------
@both
async def test_2_long_tokens_are_refused_not_echoed_past_80_characters(program):
    async with controller(program) as emu:
        q = " ".join(f"{v:.4f}" for v in targets(1)[0])
        out = await exchange(emu, ["1 HELO 1", "2 LOAD CAL 1", f"2 j 2 0 {q}",
                                   "3 RUN CAL " + "S" * 69, "4 STAT"], 4)  # one per verb
        await asyncio.sleep(0.2)
        good = running(emu) and any(o.startswith("3 ERR 12") for o in out)
        if not good:
            assert "ERR_STRTOOLNG" in emu.task.stop_reason
    assert good == (program is None)


# 3. any error ends only the session; PP to Main closes what the program opened ------------------
@both
async def test_3_pp_to_main_mid_session_leaves_nothing_open(program):
    async with controller(program, time_wait_s=0.3) as emu:
        reader, writer = await asyncio.open_connection(*emu.address)
        writer.write(frame("1 HELO 1"))
        await reader.readexactly(FRAME_LEN)
        try:
            await emu.pp_to_main()
            restarted = True
        except ProgramStoppedError:
            restarted = False
        try:  # the old session's socket was closed by UNDO
            closed = await asyncio.wait_for(reader.read(1), 1) == b""
        except (TimeoutError, ConnectionError):
            closed = False
        writer.close()
        good = restarted and closed
        if good:
            c = await client_of(emu)
            assert (await c.stat()).state == "IDLE"
            await c.close()
    assert good == (program is None)


@both
async def test_3_a_motion_error_ends_neither_program_nor_session(program):
    """A collision (ERR_COLL_STOP) mid-list: ERR 21 and STATE FAULT (findings 3 and 7)."""
    async with controller(program) as emu:
        c = await client_of(emu)
        await c.load("CAL", targets(3))
        emu.settings.faults.collision_at_move = emu.task.services["motion"].moves + 1
        with contextlib.suppress(ControllerError, Exception):
            async with asyncio.timeout(2):  # the module before the issue never answers
                async for _ in c.run("CAL", "AUTO", count=3):
                    pass
        await asyncio.sleep(0.2)
        good = running(emu)
        if good:
            stat = await c.stat()
            assert stat.state == "FAULT" and stat.idx == 1
            await c.home()  # a move that succeeds clears the fault
            assert (await c.stat()).state == "IDLE"
        await c.close()
    assert good == (program is None)


# 4. idle polling must not fill the event log ---------------------------------------------------
@both
async def test_4_an_idle_owner_does_not_fill_the_event_log(program):
    async with controller(program, poll_s=0.02) as emu:
        c = await client_of(emu)
        before = emu.log.count("warning")
        await asyncio.sleep(0.5)  # 25 polls of SocketAccept \Time:=0.02 (a fraction: accepted)
        warnings = emu.log.count("warning") - before
        assert running(emu)
        await c.close()
    assert (warnings == 0) == (program is None)


# 5. a busy newcomer's data is read before its socket is closed ---------------------------------
@both
async def test_5_a_newcomer_gets_the_refusal_and_a_clean_close(program):
    async with controller(program) as emu:
        c = await client_of(emu)
        outcomes = []
        for _ in range(5):
            reader, writer = await asyncio.open_connection(*emu.address)
            writer.write(frame("1 HELO 1") + frame("2 STAT"))  # it talks at once
            await writer.drain()
            await asyncio.sleep(0.15)  # the refusal and the close are both on their way
            try:
                data = await asyncio.wait_for(reader.read(-1), 3)
                outcomes.append(data.startswith(b"0 ERR 16 busy#"))
            except ConnectionResetError:
                outcomes.append(False)
            writer.close()
        await c.close()
    assert all(outcomes) == (program is None), outcomes


# 6. the bind address is the cell's, not the LAN port's ------------------------------------------
@both
async def test_6_a_pc_on_the_service_port_can_connect(program):
    """The cell's PC reaches the controller at 127.0.0.1 (standing for 192.168.125.1, the
    service port); the controller's LAN address is another (127.0.0.2)."""
    try:
        async with controller(program, lan_ip="127.0.0.2") as emu:
            host = emu.address[0]
    except Exception:
        host = None
    assert (host == "127.0.0.1") == (program is None)


# 7. the module follows docs/protocol.md rule for rule ---------------------------------------------
@both
async def test_7_trailing_spaces_and_non_printable_bytes_drop_the_link(program):
    async with controller(program) as emu:
        bad = [frame("1 HELO 1")[:-1].replace(b"#", b" #", 1) + b"",  # "1 HELO 1 #"
               frame("1 HELO 1").replace(b"1 HELO", b"1\x01HELO", 1)]
        answered = [await exchange(emu, [b], 1, timeout=1.0) for b in bad]
    assert (answered == [[], []]) == (program is None), answered


@both
async def test_7_controller_side_verbs_are_err_23(program):
    async with controller(program) as emu:
        out = await exchange(emu, ["1 HELO 1", "2 ACK HELO", "3 DONE RUN"], 3)
    assert (out[1:] == ["2 ERR 23 controller-side verb", "3 ERR 23 controller-side verb"]) \
        == (program is None), out


# 8. ZERO is never DONE unless the operator entered the offsets -----------------------------------
@both
async def test_8_zero_is_not_done_while_nobody_entered_the_offsets(program):
    async with controller(program, operator=False) as emu:
        c = await client_of(emu)

        async def go(idx: int) -> None:
            return None

        zero_before = emu.world.truth.joint_zero.copy()
        try:
            await asyncio.wait_for(c.zero([0.5, 0, 0, 0, 0, 0], on_wait=go), 1.0)
            done = True
        except TimeoutError:
            done = False
        if not done:
            emu.pendant.press(emu.pendant.wait_prompt(1).keys.index("Cancel") + 1)
        else:  # reported DONE, yet the robot's zero never moved
            np.testing.assert_array_equal(emu.world.truth.joint_zero, zero_before)
        await c.close()
    assert (not done) == (program is None)


# 9. the pose is read once the robot is in position -----------------------------------------------
@both
async def test_9_the_reported_joints_are_the_settled_ones(program):
    async with controller(program, speed_deg_s=600.0) as emu:
        emu.settings.time_scale = 1.0  # moves of 0.02 s, then the servo settles for 0.25 s
        c = await client_of(emu)
        target = [20.0, 10.0, -10.0, 30.0, 40.0, 50.0]
        pose = await c.movj(target)
        error = np.max(np.abs(np.array(pose.joints_deg) - target))
        await c.close()
    assert (error < 1e-3) == (program is None), error


# 10. a p target's configuration does not depend on where the robot stands -------------------------
@both
async def test_10_a_pose_list_loads_the_same_from_anywhere(program):
    async with controller(program) as emu:
        c = await client_of(emu)
        q = np.array([[30.0, 10.0, 20.0, 60.0, 45.0, 30.0]])
        pose = pose_from_transform(flange_kinematics(emu.world.nominal, np.radians(q)))
        loaded = []
        for stand in ([0, 0, 0, 0, 45, 0], [0, 0, 0, 0, -45, 0]):  # wrist one way, the other
            await c.movj(stand)
            await c.load("CAL", poses=np.round(pose, 3).tolist())
            loaded.append([float(v) for v in emu.data("cal_list").items[0].f["robax"].f.values()])
        await c.close()
    same = np.allclose(loaded[0], loaded[1], atol=1e-3)
    assert same == (program is None), loaded
