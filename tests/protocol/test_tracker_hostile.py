"""The tracker driver against emScon servers that misbehave: every wrong answer is a link error
of the documented family or a time-out, never a hang, never a measurement taken from the wrong
packet; nothing of the OS's socket errors escapes."""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

from protocol import emscon as es
from protocol.errors import (
    BeamBrokenError,
    LinkLostError,
    LinkTimeoutError,
    TrackerError,
    TrackerRefusedError,
)
from protocol.tracker import TrackerClient

Answer = Callable[[es.Command], bytes | None]  # None: close the connection


def _measurement(xyz=(2500.0, 0.0, 300.0), status=es.RS_ALL_OK) -> es.SingleMeasurement:
    return es.SingleMeasurement(status=status, meas_mode=0, is_try_mode=False, xyz=xyz,
                                std=(0.01, 0.01, 0.01), std_total=0.02, covar=None,
                                temperature=20.0, pressure=1013.0, humidity=50.0)


@contextmanager
def server(answer: Answer) -> Iterator[tuple[str, int]]:
    """A one-connection emScon server answering each command with `answer(command)`."""
    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(5)

    def serve() -> None:
        try:
            conn, _ = listener.accept()
        except OSError:
            return
        reader = es.PacketReader(from_client=True)
        with conn:
            while True:
                try:
                    data = conn.recv(4096)
                except OSError:
                    return
                if not data:
                    return
                for packet in reader.feed(data):
                    assert isinstance(packet, es.Command)
                    reply = answer(packet)
                    if reply is None:
                        return
                    conn.sendall(reply)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield listener.getsockname()[:2]
    finally:
        listener.close()
        thread.join(5)


def _measuring(result: bytes, before: bytes = b"") -> Answer:
    """OK to everything; StartMeasurement answered by `before`, its answer, then `result`."""
    def answer(command: es.Command) -> bytes | None:
        if command.command == es.C_START_MEASUREMENT:
            return before + es.encode_answer(command.command, 0) + result
        return es.encode_answer(command.command, 0)
    return answer


def _measure(address: tuple[str, int], timeout_s: float = 1.0):
    with TrackerClient(*address, timeout_s=timeout_s) as tracker:
        return tracker.measure()


def test_status_changes_and_pointing_reports_before_the_result_are_skipped():
    noise = es.encode_status_change(es.SSC_MEAS_STATUS_READY) + \
        es.encode_reflector_position((1.0, 2.0, 3.0))
    with server(_measuring(noise + es.encode_measurement(_measurement()), noise)) as address:
        assert _measure(address).xyz_mm == (2500.0, 0.0, 300.0)


@pytest.mark.parametrize(("reply", "error", "what"), [
    (b"", LinkTimeoutError, "in time"),  # the answer, never the result
    (es.HEADER.pack(1 << 20, 2) + bytes(8), LinkLostError, "out of"),  # a garbage size
    (es.HEADER.pack(16, 3) + bytes(8), LinkLostError, "cannot be read"),  # an unknown type
    (es.encode_measurement(_measurement(status=es.RS_MEASUREMENT_STATUS_NOT_READY)),
     BeamBrokenError, "not found"),  # a failed result, and the search finds nothing
    (es.encode_error(es.C_START_MEASUREMENT, es.RS_WRONG_PARAMETER), TrackerRefusedError,
     "status 3"),
    (es.encode_error(es.C_START_MEASUREMENT, es.RS_SERVER_BUSY), TrackerError, "busy"),
])
def test_a_wrong_result_is_a_named_error_never_a_point(reply, error, what):
    def answer(command: es.Command) -> bytes | None:
        if command.command == es.C_FIND_REFLECTOR:
            return es.encode_answer(command.command, es.RS_MEASUREMENT_STATUS_NOT_READY)
        return _measuring(reply)(command)

    with server(answer) as address, pytest.raises(error, match=what):
        _measure(address, timeout_s=0.5)


def test_the_answer_of_another_command_is_not_taken_for_this_ones():
    def answer(command: es.Command) -> bytes | None:
        if command.command == es.C_INITIALIZE:  # a stale answer first, then its own
            return es.encode_answer(es.C_GET_UNITS, 0, 1, 1, 0, 0, 0) + \
                es.encode_answer(es.C_INITIALIZE, es.RS_TRACKER_NOT_INITIALIZED)
        return es.encode_answer(command.command, 0)

    with server(answer) as address, TrackerClient(*address, timeout_s=1) as tracker, \
            pytest.raises(TrackerError, match="not initialised"):
        tracker.initialise()


def test_a_tracker_that_hangs_up_or_is_not_there():
    with server(lambda command: None) as address, pytest.raises(LinkLostError,
                                                                match="closed the connection"):
        _measure(address)
    free = socket.create_server(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()
    with pytest.raises(LinkLostError, match="cannot reach the tracker"):
        TrackerClient("127.0.0.1", port, connect_timeout_s=1)


def test_a_command_with_wrong_values_for_its_answer_is_refused_by_the_reader():
    # the answer of GetEnvironmentParams without its three values: a packet of the wrong size
    def answer(command: es.Command) -> bytes | None:
        if command.command == es.C_GET_ENVIRONMENT_PARAMS:
            return struct.pack("<iIII", 16, es.DT_COMMAND, command.command, 0)
        return es.encode_answer(command.command, 0)

    with server(answer) as address, TrackerClient(*address, timeout_s=1) as tracker, \
            pytest.raises(LinkLostError, match="has 16 bytes, expected 40"):
        tracker.environment()
