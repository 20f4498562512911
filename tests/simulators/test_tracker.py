"""The emulated laser tracker (emScon server side) against this project's driver and against the
published `cesapi` client: it measures the true SMR of the emulated robot within its own
uncertainty, refuses when the beam is broken, and its faults map into the link's errors.

The driver talks to the emulator over a link in memory where the socket adds nothing
(protocol.memory's `socket_link`); over TCP where the socket is the point: the first
measurements (the same figures both ways), the published client, the garbage a peer sends."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pytest

from protocol import emscon as es
from protocol.errors import (
    BeamBrokenError,
    LinkError,
    LinkLostError,
    TrackerNotInitialisedError,
    TrackerRefusedError,
    TrackerWarmingUpError,
)
from protocol.memory import socket_link
from protocol.tracker import TrackerClient, parse_tracker_url
from screwcal.instrument import tracker_noise_mm
from simulators.tracker import (
    TrackerEmulator,
    TrackerFaults,
    WorldSource,
    beam_blocked,
    refractive_index,
    station_in_world,
    view_of,
)
from simulators.truth import make_world
from simulators.world import World

SEEN = np.array([0.0, 30.0, 20.0, 0.0, -50.0, 0.0], dtype=np.float32)  # the SMR faces the tracker
AWAY = np.array([0.0, 0.0, 0.0, 0.0, 90.0, 0.0], dtype=np.float32)  # it faces the floor


@contextmanager
def running(world: World, **kwargs) -> Iterator[TrackerEmulator]:
    """A tracker emulator served from its own thread's event loop (the driver is blocking), on
    TCP at `emu.url` and in memory by `emu.connect`."""
    loop = asyncio.new_event_loop()
    emu = TrackerEmulator(WorldSource(world), **kwargs)
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    try:
        host, port = asyncio.run_coroutine_threadsafe(emu.start(), loop).result(5)
        emu.url = f"emscon://{host}:{port}"
        emu.connect = socket_link(emu.serve, loop)
        yield emu
    finally:
        asyncio.run_coroutine_threadsafe(emu.stop(), loop).result(5)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(5)
        loop.close()


def driver(emu: TrackerEmulator) -> TrackerClient:
    """The driver joined to the emulator in memory."""
    return TrackerClient.open(emu.url, connect=emu.connect)


def _true_in_tracker(world: World) -> np.ndarray:
    return view_of(world).smr_mm - station_in_world(world)


def _mahalanobis(err: np.ndarray, C: np.ndarray) -> float:
    return float(err @ np.linalg.solve(C, err))


def test_driver_measures_the_true_smr_within_its_uncertainty():
    world = make_world(None, None)
    world.q_deg = SEEN
    with running(world, seed=1) as emu, driver(emu) as tracker:
        tracker.setup()
        assert tracker.units() == (es.LU_MILLIMETER, es.AU_DEGREE, es.TU_CELSIUS, es.PU_MBAR,
                                   es.HU_RH)
        points = [tracker.measure() for _ in range(40)]
    truth = _true_in_tracker(world)
    distance = float(np.linalg.norm(truth))
    radial, lateral = tracker_noise_mm(distance)
    C = points[0].covariance
    u = truth / distance
    assert u @ C @ u == pytest.approx(radial ** 2, rel=1e-6)  # the covariance the model's
    assert np.trace(C) == pytest.approx(radial ** 2 + 2 * lateral ** 2, rel=1e-6)
    d2 = [_mahalanobis(np.asarray(p.xyz_mm) - truth, p.covariance) for p in points]
    assert max(d2) < 16.3  # chi2(3) at 0.999
    assert 1.5 < np.mean(d2) < 4.5  # chi2(3): mean 3
    assert points[0].temperature_c == 20.0 and points[0].pressure_mbar == 1013.25


def test_the_driver_reads_over_tcp_what_it_reads_in_memory():
    world = make_world(None, None)
    world.q_deg = SEEN
    measured = {}
    for link in ("tcp", "memory"):
        with running(world, seed=9) as emu, \
                (TrackerClient.open(emu.url) if link == "tcp" else driver(emu)) as tracker:
            tracker.setup()
            measured[link] = [(p.xyz_mm, p.covariance_mm2) for p in
                              (tracker.measure() for _ in range(5))]
    assert measured["tcp"] == measured["memory"]


def test_beam_broken_by_the_reflector_facing_away_then_searched_and_measured():
    world = make_world(None, None)
    world.q_deg = AWAY
    with running(world, seed=2) as emu, driver(emu) as tracker:
        tracker.setup()
        with pytest.raises(BeamBrokenError, match="not found"):
            tracker.measure()
        assert any("faces away" in why for why in emu.state.refused)
        world.q_deg = SEEN
        point = tracker.measure()
    assert not point.searched
    assert np.linalg.norm(np.asarray(point.xyz_mm) - _true_in_tracker(world)) < 0.1


def test_a_short_beam_break_is_cured_by_find_reflector_and_a_second_try():
    world = make_world(None, None)
    world.q_deg = SEEN
    with running(world, seed=3, faults=TrackerFaults(beam=1, beam_n=1)) as emu, \
            driver(emu) as tracker:
        tracker.setup()
        first = tracker.measure()
        second = tracker.measure()  # attempt 1 broken: found again, attempt 2 measures
        assert second.searched and not first.searched
        assert emu.state.attempts == 3


def test_faults_map_into_the_link_errors():
    world = make_world(None, None)
    world.q_deg = SEEN
    faults = TrackerFaults(beam=1, beam_n=2, warm=4, uninit=5, drop=7)
    with running(world, seed=4, faults=faults) as emu:
        with driver(emu) as tracker:
            with pytest.raises(TrackerNotInitialisedError):
                tracker.measure()  # attempt 0 (not initialised): no search for this one
            tracker.setup()
            with pytest.raises(BeamBrokenError) as beam:
                tracker.measure()  # attempt 1 broken, the search fails (broken until 3)
            assert isinstance(beam.value, LinkError)
            assert tracker.measure().searched  # attempt 2 broken, found, attempt 3 measures
            with pytest.raises(TrackerWarmingUpError):
                tracker.measure()  # attempt 4
            with pytest.raises(TrackerNotInitialisedError):
                tracker.measure()  # attempt 5: the initialisation lost
            tracker.initialise()
            tracker.measure()  # attempt 6
            with pytest.raises(LinkLostError, match="closed the connection"):
                tracker.measure()  # attempt 7: the connection dropped
        with driver(emu) as tracker:  # reconnect and go on
            tracker.setup(initialise=False)
            tracker.measure()


def test_wrong_weather_is_a_scale_error():
    world = make_world(None, None)
    world.q_deg = SEEN
    with running(world, seed=5, air=(30.0, 1013.25, 50.0)) as emu, \
            driver(emu) as tracker:
        tracker.setup()
        assert tracker.environment() == (30.0, 1013.25, 50.0)  # its station reads the air
        right = np.mean([np.linalg.norm(tracker.measure().xyz_mm) for _ in range(20)])
        tracker.set_environment(20.0, 1013.25, 50.0)  # 10 deg C wrong
        wrong = np.mean([np.linalg.norm(tracker.measure().xyz_mm) for _ in range(20)])
    ppm = (refractive_index(30.0, 1013.25, 50.0) / refractive_index(20.0, 1013.25, 50.0) - 1)
    distance = np.linalg.norm(_true_in_tracker(world))
    assert -11e-6 < ppm < -8e-6  # about -1 ppm per deg C
    assert wrong - right == pytest.approx(ppm * distance, abs=0.004)
    assert right == pytest.approx(distance, abs=0.004)


def test_links_of_the_robot_break_the_beam():
    world = make_world(None, None)
    world.q_deg = SEEN
    view = view_of(world)
    station = station_in_world(world)
    assert beam_blocked(view, station) is None
    # a tracker behind the robot's base, looking through the robot at the SMR: its axis
    # turned toward it, only the links can break the beam
    behind = view.smr_mm + 3000.0 * (view.skeleton_mm[1] - view.smr_mm) / \
        np.linalg.norm(view.skeleton_mm[1] - view.smr_mm)
    facing = type(view)(view.smr_mm, (behind - view.smr_mm) / np.linalg.norm(
        behind - view.smr_mm), view.skeleton_mm, view.base)
    assert "breaks the beam" in beam_blocked(facing, behind)
    far = station + 40000.0 * (station - view.smr_mm) / np.linalg.norm(station - view.smr_mm)
    assert "out of range" in beam_blocked(view, far)


def test_tracker_urls():
    assert parse_tracker_url("emscon://10.0.0.5") == ("10.0.0.5", 700)
    assert parse_tracker_url("emscon://localhost:7000") == ("localhost", 7000)
    for bad in ("tcp://x:1", "emscon://", "emscon://x:99999", "emscon://x/path"):
        with pytest.raises(ValueError, match="tracker address"):
            parse_tracker_url(bad)


def test_fault_text():
    assert TrackerFaults.parse("beam=3,beam_n=2,drop=5") == TrackerFaults(beam=3, beam_n=2,
                                                                          drop=5)
    for bad, what in (("laser=1", "one of"), ("beam=x", "whole number"), ("drop=-1", "negative")):
        with pytest.raises(ValueError, match=what):
            TrackerFaults.parse(bad)


def test_the_published_cesapi_client_measures_the_emulated_tracker():
    """cesapi as published on PyPI (its own socket thread and command loop): connect,
    initialise, set the units, measure one point; the point is the true SMR within the
    emulated uncertainty."""
    connection_module = pytest.importorskip("CESAPI.connection")
    command_module = pytest.importorskip("CESAPI.command")
    packet = pytest.importorskip("CESAPI.packet")
    world = make_world(None, None)
    world.q_deg = SEEN
    with running(world, seed=6) as emu:
        host, port = parse_tracker_url(emu.url)
        connection = connection_module.Connection()
        try:
            connection.connect(host=host, port=port)
            command = command_module.CommandSync(connection)
            command.Initialize()
            units = packet.SystemUnitsDataT()
            units.lenUnitType = packet.ES_LU_Millimeter
            units.angUnitType = packet.ES_AU_Degree
            units.tempUnitType = packet.ES_TU_Celsius
            units.pressUnitType = packet.ES_PU_Mbar
            units.humUnitType = packet.ES_HU_RH
            command.SetUnits(units)
            command.SetCoordinateSystemType(packet.ES_CS_RHR)
            command.SetMeasurementMode(packet.ES_MM_Stationary)
            result = command.StartMeasurement()
        finally:
            connection.disconnect()
    assert type(result) is packet.SingleMeasResultT
    measured = np.array([result.dVal1, result.dVal2, result.dVal3])
    truth = _true_in_tracker(world)
    radial, lateral = tracker_noise_mm(float(np.linalg.norm(truth)))
    assert np.linalg.norm(measured - truth) < 4.0 * np.hypot(radial, np.sqrt(2) * lateral)
    assert (result.dTemperature, result.dPressure, result.dHumidity) == (20.0, 1013.25, 50.0)
    assert result.dStd1 > 0 and result.dStdTotal > result.dStd1


def test_three_smrs_each_found_by_pointing_at_it():
    from screwcal.calibration.line_of_sight import THREE_SMRS_MM

    world = make_world(None, None)
    world.q_deg = SEEN
    source = WorldSource(world, THREE_SMRS_MM)
    station = station_in_world(world)
    truth = [v.smr_mm - station for v in source.tracker_views()]
    loop_world = running(world, seed=7)
    with loop_world as emu:
        emu.source = source
        with driver(emu) as tracker:
            tracker.setup()  # locked on the first SMR
            first = np.asarray(tracker.measure().xyz_mm)
            assert np.linalg.norm(first - truth[0]) < 0.1
            for k in (1, 2):  # pointed 10 mm off: still captured
                tracker.go_position(truth[k] + np.array([6.0, -8.0, 0.0]))
                assert np.linalg.norm(np.asarray(tracker.measure().xyz_mm) - truth[k]) < 0.1
            with pytest.raises(BeamBrokenError, match="GoPosition"):
                tracker.go_position(truth[0] + np.array([0.0, 0.0, 60.0]))  # nothing there
            tracker.initialise()  # back home, then onto the first SMR
            assert np.linalg.norm(np.asarray(tracker.measure().xyz_mm) - truth[0]) < 0.1


def test_the_emulator_answers_what_it_does_not_know_and_drops_garbage():
    import socket

    world = make_world(None, None)
    world.q_deg = SEEN
    with running(world, seed=8) as emu:
        host, port = parse_tracker_url(emu.url)
        with socket.create_connection((host, port), timeout=5) as sock:
            sock.sendall(es.HEADER.pack(12, es.DT_COMMAND) + (999).to_bytes(4, "little"))
            sock.sendall(es.encode_command(es.C_GET_TRACKER_STATUS))
            reader, got = es.PacketReader(), []
            while len(got) < 2:
                got += reader.feed(sock.recv(4096))
            assert got == [es.Answer(999, es.RS_NOT_IMPLEMENTED, ()),
                           es.Answer(es.C_GET_TRACKER_STATUS, 0, (es.TS_NOT_READY,))]
            sock.sendall(es.HEADER.pack(1 << 20, 0) + bytes(8))  # a size no packet has
            assert sock.recv(4096) == b""  # dropped
        with TrackerClient.open(emu.url) as tracker:  # and the next client is served
            tracker.setup()
            assert tracker.command(es.C_GET_TRACKER_STATUS).values == (es.TS_READY,)
            with pytest.raises(TrackerRefusedError, match="status 3"):
                tracker.set_environment(20.0, 3000.0, 50.0)  # no air at 3 bar
