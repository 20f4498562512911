"""The laser tracker's driver: Leica emScon TPI over TCP (`protocol.emscon` is the codec).

    with TrackerClient.open("emscon://10.0.0.5:700") as tracker:
        tracker.setup()               # Initialize, then units, coordinates and mode, explicitly
        point = tracker.measure()     # one stationary single-point measurement

`setup` initialises the tracker (unless told it already is) and sets, whatever the tracker's
settings were: lengths in mm, angles in degrees, deg C, mbar, %RH; Cartesian right-handed
coordinates; the stationary measurement mode; the extended statistics (the result then carries
the point's covariance). `measure` returns a `TrackerPoint`: the reflector's position (mm), its
3x3 covariance (mm^2), the weather the tracker measured with, and the time.

The tracker's refusals map into the link's error family (protocol/errors.py), so a job pauses on
them and resumes: no reflector locked (the beam is broken, or the reflector faces away) ->
`FindReflector` at the last distance, then one more try, then `BeamBrokenError`; not initialised
-> `TrackerNotInitialisedError`; the laser warming up -> `TrackerWarmingUpError`; a dropped or
silent connection -> `LinkLostError` / `LinkTimeoutError`. A refusal no reconnect cures (a wrong
parameter) is a `TrackerRefusedError`. The OS's socket errors never escape.
"""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from urllib.parse import urlsplit

import numpy as np

from protocol import emscon as es
from protocol.errors import (
    BeamBrokenError,
    FramingError,
    LinkLostError,
    LinkTimeoutError,
    TrackerError,
    TrackerNotInitialisedError,
    TrackerRefusedError,
    TrackerWarmingUpError,
)
from protocol.memory import ByteSocket

SCHEME = "emscon"
INITIALISE_TIMEOUT_S = 90.0  # an AT40x initialises in well under this; cesapi waits as long

_BEAM_BROKEN = {es.RS_MEASUREMENT_STATUS_NOT_READY}
_WARMING_UP = {es.RS_ADM_STARTUP_BUSY, es.RS_SYSTEM_NOT_READY}


@dataclass(frozen=True)
class TrackerPoint:
    """One measured reflector position, mm in the tracker's frame (RHR), with its covariance
    (mm^2, row-major 3x3), the weather it was measured in, and when (Unix time, s)."""

    xyz_mm: tuple[float, float, float]
    covariance_mm2: tuple[float, ...]
    temperature_c: float
    pressure_mbar: float
    humidity_pct: float
    time_s: float
    searched: bool = False  # the reflector was searched for (FindReflector) before it

    @property
    def covariance(self) -> np.ndarray:
        return np.asarray(self.covariance_mm2, dtype=float).reshape(3, 3)


def covariance_of(m: es.SingleMeasurement) -> tuple[float, ...]:
    """The 3x3 covariance of a result (row-major): the extended result's covariances, or the
    standard result's standard deviations on the diagonal."""
    sx, sy, sz = m.std
    c12, c13, c23 = m.covar or (0.0, 0.0, 0.0)
    return (sx * sx, c12, c13, c12, sy * sy, c23, c13, c23, sz * sz)


def parse_tracker_url(url: str) -> tuple[str, int]:
    """`emscon://HOST[:PORT]` (port 700 by default) -> (host, port); ValueError naming what is
    wrong."""
    parts = urlsplit(url)
    if parts.scheme != SCHEME or not parts.hostname or parts.path not in ("", "/"):
        raise ValueError(f"tracker address {url!r}: expected emscon://HOST[:PORT]")
    try:
        port = parts.port or es.DEFAULT_PORT
    except ValueError:
        raise ValueError(f"tracker address {url!r}: the port is not a number in 1-65535") \
            from None
    return parts.hostname, port


def _status_error(status: int, command: int, what: str) -> Exception:
    """The error of the link family a status means."""
    text = f"the tracker refused {what} (emScon status {status})"
    if status in _BEAM_BROKEN:
        return BeamBrokenError(f"{what}: no reflector locked, the beam is broken or the "
                               f"reflector faces away (emScon status {status})", status, command)
    if status == es.RS_TRACKER_NOT_INITIALIZED:
        return TrackerNotInitialisedError(f"{what}: the tracker is not initialised (emScon "
                                          f"status {status}): initialise it", status, command)
    if status in _WARMING_UP:
        return TrackerWarmingUpError(f"{what}: the tracker's laser is still warming up (emScon "
                                     f"status {status}): wait and try again", status, command)
    if status == es.RS_SERVER_BUSY:
        return TrackerError(f"{what}: the tracker is busy (emScon status {status})", status,
                            command)
    return TrackerRefusedError(text, status, command)


