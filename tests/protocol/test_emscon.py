"""The emScon TPI codec, held to the published `cesapi` package's packet layouts (its classes
generated from Leica's C header): every packet this project sends or reads, packed by one side
and unpacked by the other, field by field."""

from __future__ import annotations

import pytest

from protocol import emscon as es
from protocol.errors import FramingError

cesapi = pytest.importorskip("CESAPI.packet")


def _cesapi_command(cls: type, **fields: object) -> bytes:
    packet = cls()
    for name, value in fields.items():
        target = packet
        *path, last = name.split(".")
        for part in path:
            target = getattr(target, part)
        setattr(target, last, value)
    return packet.pack()


@pytest.mark.parametrize(("ours", "theirs"), [
    (es.encode_command(es.C_INITIALIZE), _cesapi_command(cesapi.InitializeCT)),
    (es.encode_command(es.C_START_MEASUREMENT), _cesapi_command(cesapi.StartMeasurementCT)),
    (es.encode_command(es.C_GET_TRACKER_STATUS), _cesapi_command(cesapi.GetTrackerStatusCT)),
    (es.encode_command(es.C_GET_ENVIRONMENT_PARAMS),
     _cesapi_command(cesapi.GetEnvironmentParamsCT)),
    (es.encode_command(es.C_GET_UNITS), _cesapi_command(cesapi.GetUnitsCT)),
    (es.encode_command(es.C_GO_POSITION, 2500.5, -30.25, 400.0, 1),
     _cesapi_command(cesapi.GoPositionCT, dVal1=2500.5, dVal2=-30.25, dVal3=400.0, bUseADM=1)),
    (es.encode_command(es.C_FIND_REFLECTOR, 2512.25),
     _cesapi_command(cesapi.FindReflectorCT, dAproxDistance=2512.25)),
    (es.encode_command(es.C_SET_COORDINATE_SYSTEM_TYPE, es.CS_RHR),
     _cesapi_command(cesapi.SetCoordinateSystemTypeCT, coordSysType=cesapi.ES_CS_RHR)),
    (es.encode_command(es.C_SET_MEASUREMENT_MODE, es.MM_STATIONARY),
     _cesapi_command(cesapi.SetMeasurementModeCT, measMode=cesapi.ES_MM_Stationary)),
    (es.encode_command(es.C_SET_STATISTIC_MODE, es.SM_EXTENDED, es.SM_STANDARD),
     _cesapi_command(cesapi.SetStatisticModeCT, stationaryMeasurements=cesapi.ES_SM_Extended,
                     continuousMeasurements=cesapi.ES_SM_Standard)),
    (es.encode_command(es.C_SET_STATIONARY_MODE_PARAMS, 500, 1),
     _cesapi_command(cesapi.SetStationaryModeParamsCT, **{
         "stationaryModeData.lMeasTime": 500, "stationaryModeData.bUseADM": 1})),
    (es.encode_command(es.C_SET_UNITS, es.LU_MILLIMETER, es.AU_DEGREE, es.TU_CELSIUS,
                       es.PU_MBAR, es.HU_RH),
     _cesapi_command(cesapi.SetUnitsCT, **{
         "unitsSettings.lenUnitType": cesapi.ES_LU_Millimeter,
         "unitsSettings.angUnitType": cesapi.ES_AU_Degree,
         "unitsSettings.tempUnitType": cesapi.ES_TU_Celsius,
         "unitsSettings.pressUnitType": cesapi.ES_PU_Mbar,
         "unitsSettings.humUnitType": cesapi.ES_HU_RH})),
    (es.encode_command(es.C_SET_ENVIRONMENT_PARAMS, 20.5, 1013.25, 45.0),
     _cesapi_command(cesapi.SetEnvironmentParamsCT, **{
         "environmentData.dTemperature": 20.5, "environmentData.dPressure": 1013.25,
         "environmentData.dHumidity": 45.0})),
])
def test_commands_are_cesapis_bytes(ours, theirs):
    assert ours == theirs
    # and the server side reads cesapi's packet back as the same command
    (command,) = es.PacketReader(from_client=True).feed(theirs)
    assert isinstance(command, es.Command)
    assert es.encode_command(command.command, *command.args) == theirs


