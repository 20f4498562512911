"""Emulator in the loop: the real client, the real emulator, real TCP on port 0."""

import asyncio

import numpy as np
import pytest

from protocol.client import ControllerClient, Timeouts
from protocol.codec import FRAME_LEN, Stat, encode, frame
from protocol.errors import ControllerError, LinkLostError, SequenceError
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.pose import pose_from_transform
from screwcal.kinematics.robots import irb1600
from tests.simulators.conftest import targets


@pytest.mark.parametrize("list_name", ["CAL", "PERF"])
async def test_auto_run_delivers_every_pose_once_in_order(client, emulator, list_name):
    q = targets(40)
    await client.load(list_name, q)
    got = [p async for p in client.run(list_name, "AUTO", count=40)]
    assert [p.idx for p in got] == list(range(40))
    assert [p.flag for p in got] == [0] + [1] * 38 + [2]
    np.testing.assert_allclose([p.joints_deg for p in got], q, atol=1e-4)
    # p packets are the NOMINAL kinematics of the j packets (as CRobT), 32-bit rounded.
    nominal = pose_from_transform(flange_kinematics(irb1600(), np.radians([p.joints_deg
                                                                          for p in got])))
    np.testing.assert_allclose(np.array([p.tool0 for p in got])[:, :3], nominal[:, :3],
                               atol=2e-3)
    stat = await client.stat()
    assert (stat.state, stat.list, stat.idx, stat.count) == ("IDLE", list_name, 40, 40)


@pytest.mark.parametrize("list_name", ["CAL", "PERF"])
async def test_step_mode_waits_for_every_go_ahead(client, emulator, list_name):
    q = targets(5)
    await client.load(list_name, q)
    asked = []

    async def operator(idx: int) -> None:
        # The robot has not moved to this pose before the go-ahead.
        assert emulator.world.arrivals == idx
        asked.append(idx)

    got = [p.idx async for p in client.run(list_name, "STEP", on_wait=operator, count=5)]
    assert asked == got == [0, 1, 2, 3, 4]


async def test_a_refused_go_ahead_never_moves_the_robot(client, emulator):
    await client.load("CAL", targets(3))

    async def operator(idx: int) -> None:
        if idx == 1:
            raise KeyboardInterrupt  # the operator says no

    before = emulator.world.arrivals
    with pytest.raises(KeyboardInterrupt):
        async for _ in client.run("CAL", "STEP", on_wait=operator):
            pass
    assert emulator.world.arrivals == before + 1  # pose 0 only
    await client.abort()  # the waiting run is ended cleanly
    assert (await client.stat()).state == "IDLE"


async def test_keep_alive_holds_a_quiet_owner_and_notices_a_drop(emulator):
    emulator.settings.idle_timeout_s = 0.3
    quiet = ControllerClient(*emulator.address, Timeouts(keepalive_s=10))
    kept = ControllerClient(*emulator.address, Timeouts(keepalive_s=0.05))
    await quiet.connect()
    await asyncio.sleep(0.6)  # silent beyond the idle time: dropped
    assert isinstance(quiet.lost, LinkLostError)
    await quiet.close()
    await kept.connect()
    await asyncio.sleep(0.9)  # three idle times, kept by STAT
    assert kept.lost is None and (await kept.stat()).state == "IDLE"
    assert emulator.data("last_seq") == 1  # STAT does not count as a completed request
    kept._writer.transport.abort()  # the link breaks: the keep-alive notices
    await asyncio.sleep(0.3)
    assert kept.lost is not None
    await kept.close()


async def test_task_space_list_is_solved_by_the_controller(client):
    q = targets(3)
    poses = pose_from_transform(flange_kinematics(irb1600(), np.radians(q)))
    await client.load("PERF", poses=np.round(poses, 3))
    got = [p async for p in client.run("PERF", "AUTO")]
    np.testing.assert_allclose([p.tool0 for p in got], poses, atol=2e-3)


async def test_out_of_limit_targets_are_refused_before_any_motion(client, emulator):
    before = emulator.world.arrivals
    bad = targets(4)
    bad[2, 1] = 151.0  # joint 2 limit is 150
    with pytest.raises(ControllerError) as err:
        await client.load("CAL", bad)
    assert err.value.code == 20 and "pose 2" in err.value.text
    with pytest.raises(ControllerError) as err:
        await client.movj([0, 0, -250, 0, 0, 0])
    assert err.value.code == 20
    assert emulator.world.arrivals == before
    assert emulator.data("cal_count") == 0  # the list was left unchanged: nothing loaded
    with pytest.raises(SequenceError, match="no CAL list loaded"):  # nor does the client run it
        _ = [p async for p in client.run("CAL")]


