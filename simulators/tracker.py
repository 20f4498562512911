"""A laser-tracker emulator: the emScon TPI server side (`protocol.emscon`) on TCP, measuring the
true position of a reflector (SMR) on the emulated robot's flange.

What it measures: the SMR's true centre, in the tracker's frame (the world's axes, the tracker's
head at the origin), with the error model of an AT40x-class tracker (screwcal/instrument.py):
along the line of sight the distance meter's noise, across it the two angles' noise growing
with the range (U = 15 um + 6 um/m, k = 2), drawn from a seed; the covariance the result carries
is that same model's. The distance is scaled by the refractive index of the true air over the
index of the air the tracker assumes (its weather station's, or what a client set with
SetEnvironmentParams): a wrong weather is a scale error, about 1 ppm per deg C.

When it cannot measure: no reflector is locked when the SMR is out of range, faces away from the
tracker by more than its acceptance angle, or a link of the robot (a capsule around each segment
of the true robot's skeleton) breaks the beam; a measurement then fails with
ES_RS_MeasurementStatusNotReady and a FindReflector finds nothing. The tracker must be
initialised first (ES_RS_TrackerNotInitialized). `TrackerFaults` injects, at a given measurement
attempt: the beam broken for a number of attempts, the connection dropped, the initialisation
lost, the laser warming up (ES_RS_ADMStartUpBusy).
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass, field, fields
from typing import Protocol

import numpy as np

from protocol import emscon as es
from protocol.errors import FramingError
from screwcal.calibration.line_of_sight import (
    DEFAULT_SMR_AXIS,
    DEFAULT_SMR_MM,
    TrackerView,
    beam_blocked,
    view_from,
)
from screwcal.instrument import TRACKER_STAND_MM, tracker_covariance_mm2, tracker_noise_mm
from screwcal.kinematics.se3 import Array, transform_points
from simulators.world import World

STANDARD_AIR = (20.0, 1013.25, 50.0)  # deg C, mbar, %RH
CAPTURE_MM = 25.0  # GoPosition locks on an SMR this close to where it points (its camera's
# field at a few metres)

_LENGTH_PER_MM = {0: 1e-3, 1: 1.0, 2: 1e3, 3: 1 / 304.8, 4: 1 / 914.4, 5: 1 / 25.4}
_PRESSURE_PER_MBAR = {0: 1.0, 1: 1.0, 2: 0.1, 3: 0.750062, 4: 0.0145038, 6: 0.0295300}


def refractive_index(temperature_c: float, pressure_mbar: float, humidity_pct: float) -> float:
    """The refractive index of air (NIST's shop-floor form of Edlén's equation, red light):
    n = 1 + 7.86e-4 p / (273 + t) - 1.5e-11 RH (t^2 + 160), p in kPa."""
    t, p_kpa = temperature_c, pressure_mbar / 10.0
    return 1.0 + 7.86e-4 * p_kpa / (273.0 + t) - 1.5e-11 * humidity_pct * (t * t + 160.0)


@dataclass
class TrackerFaults:
    """Faults at a measurement attempt (StartMeasurement requests counted from 0), each once."""

    beam: int | None = None  # the beam broken from this attempt on ...
    beam_n: int = 3  # ... for this many attempts (FindReflector fails meanwhile)
    drop: int | None = None  # the connection closed instead of answering this attempt
    uninit: int | None = None  # the tracker loses its initialisation at this attempt
    warm: int | None = None  # this attempt answered "the laser is warming up"

    @classmethod
    def parse(cls, text: str) -> TrackerFaults:
        """`beam=3,beam_n=2,drop=5,uninit=7,warm=9` (the CLI's form)."""
        names = {f.name for f in fields(cls)}
        values: dict[str, int] = {}
        for item in filter(None, (t.strip() for t in text.split(","))):
            name, _, value = item.partition("=")
            if name not in names:
                raise ValueError(f"tracker fault {name!r}: one of {', '.join(sorted(names))}")
            try:
                values[name] = int(value)
            except ValueError:
                raise ValueError(f"tracker fault {name}: {value!r} is not a whole number") \
                    from None
            if values[name] < 0:
                raise ValueError(f"tracker fault {name}: {value} is negative")
        return cls(**values)

    def beam_broken(self, attempt: int) -> bool:
        return self.beam is not None and self.beam <= attempt < self.beam + self.beam_n

    def take(self, name: str, attempt: int) -> bool:
        if getattr(self, name) == attempt:
            setattr(self, name, None)
            return True
        return False


def view_of(world: World, smr_mm: tuple[float, float, float] = DEFAULT_SMR_MM,
            smr_axis: tuple[float, float, float] = DEFAULT_SMR_AXIS) -> TrackerView:
    return view_from(world.true_tool0(), world.true_skeleton_mm(), world.truth.base, smr_mm,
                     smr_axis)


class TrackerSource(Protocol):
    def tracker_views(self) -> list[TrackerView] | None: ...  # per SMR; None: no robot yet


Point = tuple[float, float, float]


@dataclass
class WorldSource:
    """The shared world, in one process; the SMRs' centres in tool0, their openings along
    `smr_axis`."""

    world: World
    smrs_mm: tuple[Point, ...] = (DEFAULT_SMR_MM,)
    smr_axis: Point = DEFAULT_SMR_AXIS

    def tracker_views(self) -> list[TrackerView] | None:
        return [view_of(self.world, smr, self.smr_axis) for smr in self.smrs_mm]


@dataclass
class WorldFileSource:
    """The world file an `emulator irc5` process keeps (`simulators.arm.WorldFileWriter`)."""

    path: str
    smrs_mm: tuple[Point, ...] = (DEFAULT_SMR_MM,)
    smr_axis: Point = DEFAULT_SMR_AXIS

    def __post_init__(self) -> None:
        from simulators.arm import WorldFileSource as Reader

        self._reader = Reader(self.path)

    def tracker_views(self) -> list[TrackerView] | None:
        frames = self._reader.true_frames()
        return None if frames is None else [view_from(*frames, smr, self.smr_axis)
                                            for smr in self.smrs_mm]


def station_in_world(world: World, stand_mm: tuple[float, float, float] = TRACKER_STAND_MM
                     ) -> Array:
    """Where a tracker standing at `stand_mm` of the robot's base frame is in the world."""
    return transform_points(world.truth.base, np.asarray(stand_mm, dtype=float)[None])[0]


@dataclass
class TrackerState:
    """The tracker's own state, shared by its connections."""

    initialised: bool = False
    units: tuple[int, ...] = (es.LU_MILLIMETER, es.AU_DEGREE, es.TU_CELSIUS, es.PU_MBAR,
                              es.HU_RH)
    statistic: int = es.SM_STANDARD
    environment: tuple[float, float, float] | None = None  # set by a client; None: measured
    locked: int = 0  # the SMR the beam is locked on (GoPosition chooses among several)
    attempts: int = 0
    measured: list[tuple[Array, Array]] = field(default_factory=list)  # (true, reported) mm
    refused: dict[str, int] = field(default_factory=dict)  # why, how often


class TrackerEmulator:
    def __init__(self, source: TrackerSource,
                 stand_mm: tuple[float, float, float] = TRACKER_STAND_MM, *,
                 seed: int | None = None,
                 faults: TrackerFaults | None = None,
                 air: tuple[float, float, float] = STANDARD_AIR, initialise_s: float = 0.05,
                 measure_s: float = 0.02, yaw_deg: float = 0.0):
        """`yaw_deg`: the tracker's frame turned about the vertical from the robot's (a
        levelled tracker's zero direction is wherever it was set up)."""
        self.source, self.stand_mm = source, np.asarray(stand_mm, dtype=float)
        c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
        self.turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # world <- tracker
        self.faults = faults or TrackerFaults()
        self.rng = np.random.default_rng(seed)
        self.air = air  # the true air: deg C, mbar, %RH
        self.initialise_s, self.measure_s = initialise_s, measure_s
        self.state = TrackerState()
        self._server: asyncio.base_events.Server | None = None
        self._writers: set[asyncio.StreamWriter] = set()

    # -- the measurement --------------------------------------------------------------------
    def weather(self) -> tuple[float, float, float]:
        """The air the tracker computes with: what a client set, else its station's (true)."""
        return self.state.environment or self.air

    def _view(self, index: int | None = None) -> tuple[TrackerView, Array] | str:
        """The locked SMR's view (or SMR `index`'s) and the tracker's place, world frame."""
        views = self.source.tracker_views()
        if views is None:
            return "no robot known yet"
        view = views[self.state.locked if index is None else index]
        return view, transform_points(view.base, self.stand_mm[None])[0]

    def point_at(self, xyz: Array) -> bool:
        """GoPosition: lock on the SMR within CAPTURE_MM of the pointed position (tracker
        frame, mm) that the beam reaches; False when there is none."""
        views = self.source.tracker_views()
        if views is None:
            return False
        for k in range(len(views)):
            seen = self._view(k)
            if isinstance(seen, str):
                return False
            view, station = seen
            if np.linalg.norm(view.smr_mm - station - self.turn @ xyz) <= CAPTURE_MM and \
                    beam_blocked(view, station) is None:
                self.state.locked = k
                return True
        return False

    def measurement(self) -> es.SingleMeasurement | str:
        """One measurement of the locked SMR now, in the units set, or why there is none."""
        seen = self._view()
        if isinstance(seen, str):
            return seen
        view, station = seen
        blocked = beam_blocked(view, station)
        if blocked is not None:
            return blocked
        line = view.smr_mm - station
        distance = float(np.linalg.norm(line))
        u = line / distance
        radial, lateral = tracker_noise_mm(distance)
        # two directions across the line of sight
        helper = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        e1 = np.cross(u, helper)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(u, e1)
        weather = self.weather()
        scale = refractive_index(*self.air) / refractive_index(*weather)
        noise = self.rng.normal(0.0, 1.0, 3) * (radial, lateral, lateral)
        reported = self.turn.T @ (u * (distance * scale + noise[0]) + e1 * noise[1]
                                  + e2 * noise[2])  # in the tracker's own frame
        self.state.measured.append((self.turn.T @ line, reported))
        C = tracker_covariance_mm2((self.turn.T @ line)[None])[0]
        k = _LENGTH_PER_MM[self.state.units[0]]
        std = np.sqrt(np.diag(C)) * k
        covar = (C[0, 1] * k * k, C[0, 2] * k * k, C[1, 2] * k * k)
        extended = self.state.statistic == es.SM_EXTENDED
        temperature, pressure, humidity = weather
        if self.state.units[2] == 1:  # Fahrenheit
            temperature = temperature * 9.0 / 5.0 + 32.0
        pressure *= _PRESSURE_PER_MBAR[self.state.units[3]]
        std3 = (float(std[0]), float(std[1]), float(std[2]))
        return es.SingleMeasurement(
            status=es.RS_ALL_OK, meas_mode=es.MM_STATIONARY, is_try_mode=False,
            xyz=(float(reported[0] * k), float(reported[1] * k), float(reported[2] * k)),
            std=std3, std_total=float(np.sqrt(np.trace(C)) * k),
            covar=covar if extended else None, temperature=temperature, pressure=pressure,
            humidity=humidity, apriori_std=std3, apriori_std_total=float(np.sqrt(np.trace(C)) * k),
            apriori_covar=covar if extended else None)

    def _refuse(self, why: str) -> None:
        self.state.refused[why] = self.state.refused.get(why, 0) + 1

    # -- the commands -----------------------------------------------------------------------
    async def answer(self, command: es.Command, writer: asyncio.StreamWriter) -> bool:
        """Answer one command; False when the connection is to be closed."""
        c, args, state = command.command, command.args, self.state
        ok = es.RS_ALL_OK
        if c == es.C_INITIALIZE:
            await asyncio.sleep(self.initialise_s)
            state.initialised, state.locked = True, 0  # to its home, then onto the first SMR
            writer.write(es.encode_answer(c, ok))
        elif c == es.C_SET_UNITS:
            length, _angle, temperature, pressure, humidity = (int(v) for v in args)
            if length not in _LENGTH_PER_MM or temperature not in (0, 1) \
                    or pressure not in _PRESSURE_PER_MBAR or humidity != es.HU_RH:
                writer.write(es.encode_answer(c, es.RS_WRONG_PARAMETER))
            else:
                state.units = tuple(int(v) for v in args)
                writer.write(es.encode_answer(c, ok))
        elif c == es.C_GET_UNITS:
            writer.write(es.encode_answer(c, ok, *state.units))
        elif c == es.C_SET_COORDINATE_SYSTEM_TYPE:
            writer.write(es.encode_answer(c, ok if args[0] == es.CS_RHR
                                          else es.RS_NOT_IMPLEMENTED))
        elif c == es.C_SET_MEASUREMENT_MODE:
            writer.write(es.encode_answer(c, ok if args[0] == es.MM_STATIONARY
                                          else es.RS_WRONG_PARAMETER))
        elif c == es.C_SET_STATISTIC_MODE:
            state.statistic = int(args[0])
            writer.write(es.encode_answer(c, ok))
        elif c == es.C_SET_STATIONARY_MODE_PARAMS:
            writer.write(es.encode_answer(c, ok))
        elif c == es.C_SET_ENVIRONMENT_PARAMS:
            t, p, h = (float(v) for v in args)
            if not (-20.0 <= t <= 60.0 and 500.0 <= p <= 1200.0 and 0.0 <= h <= 100.0):
                writer.write(es.encode_answer(c, es.RS_WRONG_PARAMETER))
            else:
                state.environment = (t, p, h)
                writer.write(es.encode_answer(c, ok))
        elif c == es.C_GET_ENVIRONMENT_PARAMS:
            writer.write(es.encode_answer(c, ok, *self.weather()))
        elif c == es.C_GET_TRACKER_STATUS:
            writer.write(es.encode_answer(c, ok, es.TS_READY if state.initialised
                                          else es.TS_NOT_READY))
        elif c == es.C_FIND_REFLECTOR:
            result = self.measurement() if state.initialised else "not initialised"
            broken = self.faults.beam_broken(state.attempts)  # until the next attempt
            if isinstance(result, str) or broken:
                self._refuse("find reflector: " + ("beam broken (fault)" if broken
                                                   else str(result)))
                writer.write(es.encode_answer(c, es.RS_MEASUREMENT_STATUS_NOT_READY))
            else:
                writer.write(es.encode_answer(c, ok))
        elif c == es.C_GO_POSITION:
            x, y, z = (float(v) / _LENGTH_PER_MM[state.units[0]] for v in args[:3])
            found = state.initialised and self.point_at(np.array([x, y, z]))
            if not found:
                self._refuse("go position: no reflector there")
            writer.write(es.encode_answer(c, ok if found
                                          else es.RS_MEASUREMENT_STATUS_NOT_READY))
        elif c == es.C_START_MEASUREMENT:
            return await self._start_measurement(writer)
        else:
            writer.write(es.encode_answer(c, es.RS_NOT_IMPLEMENTED))
        return True

    async def _start_measurement(self, writer: asyncio.StreamWriter) -> bool:
        state, faults = self.state, self.faults
        attempt = state.attempts
        state.attempts += 1
        c = es.C_START_MEASUREMENT
        if faults.take("drop", attempt):
            self._refuse("connection dropped (fault)")
            return False
        if faults.take("uninit", attempt):
            state.initialised = False
        status = es.RS_ALL_OK
        if not state.initialised:
            status, why = es.RS_TRACKER_NOT_INITIALIZED, "not initialised"
        elif faults.take("warm", attempt):
            status, why = es.RS_ADM_STARTUP_BUSY, "warming up (fault)"
        elif faults.beam_broken(attempt):
            status, why = es.RS_MEASUREMENT_STATUS_NOT_READY, "beam broken (fault)"
        if status != es.RS_ALL_OK:
            self._refuse(why)
            writer.write(es.encode_answer(c, status))
            return True
        await asyncio.sleep(self.measure_s)
        result = self.measurement()
        if isinstance(result, str):
            self._refuse(result)
            writer.write(es.encode_status_change(es.SSC_MEAS_STATUS_NOT_READY))
            writer.write(es.encode_answer(c, es.RS_MEASUREMENT_STATUS_NOT_READY))
            return True
        writer.write(es.encode_answer(c, es.RS_ALL_OK))
        writer.write(es.encode_measurement(result))
        return True

    # -- serving ----------------------------------------------------------------------------
    async def start(self, host: str = "127.0.0.1", port: int = 0) -> tuple[str, int]:
        self._server = await asyncio.start_server(self.serve, host, port)
        addr = self._server.sockets[0].getsockname()
        return addr[0], addr[1]

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()
        for writer in list(self._writers):
            writer.close()
        if self._server is not None:
            await self._server.wait_closed()

    async def serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        """One client's connection (TCP from `start`, or a link in memory: protocol.memory)."""
        self._writers.add(writer)
        packets = es.PacketReader(from_client=True)
        try:
            while data := await reader.read(4096):
                for packet in packets.feed(data):
                    if isinstance(packet, es.Command):
                        if not await self.answer(packet, writer):
                            return
                    elif isinstance(packet, es.Unreadable) and packet.command is not None:
                        writer.write(es.encode_answer(packet.command, es.RS_NOT_IMPLEMENTED))
                await writer.drain()
        except (ConnectionError, FramingError):
            pass  # gone, or garbage: the peer is dropped
        finally:
            self._writers.discard(writer)
            writer.close()
            with contextlib.suppress(ConnectionError):
                await writer.wait_closed()
