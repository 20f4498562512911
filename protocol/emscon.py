"""Leica emScon TPI (AT401/402/403, AT901): the binary packets over TCP, as bytes in, packets out;
no I/O (`protocol.tracker` is the driver, `simulators.tracker` the emulated server).

Every packet starts with a header `<i I`: its whole size in bytes (the header included) and its
data type (ES_DataType). A command (type 0) carries the command number after the header, then
its parameters; its answer carries the command number, the result status (ES_ResultStatus),
then the answer's values. Measurements, errors and status changes come as their own types.
Little-endian, packed C structs: `int`/enum as 4 bytes, `double` as 8. Lengths in the units set
with SetUnits (this project sets mm, degrees, deg C, mbar, %RH), coordinates in the coordinate
system type set with SetCoordinateSystemType (this project: RHR, Cartesian right-handed).

Only the packets the calibration needs are here: Initialize, SetUnits, SetCoordinateSystemType,
SetMeasurementMode (stationary), SetStationaryModeParams, SetStatisticMode, SetEnvironmentParams,
GetEnvironmentParams, GetTrackerStatus, GoPosition, FindReflector, StartMeasurement; the
single-measurement
results (standard and extended statistics), the error packet and the status change. Their
layouts follow the public emScon programmer's manual's C header; the tests hold them to the
published `cesapi` package's layouts field by field.

`encode_*` make packets; `PacketReader.feed(data) -> list[Packet]` takes any chunks (TCP splits
and merges). A header whose size is out of bounds raises `FramingError` (the stream cannot be
trusted any more: drop the connection); a well-framed packet of an unknown type or command, or
of a known kind with the wrong size, becomes an `Unreadable` naming what is wrong, and the
packets after it are read on.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Union

from protocol.errors import FramingError, PayloadError

DEFAULT_PORT = 700  # the tracker controller's TPI port
HEADER = struct.Struct("<iI")  # lPacketSize, type
MIN_PACKET = 12  # a header and one 4-byte field: no packet is shorter
MAX_PACKET = 4096  # the longest packet of the TPI is far shorter: a larger size is garbage

# ES_DataType
DT_COMMAND, DT_ERROR, DT_SINGLE_MEAS, DT_NIVEL, DT_REFLECTOR_POS = 0, 1, 2, 6, 7
DT_STATUS_CHANGE, DT_SINGLE_MEAS2 = 8, 9

# ES_Command (the ones used here)
C_GET_TRACKER_STATUS = 2
C_SET_UNITS = 5
C_GET_UNITS = 6
C_INITIALIZE = 7
C_SET_ENVIRONMENT_PARAMS = 20
C_GET_ENVIRONMENT_PARAMS = 21
C_SET_MEASUREMENT_MODE = 24
C_SET_COORDINATE_SYSTEM_TYPE = 26
C_SET_STATIONARY_MODE_PARAMS = 28
C_START_MEASUREMENT = 49
C_GO_POSITION = 55
C_FIND_REFLECTOR = 63
C_SET_STATISTIC_MODE = 80

# ES_ResultStatus (the ones the driver tells apart)
RS_ALL_OK = 0
RS_SERVER_BUSY = 1
RS_NOT_IMPLEMENTED = 2
RS_WRONG_PARAMETER = 3
RS_TRACKER_NOT_INITIALIZED = 39
RS_MEASUREMENT_STATUS_NOT_READY = 10004  # no reflector locked: the beam is broken
RS_ADM_STARTUP_BUSY = 10005  # the distance meter (laser) is still warming up
RS_SYSTEM_NOT_READY = 10014  # the system is not ready to measure (warming up, levelling)

# ES_TrackerStatus
TS_NOT_READY, TS_BUSY, TS_READY = 0, 1, 2
# ES_LengthUnit, ES_AngleUnit, ES_TemperatureUnit, ES_PressureUnit, ES_HumidityUnit
LU_MILLIMETER, AU_DEGREE, TU_CELSIUS, PU_MBAR, HU_RH = 1, 1, 0, 0, 0
CS_RHR = 0  # ES_CoordinateSystemType: Cartesian, right-handed
MM_STATIONARY = 0  # ES_MeasMode
SM_STANDARD, SM_EXTENDED = 0, 1  # ES_StatisticMode: extended adds the covariances
# ES_SystemStatusChange (the ones the emulator sends)
SSC_MEAS_STATUS_NOT_READY, SSC_MEAS_STATUS_READY = 25, 27

# Command parameters (after the command number) and answers (after command and status)
_COMMAND_ARGS: dict[int, struct.Struct] = {
    C_GET_TRACKER_STATUS: struct.Struct("<"),
    C_SET_UNITS: struct.Struct("<IIIII"),  # length, angle, temperature, pressure, humidity
    C_GET_UNITS: struct.Struct("<"),
    C_INITIALIZE: struct.Struct("<"),
    C_SET_ENVIRONMENT_PARAMS: struct.Struct("<ddd"),  # temperature, pressure, humidity
    C_GET_ENVIRONMENT_PARAMS: struct.Struct("<"),
    C_SET_MEASUREMENT_MODE: struct.Struct("<I"),
    C_SET_COORDINATE_SYSTEM_TYPE: struct.Struct("<I"),
    C_SET_STATIONARY_MODE_PARAMS: struct.Struct("<ii"),  # lMeasTime (ms), bUseADM
    C_START_MEASUREMENT: struct.Struct("<"),
    C_FIND_REFLECTOR: struct.Struct("<d"),  # approximate distance
    C_GO_POSITION: struct.Struct("<dddi"),  # x, y, z to point at, bUseADM (lock on there)
    C_SET_STATISTIC_MODE: struct.Struct("<II"),  # stationary, continuous
}
_ANSWER_VALUES: dict[int, struct.Struct] = {
    C_GET_TRACKER_STATUS: struct.Struct("<I"),
    C_GET_UNITS: struct.Struct("<IIIII"),
    C_GET_ENVIRONMENT_PARAMS: struct.Struct("<ddd"),
}
_NO_VALUES = struct.Struct("<")
_COMMAND_HEAD = struct.Struct("<iII")  # header, command
_ANSWER_HEAD = struct.Struct("<iIII")  # header, command, status
_STATUS_CHANGE = struct.Struct("<iII")  # header, ES_SystemStatusChange
_ERROR = struct.Struct("<iIII")  # header, command, status
# ReturnDataT (header, status), then measMode, bIsTryMode, then doubles
_SINGLE_MEAS = struct.Struct("<iIIIi" + "d" * 17)  # 156 bytes
_SINGLE_MEAS2 = struct.Struct("<iIIIi" + "d" * 23)  # 204 bytes
_REFLECTOR_POS = struct.Struct("<iIIddd")  # 36 bytes


@dataclass(frozen=True)
class Command:
    """A command packet: its number and its parameters (a tuple, the command's layout)."""

    command: int
    args: tuple[float | int, ...] = ()


@dataclass(frozen=True)
class Answer:
    """A command's answer: its number, its ES_ResultStatus and its values."""

    command: int
    status: int
    values: tuple[float | int, ...] = ()


@dataclass(frozen=True)
class ErrorPacket:
    """ES_DT_Error: the tracker reports a failure outside a command's answer."""

    command: int
    status: int


@dataclass(frozen=True)
class StatusChange:
    """ES_DT_SystemStatusChange: something changed on the tracker (ES_SystemStatusChange)."""

    change: int


@dataclass(frozen=True)
class ReflectorPosition:
    """ES_DT_ReflectorPosResult: where the tracker points now (not a measurement)."""

    status: int
    xyz: tuple[float, float, float]


@dataclass(frozen=True)
class SingleMeasurement:
    """A stationary single-point result (ES_DT_SingleMeasResult or, with the extended
    statistics, ES_DT_SingleMeasResult2 and its covariances). Values in the units set."""

    status: int
    meas_mode: int
    is_try_mode: bool
    xyz: tuple[float, float, float]
    std: tuple[float, float, float]  # standard deviations of X, Y, Z
    std_total: float
    covar: tuple[float, float, float] | None  # 12, 13, 23; None in the standard result
    temperature: float
    pressure: float
    humidity: float
    pointing_error: tuple[float, float, float] = (0.0, 0.0, 0.0)
    apriori_std: tuple[float, float, float] = (0.0, 0.0, 0.0)
    apriori_std_total: float = 0.0
    apriori_covar: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class Unreadable:
    """A well-framed packet that is not a valid one: an unknown type or command, or the wrong
    size for its kind. `command` is the command number when the packet is a command (the
    server answers it RS_NOT_IMPLEMENTED), else None."""

    reason: str
    raw: bytes
    command: int | None = None


Packet = Union[Command, Answer, ErrorPacket, StatusChange, ReflectorPosition,  # noqa: UP007
               SingleMeasurement, Unreadable]


def _args_layout(command: int) -> struct.Struct:
    try:
        return _COMMAND_ARGS[command]
    except KeyError:
        raise PayloadError(f"emScon command {command} is not one this codec knows",
                           code=RS_NOT_IMPLEMENTED) from None


def encode_command(command: int, *args: float | int) -> bytes:
    """One command packet: `encode_command(C_SET_COORDINATE_SYSTEM_TYPE, CS_RHR)`."""
    layout = _args_layout(command)
    if len(args) != len(layout.unpack(bytes(layout.size))):
        raise ValueError(f"emScon command {command} takes "
                         f"{len(layout.unpack(bytes(layout.size)))} parameters, got {len(args)}")
    body = layout.pack(*args)
    return _COMMAND_HEAD.pack(_COMMAND_HEAD.size + len(body), DT_COMMAND, command) + body


def encode_answer(command: int, status: int, *values: float | int) -> bytes:
    """A command's answer; a failed one (status not RS_ALL_OK) carries its values zeroed, as
    the tracker sends it, so every answer of a command has the same size."""
    layout = _ANSWER_VALUES.get(command, _NO_VALUES)
    if not values:
        values = layout.unpack(bytes(layout.size))
    body = layout.pack(*values)
    return _ANSWER_HEAD.pack(_ANSWER_HEAD.size + len(body), DT_COMMAND, command, status) + body


def encode_error(command: int, status: int) -> bytes:
    return _ERROR.pack(_ERROR.size, DT_ERROR, command, status)


def encode_status_change(change: int) -> bytes:
    return _STATUS_CHANGE.pack(_STATUS_CHANGE.size, DT_STATUS_CHANGE, change)


def encode_reflector_position(xyz: tuple[float, float, float], status: int = RS_ALL_OK
                              ) -> bytes:
    return _REFLECTOR_POS.pack(_REFLECTOR_POS.size, DT_REFLECTOR_POS, status, *xyz)


def encode_measurement(m: SingleMeasurement) -> bytes:
    """ES_DT_SingleMeasResult2 when `m.covar` is given (the extended statistics), else
    ES_DT_SingleMeasResult."""
    head = (m.status, m.meas_mode, int(m.is_try_mode))
    if m.covar is None:
        return _SINGLE_MEAS.pack(_SINGLE_MEAS.size, DT_SINGLE_MEAS, *head, *m.xyz, *m.std,
                                 m.std_total, *m.pointing_error, *m.apriori_std,
                                 m.apriori_std_total, m.temperature, m.pressure, m.humidity)
    apriori_covar = m.apriori_covar or (0.0, 0.0, 0.0)
    return _SINGLE_MEAS2.pack(_SINGLE_MEAS2.size, DT_SINGLE_MEAS2, *head, *m.xyz, *m.std,
                              m.std_total, *m.covar, *m.pointing_error, *m.apriori_std,
                              m.apriori_std_total, *apriori_covar, m.temperature, m.pressure,
                              m.humidity)


def _three(values: tuple[float | int, ...]) -> tuple[float, float, float]:
    return float(values[0]), float(values[1]), float(values[2])


def decode(raw: bytes, *, from_client: bool = False) -> Packet:
    """One whole packet (its size already checked by the reader) -> its value. A command
    packet is a `Command` when it comes from a client (`from_client`), else an `Answer`."""
    size, kind = HEADER.unpack_from(raw)
    expected: int | None = None
    if kind == DT_COMMAND:
        command = struct.unpack_from("<I", raw, HEADER.size)[0]
        layout = _args_layout(command) if from_client else _ANSWER_VALUES.get(command,
                                                                              _NO_VALUES)
        head = _COMMAND_HEAD if from_client else _ANSWER_HEAD
        expected = head.size + layout.size
        if size == expected:
            if from_client:
                return Command(command, layout.unpack_from(raw, head.size))
            status = struct.unpack_from("<I", raw, 12)[0]
            return Answer(command, status, layout.unpack_from(raw, head.size))
    elif kind == DT_ERROR and size == _ERROR.size:
        _, _, command, status = _ERROR.unpack(raw)
        return ErrorPacket(command, status)
    elif kind == DT_STATUS_CHANGE and size == _STATUS_CHANGE.size:
        return StatusChange(_STATUS_CHANGE.unpack(raw)[2])
    elif kind == DT_REFLECTOR_POS and size == _REFLECTOR_POS.size:
        v = _REFLECTOR_POS.unpack(raw)
        return ReflectorPosition(v[2], _three(v[3:6]))
    elif kind == DT_SINGLE_MEAS and size == _SINGLE_MEAS.size:
        v = _SINGLE_MEAS.unpack(raw)[2:]
        return SingleMeasurement(
            status=v[0], meas_mode=v[1], is_try_mode=bool(v[2]), xyz=_three(v[3:6]),
            std=_three(v[6:9]), std_total=v[9], covar=None, pointing_error=_three(v[10:13]),
            apriori_std=_three(v[13:16]), apriori_std_total=v[16], temperature=v[17],
            pressure=v[18], humidity=v[19])
    elif kind == DT_SINGLE_MEAS2 and size == _SINGLE_MEAS2.size:
        v = _SINGLE_MEAS2.unpack(raw)[2:]
        return SingleMeasurement(
            status=v[0], meas_mode=v[1], is_try_mode=bool(v[2]), xyz=_three(v[3:6]),
            std=_three(v[6:9]), std_total=v[9], covar=_three(v[10:13]),
            pointing_error=_three(v[13:16]), apriori_std=_three(v[16:19]),
            apriori_std_total=v[19], apriori_covar=_three(v[20:23]), temperature=v[23],
            pressure=v[24], humidity=v[25])
    elif kind not in (DT_ERROR, DT_STATUS_CHANGE, DT_REFLECTOR_POS, DT_SINGLE_MEAS,
                      DT_SINGLE_MEAS2):
        raise PayloadError(f"emScon packet of type {kind} ({size} bytes): not a type this "
                           "codec reads")
    raise PayloadError(f"emScon packet of type {kind} has {size} bytes"
                       + (f", expected {expected}" if expected is not None else ""))


class PacketReader:
    """Incremental: feed bytes, get packets. `from_client`: the server's side (commands)."""

    def __init__(self, *, from_client: bool = False) -> None:
        self._buffer = bytearray()
        self.from_client = from_client
        self._broken = False

    def feed(self, data: bytes) -> list[Packet]:
        if self._broken:
            raise FramingError("the emScon stream broke earlier: reconnect")
        self._buffer += data
        out: list[Packet] = []
        while len(self._buffer) >= HEADER.size:
            size = HEADER.unpack_from(self._buffer)[0]
            if not MIN_PACKET <= size <= MAX_PACKET:
                self._broken = True
                raise FramingError(f"emScon packet size {size} out of [{MIN_PACKET}, "
                                   f"{MAX_PACKET}]: the stream cannot be trusted")
            if len(self._buffer) < size:
                break
            raw = bytes(self._buffer[:size])
            del self._buffer[:size]
            try:
                out.append(decode(raw, from_client=self.from_client))
            except PayloadError as err:
                kind, command = struct.unpack_from("<II", raw, 4)
                out.append(Unreadable(str(err), raw, command if kind == DT_COMMAND else None))
        return out