async def test_movj_home_and_zero(client, emulator):
    moved = await client.movj([10, 20, -30, 40, 50, 60])
    np.testing.assert_allclose(moved.joints_deg, [10, 20, -30, 40, 50, 60], atol=1e-4)
    home = await client.home()
    np.testing.assert_allclose(home.tool0[:3], [815, 0, 961.5], atol=1e-3)
    zero_before = emulator.world.truth.joint_zero.copy()
    await client.zero([-2.0, -1.1, -3.1, 2.0, -3.7, 4.6],  # the correction of Table 11
                      on_wait=_accept)
    np.testing.assert_allclose(np.degrees(emulator.world.truth.joint_zero - zero_before),
                               [-2.0, -1.1, -3.1, 2.0, -3.7, 4.6], atol=1e-6)
    np.testing.assert_allclose(emulator.world.q_deg, 0, atol=1e-4)  # that position now reads 0
    np.testing.assert_allclose(np.degrees(emulator.world.truth.joint_zero), 0, atol=1e-5)


async def test_zero_waits_for_the_go_ahead_then_the_flexpendant(client, emulator):
    """A real IRC5 stops after ZERO (WAIT 0); after the go-ahead the FlexPendant shows the
    offsets, the operator enters them and presses Done: only then DONE ZERO."""
    emulator.settings.operator = False  # this test is the person at the controller
    zero_before = emulator.world.truth.joint_zero.copy()
    waited = []

    async def operator(idx: int) -> None:
        waited.append(idx)
        # nothing applied while the person is at the controller
        np.testing.assert_array_equal(emulator.world.truth.joint_zero, zero_before)

    async def person() -> None:
        prompt = await asyncio.to_thread(emulator.pendant.wait_prompt, 5.0)
        assert "j1..j6 0.5000 0.0000 0.0000 0.0000 0.0000 0.0000" in prompt.screen
        await asyncio.sleep(0.2)  # the operator takes a moment: no DONE meanwhile
        emulator.pendant.press(emulator.enter_offsets(prompt))

    helper = asyncio.create_task(person())
    await client.zero([0.5, 0, 0, 0, 0, 0], on_wait=operator)
    await helper
    assert waited == [0]
    assert np.degrees(emulator.world.truth.joint_zero - zero_before)[0] == pytest.approx(0.5)


async def test_zero_cancelled_on_the_flexpendant_is_never_reported_done(client, emulator):
    """Finding 8: RAPID cannot write the offsets; Cancel on the pendant is ERR 22, not DONE."""
    emulator.settings.operator = False
    zero_before = emulator.world.truth.joint_zero.copy()

    async def cancel() -> None:
        prompt = await asyncio.to_thread(emulator.pendant.wait_prompt, 5.0)
        emulator.pendant.press(prompt.keys.index("Cancel") + 1)

    helper = asyncio.create_task(cancel())
    with pytest.raises(ControllerError) as err:
        await client.zero([0.5, 0, 0, 0, 0, 0], on_wait=_accept)
    await helper
    assert err.value.code == 22
    np.testing.assert_array_equal(emulator.world.truth.joint_zero, zero_before)
    assert (await client.stat()).state == "IDLE"


async def _accept(idx: int) -> None:
    return None


async def test_abort_stops_the_run_after_the_current_move(emulator):
    emulator.settings.time_scale = 0.05  # 60 deg/s scaled: a few ms a move
    c = ControllerClient(*emulator.address, Timeouts(pose_s=5, motion_s=5))
    await c.connect()
    await c.load("CAL", targets(30))
    seen = []
    with pytest.raises(ControllerError) as err:
        async for p in c.run("CAL", "AUTO"):
            seen.append(p.idx)
            if p.idx == 2:
                await c.abort()
    assert err.value.code == 22
    assert 3 <= len(seen) < 30 and seen == list(range(len(seen)))
    assert (await c.stat()).state == "IDLE"
    await c.close()


async def test_unknown_verb_is_answered_and_the_session_goes_on(emulator):
    reader, writer = await asyncio.open_connection(*emulator.address)
    writer.write(frame("7 FLY") + encode(Stat(8)))
    await writer.drain()
    data = await asyncio.wait_for(reader.readexactly(2 * FRAME_LEN), 2)
    assert data[:FRAME_LEN].startswith(b"7 ERR 11 ")
    assert data[FRAME_LEN:].startswith(b"8 STAT IDLE")
    writer.close()


async def test_controller_keeps_listening_after_a_client_leaves(emulator):
    for _ in range(3):
        async with ControllerClient(*emulator.address) as c:
            assert (await c.stat()).state == "IDLE"
    assert emulator.sessions == 3