def test_constants_are_the_headers():
    pairs = {
        "DT_COMMAND": "ES_DT_Command", "DT_ERROR": "ES_DT_Error",
        "DT_SINGLE_MEAS": "ES_DT_SingleMeasResult", "DT_SINGLE_MEAS2": "ES_DT_SingleMeasResult2",
        "DT_STATUS_CHANGE": "ES_DT_SystemStatusChange",
        "DT_REFLECTOR_POS": "ES_DT_ReflectorPosResult",
        "C_INITIALIZE": "ES_C_Initialize", "C_SET_UNITS": "ES_C_SetUnits",
        "C_START_MEASUREMENT": "ES_C_StartMeasurement", "C_FIND_REFLECTOR": "ES_C_FindReflector",
        "C_GO_POSITION": "ES_C_GoPosition",
        "C_SET_STATISTIC_MODE": "ES_C_SetStatisticMode",
        "RS_TRACKER_NOT_INITIALIZED": "ES_RS_TrackerNotInitialized",
        "RS_MEASUREMENT_STATUS_NOT_READY": "ES_RS_MeasurementStatusNotReady",
        "RS_ADM_STARTUP_BUSY": "ES_RS_ADMStartUpBusy",
        "RS_SYSTEM_NOT_READY": "ES_RS_SystemNotReadyForMeasurement",
        "SSC_MEAS_STATUS_NOT_READY": "ES_SSC_MeasStatus_NotReady",
        "SSC_MEAS_STATUS_READY": "ES_SSC_MeasStatus_Ready",
    }
    for ours, theirs in pairs.items():
        assert getattr(es, ours) == getattr(cesapi, theirs), ours


def _measurement(covar: bool) -> es.SingleMeasurement:
    return es.SingleMeasurement(
        status=es.RS_ALL_OK, meas_mode=es.MM_STATIONARY, is_try_mode=False,
        xyz=(2500.125, -310.5, 402.75), std=(0.011, 0.012, 0.013), std_total=0.021,
        covar=(1e-5, -2e-5, 3e-6) if covar else None, temperature=21.5, pressure=1008.0,
        humidity=41.0, pointing_error=(0.1, 0.2, 0.3), apriori_std=(0.01, 0.02, 0.03),
        apriori_std_total=0.04, apriori_covar=(4e-6, 5e-6, 6e-6) if covar else None)


def test_standard_result_reads_as_cesapis():
    raw = es.encode_measurement(_measurement(covar=False))
    theirs = cesapi.SingleMeasResultT()
    theirs.unpack(raw)
    assert theirs.packetInfo.packetHeader.lPacketSize == len(raw) == 156
    assert (theirs.dVal1, theirs.dVal2, theirs.dVal3) == (2500.125, -310.5, 402.75)
    assert (theirs.dStd1, theirs.dStd2, theirs.dStd3, theirs.dStdTotal) == \
        (0.011, 0.012, 0.013, 0.021)
    assert (theirs.dPointingError1, theirs.dAprioriStd3, theirs.dAprioriStdTotal) == \
        (0.1, 0.03, 0.04)
    assert (theirs.dTemperature, theirs.dPressure, theirs.dHumidity) == (21.5, 1008.0, 41.0)
    assert theirs.pack() == raw
    assert es.PacketReader().feed(raw) == [_measurement(covar=False)]


def test_extended_result_reads_as_cesapis():
    raw = es.encode_measurement(_measurement(covar=True))
    theirs = cesapi.SingleMeasResult2T()
    theirs.unpack(raw)
    assert theirs.packetInfo.packetHeader.lPacketSize == len(raw) == 204
    assert theirs.packetInfo.packetHeader.type == cesapi.ES_DT_SingleMeasResult2
    assert (theirs.dCovar12, theirs.dCovar13, theirs.dCovar23) == (1e-5, -2e-5, 3e-6)
    assert (theirs.dPointingErrorH, theirs.dPointingErrorD) == (0.1, 0.3)
    assert (theirs.dAprioriCovar12, theirs.dAprioriCovar23) == (4e-6, 6e-6)
    assert (theirs.dTemperature, theirs.dPressure, theirs.dHumidity) == (21.5, 1008.0, 41.0)
    assert theirs.pack() == raw
    assert es.PacketReader().feed(raw) == [_measurement(covar=True)]