class TrackerClient:
    """One connection to an emScon server. Not thread-safe: one caller at a time.

    `connect`: what opens the connection (default: TCP to host:port); a test joins the driver
    to an emulated tracker in memory with protocol.memory's `socket_link`."""

    def __init__(self, host: str, port: int = es.DEFAULT_PORT, *, timeout_s: float = 10.0,
                 connect_timeout_s: float = 5.0,
                 connect: Callable[[], ByteSocket] | None = None):
        self.host, self.port, self.timeout_s = host, port, timeout_s
        self.address = f"{SCHEME}://{host}:{port}"
        self._reader = es.PacketReader()
        self._pending: list[es.Packet] = []
        self.status_changes: list[int] = []  # ES_SystemStatusChange codes seen, in order
        self._last_distance_mm = 0.0
        try:
            self._sock: ByteSocket = connect() if connect is not None else \
                socket.create_connection((host, port), timeout=connect_timeout_s)
        except OSError as err:
            raise LinkLostError(f"cannot reach the tracker at {self.address}: {err}") from err

    @classmethod
    def open(cls, url: str, *, timeout_s: float = 10.0, connect_timeout_s: float = 5.0,
             connect: Callable[[], ByteSocket] | None = None) -> TrackerClient:
        host, port = parse_tracker_url(url)
        return cls(host, port, timeout_s=timeout_s, connect_timeout_s=connect_timeout_s,
                   connect=connect)

    def close(self) -> None:
        self._sock.close()

    def __enter__(self) -> TrackerClient:
        return self

    def __exit__(self, kind: type[BaseException] | None, err: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # -- the packets ------------------------------------------------------------------------
    def _send(self, command: int, *args: float | int) -> None:
        try:
            self._sock.sendall(es.encode_command(command, *args))
        except OSError as err:
            self.close()
            raise LinkLostError(f"the tracker at {self.address} dropped the connection: "
                                f"{err}") from err

    def _next(self, deadline: float, what: str) -> es.Packet:
        """The next packet that is not a status change or a pointing report."""
        while True:
            while self._pending:
                packet = self._pending.pop(0)
                if isinstance(packet, es.StatusChange):
                    self.status_changes.append(packet.change)
                elif isinstance(packet, es.Unreadable):
                    self.close()
                    raise LinkLostError(f"the tracker at {self.address} sent a packet that "
                                        f"cannot be read ({packet.reason}): connection dropped")
                elif not isinstance(packet, es.ReflectorPosition):
                    return packet
            left = deadline - time.monotonic()
            if left <= 0:
                raise LinkTimeoutError(f"no answer from the tracker at {self.address} to {what} "
                                       "in time")
            self._sock.settimeout(left)
            try:
                data = self._sock.recv(65536)
            except TimeoutError:
                continue
            except OSError as err:
                self.close()
                raise LinkLostError(f"the tracker at {self.address} dropped the connection: "
                                    f"{err}") from err
            if not data:
                self.close()
                raise LinkLostError(f"the tracker at {self.address} closed the connection "
                                    f"during {what}")
            try:
                self._pending += self._reader.feed(data)
            except FramingError as err:
                self.close()
                raise LinkLostError(f"the tracker at {self.address}: {err}") from err

    def _answer(self, command: int, what: str, timeout_s: float | None = None) -> es.Answer:
        deadline = time.monotonic() + (timeout_s or self.timeout_s)
        while True:
            packet = self._next(deadline, what)
            if isinstance(packet, es.ErrorPacket):
                raise _status_error(packet.status, packet.command, what)
            if isinstance(packet, es.Answer) and packet.command == command:
                if packet.status != es.RS_ALL_OK:
                    raise _status_error(packet.status, command, what)
                return packet
            # a late result or answer of an earlier, abandoned request: not this one's

    def command(self, command: int, *args: float | int, what: str = "",
                timeout_s: float | None = None) -> es.Answer:
        """Send one command and wait for its answer (status checked)."""
        what = what or f"command {command}"
        self._send(command, *args)
        return self._answer(command, what, timeout_s)

    # -- what a calibration does ------------------------------------------------------------
    def initialise(self) -> None:
        self.command(es.C_INITIALIZE, what="Initialize", timeout_s=INITIALISE_TIMEOUT_S)

    def setup(self, *, initialise: bool = True) -> None:
        """Initialise (unless `initialise` is False), then set the units, the coordinate type,
        the stationary mode and the extended statistics explicitly."""
        if initialise:
            self.initialise()
        self.command(es.C_SET_UNITS, es.LU_MILLIMETER, es.AU_DEGREE, es.TU_CELSIUS, es.PU_MBAR,
                     es.HU_RH, what="SetUnits (mm, deg, deg C, mbar, %RH)")
        self.command(es.C_SET_COORDINATE_SYSTEM_TYPE, es.CS_RHR,
                     what="SetCoordinateSystemType (RHR)")
        self.command(es.C_SET_MEASUREMENT_MODE, es.MM_STATIONARY,
                     what="SetMeasurementMode (stationary)")
        self.command(es.C_SET_STATISTIC_MODE, es.SM_EXTENDED, es.SM_EXTENDED,
                     what="SetStatisticMode (extended)")

    def units(self) -> tuple[int, ...]:
        return tuple(int(v) for v in self.command(es.C_GET_UNITS, what="GetUnits").values)

    def environment(self) -> tuple[float, float, float]:
        """The weather the tracker computes the refraction from: deg C, mbar, %RH."""
        v = self.command(es.C_GET_ENVIRONMENT_PARAMS, what="GetEnvironmentParams").values
        return float(v[0]), float(v[1]), float(v[2])

    def set_environment(self, temperature_c: float, pressure_mbar: float,
                        humidity_pct: float) -> None:
        self.command(es.C_SET_ENVIRONMENT_PARAMS, temperature_c, pressure_mbar, humidity_pct,
                     what="SetEnvironmentParams")

    def go_position(self, xyz_mm: tuple[float, float, float] | list[float]) -> None:
        """Point the beam at a position (mm, the tracker's frame) and lock on the reflector
        found there (several SMRs on the flange: each measured in turn); BeamBrokenError when
        none is there."""
        x, y, z = (float(v) for v in xyz_mm)
        self.command(es.C_GO_POSITION, x, y, z, 1, what=f"GoPosition ({x:.1f}, {y:.1f}, "
                     f"{z:.1f}) mm")
        self._last_distance_mm = float(np.linalg.norm((x, y, z)))

    def find_reflector(self, approx_distance_mm: float | None = None) -> None:
        distance = self._last_distance_mm if approx_distance_mm is None else approx_distance_mm
        self.command(es.C_FIND_REFLECTOR, float(distance), what="FindReflector")

    def _measure_once(self) -> es.SingleMeasurement:
        what = "StartMeasurement"
        self._send(es.C_START_MEASUREMENT)
        self._answer(es.C_START_MEASUREMENT, what)
        deadline = time.monotonic() + self.timeout_s
        while True:
            packet = self._next(deadline, "the measurement's result")
            if isinstance(packet, es.ErrorPacket):
                raise _status_error(packet.status, packet.command, what)
            if isinstance(packet, es.SingleMeasurement):
                if packet.status != es.RS_ALL_OK:
                    raise _status_error(packet.status, es.C_START_MEASUREMENT, what)
                return packet

    def measure(self) -> TrackerPoint:
        """One stationary measurement. Beam broken: FindReflector, then one more try."""
        searched = False
        try:
            m = self._measure_once()
        except BeamBrokenError:
            try:
                self.find_reflector()
            except BeamBrokenError as err:
                raise BeamBrokenError(f"the reflector is not found (FindReflector at "
                                      f"{self._last_distance_mm:.0f} mm): {err}", err.status,
                                      err.command) from err
            searched = True
            m = self._measure_once()
        self._last_distance_mm = float(np.linalg.norm(m.xyz))
        return TrackerPoint(xyz_mm=m.xyz, covariance_mm2=covariance_of(m),
                            temperature_c=m.temperature, pressure_mbar=m.pressure,
                            humidity_pct=m.humidity, time_s=time.time(), searched=searched)
