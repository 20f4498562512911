"""The arm emulator measures the true robot that the IRC5 emulator moves.

The reader talks to the emulator over a link in memory (protocol.memory's `serial_link`) where the
socket adds nothing; over socket:// and the pty where the port is the point (pyserial's socket://
draining, a real serial device, a peer flooding a line, an arm in another process)."""

import asyncio
import contextlib

import numpy as np
import pytest

from protocol.arm import ArmReader
from protocol.errors import ArmLineError
from protocol.memory import serial_link
from screwcal.calibration.flange import frame_from_holes
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.se3 import exp_twist
from simulators.arm import ArmEmulator, WorldFileSource, WorldFileWriter
from tests.simulators.conftest import targets


@pytest.fixture
async def arm(emulator):
    a = ArmEmulator(emulator.world, seed=1)
    host, port = await a.start("127.0.0.1", 0, pty=True)
    a.url = f"socket://{host}:{port}"
    a.connect = serial_link(a.serve, asyncio.get_running_loop())
    yield a
    await a.stop()


async def in_memory(arm: ArmEmulator) -> ArmReader:
    """A reader joined to the emulated arm in memory."""
    return await asyncio.to_thread(ArmReader, "memory", connect=arm.connect)


async def test_holes_give_the_true_flange_within_the_arm_noise(client, emulator, arm):
    reader = await in_memory(arm)
    world = emulator.world
    await client.movj([20, 30, -20, 40, 50, 60])
    holes = await asyncio.to_thread(reader.read_holes, 2.0)
    np.testing.assert_allclose(holes.points_mm, world.true_holes_mm(), atol=6 * 0.013)
    # The holes' Gram-Schmidt frame (Eqs. 4.1-4.4) turns with the TRUE flange, not the nominal.
    T_true = forward_kinematics(world.truth, np.radians(world.q_deg.astype(float))[None])[0]
    layout = frame_from_holes(world.holes_mm)[0]
    measured = frame_from_holes(np.array(holes.points_mm))[0]
    np.testing.assert_allclose(measured[:3, :3], T_true[:3, :3] @ layout[:3, :3], atol=2e-3)
    reader.close()


async def test_the_reader_reads_in_memory_what_pyserial_reads_over_socket():
    """The same seeded arm asked three times over pyserial's socket:// and over the link in
    memory: the same lines, so the same holes and SEQs, bit for bit."""
    from tests.simulators.conftest import make_world

    world = make_world()
    read = {}
    for link in ("socket", "memory"):
        arm = ArmEmulator(world, seed=5)
        host, port = await arm.start("127.0.0.1", 0)
        arm.connect = serial_link(arm.serve, asyncio.get_running_loop())
        reader = await (asyncio.to_thread(ArmReader, f"socket://{host}:{port}")
                        if link == "socket" else in_memory(arm))
        read[link] = []
        for _ in range(3):
            await asyncio.to_thread(reader.request)
            read[link].append(await asyncio.to_thread(reader.read_holes, 2.0))
        await asyncio.to_thread(reader.close)
        await arm.stop()
    assert read["socket"] == read["memory"]
    assert [h.seqs for h in read["memory"]] == [(1, 2, 3), (4, 5, 6), (7, 8, 9)]


async def test_one_triple_per_pose_while_a_list_runs(client, emulator, arm):
    emulator.settings.time_scale = 0.05
    reader = await in_memory(arm)
    await client.load("CAL", targets(4, seed=5))
    sets = []
    async for _ in client.run("CAL", "AUTO"):
        sets.append(await asyncio.to_thread(reader.read_holes, 2.0))
        expected = emulator.world.true_holes_mm()
        np.testing.assert_allclose(sets[-1].points_mm, expected, atol=6 * 0.013)
    assert [s.seqs for s in sets] == [(1, 2, 3), (4, 5, 6), (7, 8, 9), (10, 11, 12)]
    assert reader.problems == []
    reader.close()


async def test_the_pty_serves_the_same_stream(client, arm):
    reader = await asyncio.to_thread(ArmReader, arm.pty_path)
    await client.movj([5, 10, -10, 0, 20, 0])
    holes = await asyncio.to_thread(reader.read_holes, 2.0)
    assert holes.seqs == (1, 2, 3)
    reader.close()