def test_answers_errors_and_status_changes_read_as_cesapis():
    theirs = cesapi.GetEnvironmentParamsRT()
    theirs.packetInfo.status = cesapi.ES_RS_AllOK
    theirs.environmentData.dTemperature = 19.0
    theirs.environmentData.dPressure = 990.0
    theirs.environmentData.dHumidity = 55.0
    assert es.encode_answer(es.C_GET_ENVIRONMENT_PARAMS, es.RS_ALL_OK, 19.0, 990.0, 55.0) == \
        theirs.pack()
    failed = cesapi.StartMeasurementRT()
    failed.packetInfo.status = cesapi.ES_RS_TrackerNotInitialized
    assert es.encode_answer(es.C_START_MEASUREMENT, es.RS_TRACKER_NOT_INITIALIZED) == \
        failed.pack()
    status = cesapi.GetTrackerStatusRT()
    status.trackerStatus = cesapi.ES_TS_Ready
    assert es.encode_answer(es.C_GET_TRACKER_STATUS, es.RS_ALL_OK, es.TS_READY) == status.pack()
    error = cesapi.ErrorResponseT()
    error.command, error.status = cesapi.ES_C_StartMeasurement, cesapi.ES_RS_ADMStartUpBusy
    assert es.encode_error(es.C_START_MEASUREMENT, es.RS_ADM_STARTUP_BUSY) == error.pack()
    change = cesapi.SystemStatusChangeT()
    change.systemStatusChange = cesapi.ES_SSC_MeasStatus_NotReady
    assert es.encode_status_change(es.SSC_MEAS_STATUS_NOT_READY) == change.pack()
    position = cesapi.ReflectorPosResultT()
    position.dVal1, position.dVal2, position.dVal3 = 1.0, 2.0, 3.0
    assert es.encode_reflector_position((1.0, 2.0, 3.0)) == position.pack()
    # cesapi's factory reads ours as the right classes
    factory = cesapi.PacketFactory()
    assert type(factory.packet(es.encode_answer(es.C_INITIALIZE, 0))) is cesapi.InitializeRT
    assert type(factory.packet(es.encode_measurement(_measurement(True)))) is \
        cesapi.SingleMeasResult2T


def test_reader_splits_and_merges():
    stream = es.encode_status_change(es.SSC_MEAS_STATUS_READY) + \
        es.encode_answer(es.C_START_MEASUREMENT, 0) + es.encode_measurement(_measurement(True))
    reader = es.PacketReader()
    got = []
    for i in range(0, len(stream), 7):
        got += reader.feed(stream[i:i + 7])
    assert got == [es.StatusChange(es.SSC_MEAS_STATUS_READY),
                   es.Answer(es.C_START_MEASUREMENT, 0, ()), _measurement(True)]


def test_reader_names_what_it_cannot_read_and_reads_on():
    unknown = es.HEADER.pack(16, 3) + bytes(8)  # type 3 is no packet type
    wrong_size = es.HEADER.pack(20, es.DT_STATUS_CHANGE) + bytes(12)
    foreign = es.HEADER.pack(12, es.DT_COMMAND) + (999).to_bytes(4, "little")
    reader = es.PacketReader(from_client=True)
    got = reader.feed(unknown + wrong_size + foreign + es.encode_command(es.C_INITIALIZE))
    assert [type(p) for p in got] == [es.Unreadable] * 3 + [es.Command]
    assert "type 3" in got[0].reason and "has 20 bytes" in got[1].reason
    assert got[2].command == 999 and got[0].command is None


@pytest.mark.parametrize("size", [0, 8, -4, 1 << 20])
def test_reader_refuses_a_size_out_of_bounds(size):
    reader = es.PacketReader()
    with pytest.raises(FramingError, match="out of"):
        reader.feed(es.HEADER.pack(size, 0) + bytes(8))
    with pytest.raises(FramingError, match="broke earlier"):
        reader.feed(es.encode_status_change(es.SSC_MEAS_STATUS_READY))


def test_a_command_with_the_wrong_number_of_parameters_is_refused():
    with pytest.raises(ValueError, match="takes 1 parameters, got 0"):
        es.encode_command(es.C_FIND_REFLECTOR)