async def test_out_of_reach_holes_are_not_measured(client, emulator, arm):
    world = emulator.world
    world.truth = world.truth.with_frames(base=exp_twist([0, 0, 0, 3000.0, 0, 0]))  # arm far
    reader = await in_memory(arm)
    await client.home()
    with pytest.raises(ArmLineError, match="not measured: OUT_OF_REACH"):
        await asyncio.to_thread(reader.read_holes, 2.0)
    reader.close()


async def test_before_any_robot_the_arm_says_so(tmp_path):
    arm = ArmEmulator(WorldFileSource(tmp_path / "absent.json"), seed=2)  # not started
    arm.connect = serial_link(arm.serve, asyncio.get_running_loop())
    reader = await in_memory(arm)
    await asyncio.to_thread(reader.request)
    with pytest.raises(ArmLineError, match="not measured: NO_ROBOT"):
        await asyncio.to_thread(reader.read_holes, 2.0)
    reader.close()


async def test_an_arm_in_another_process_follows_the_world_file(tmp_path, client, emulator):
    path = tmp_path / "world.json"
    emulator.world.observers.append(WorldFileWriter(path))
    arm = ArmEmulator(WorldFileSource(path), seed=2)
    host, port = await arm.start("127.0.0.1", 0)
    reader = await asyncio.to_thread(ArmReader, f"socket://{host}:{port}")
    await client.movj([0, 20, -20, 0, 30, 0])
    holes = await asyncio.to_thread(reader.read_holes, 2.0)
    np.testing.assert_allclose(holes.points_mm, emulator.world.true_holes_mm(), atol=0.08)
    reader.close()
    await arm.stop()


async def test_drain_over_socket_then_each_pose_gets_its_own_holes(client, emulator, arm):
    """socket:// reports in_waiting as 0/1: a drain must still drop every stale line."""
    reader = await asyncio.to_thread(ArmReader, arm.url)
    for q in ([0, 10, 0, 0, 20, 0], [10, 20, -10, 0, 30, 0]):
        await client.movj(q)  # an arrival whose holes nobody reads
    await asyncio.sleep(0.05)
    await asyncio.to_thread(reader.drain)
    await client.movj([20, 30, -20, 0, 40, 0])
    holes = await asyncio.to_thread(reader.read_holes, 2.0)
    np.testing.assert_allclose(holes.points_mm, emulator.world.true_holes_mm(), atol=6 * 0.013)
    reader.close()


async def test_an_arm_process_follows_an_irc5_emulator_restarted_alone(tmp_path):
    """The restarted irc5 emulator counts its arrivals from 0 again: the arm following its
    world file must not wait for the old count (it stalled before)."""
    from simulators.truth import make_world

    path = tmp_path / "world.json"
    source = WorldFileSource(path, poll_s=0.001)
    first = make_world(None, None)
    writer = WorldFileWriter(path)
    for k in range(3):
        await first.set_joints(np.zeros(6) + k)
        writer(first)
    seen = await asyncio.wait_for(source.wait_arrival(0), 1)
    assert seen == 3
    restarted = make_world(None, None)  # a new process: arrivals from 0, a new writer
    again = WorldFileWriter(path)
    await restarted.set_joints(np.ones(6))
    again(restarted)
    assert await asyncio.wait_for(source.wait_arrival(seen), 1) == 4


async def test_a_100_kb_line_drops_that_peer_and_the_arm_goes_on(arm, client, caplog):
    host, port = arm.url.removeprefix("socket://").split(":")
    reader, writer = await asyncio.open_connection(host, int(port))
    writer.write(b"M" * 100_000 + b"\r\n")
    with contextlib.suppress(ConnectionError):
        await writer.drain()
        async with asyncio.timeout(3):
            assert await reader.read(-1) == b""  # dropped, nothing measured for it
    writer.close()
    assert not [r for r in caplog.records if r.levelname == "ERROR"]  # nothing unhandled
    good = await asyncio.to_thread(ArmReader, arm.url)
    await client.movj([20, 30, -20, 40, 50, 60])
    await asyncio.to_thread(good.request)
    holes = await asyncio.to_thread(good.read_holes, 2.0)
    assert len(holes.points_mm) == 3
    await asyncio.to_thread(good.close)
