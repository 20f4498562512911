import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from protocol.codec import (
    FRAME_LEN,
    Abrt,
    Ack,
    Bye,
    Decoder,
    Done,
    Err,
    Go,
    Helo,
    Home,
    Joints,
    Load,
    MovJ,
    Pose,
    Run,
    Stat,
    StatReply,
    Wait,
    Zero,
    encode,
    frame,
    parse_payload,
)
from protocol.errors import FramingError, PayloadError, ProtocolError

SIX = (10.5, -20.25, 30.0, -0.0001, 179.9999, -400.0)
MESSAGES = [
    Helo(1), Stat(2), Load(3, "CAL", 40), Load(4, "PERF", 200), Run(5, "CAL", "AUTO"),
    Run(6, "PERF", "STEP"), Go(7, 12), MovJ(8, SIX), Home(9), Zero(10, SIX), Abrt(11),
    Bye(999999), Joints(5, 0, 0, SIX), Pose(5, 2, 39, (815.0, 0.0, 961.5, 0.0, 90.0, 0.0)),
    Ack(1, "HELO", ("1",)), Ack(3, "LOAD"), Err(1, 15, "version"), Err(5, 22, "aborted"),
    StatReply(2, "IDLE", "AUTO", "NONE", 0, 0, 1), Wait(6, 3), Done(5, "RUN"),
]
# Recorded frames, as a controller and a client put them on the wire.
RECORDED = (
    b"1 HELO 1#".ljust(80) + b"1 ACK HELO 1#".ljust(80)
    + b"12 j 0 0 -53.6383 45.9603 6.5768 -9.2281 -83.1463 55.7123#".ljust(80)
    + b"12 p 2 0 548.855 -728.036 373.040 52.5837 34.3963 23.5934#".ljust(80)
    + b"12 DONE RUN#".ljust(80)
)


@pytest.mark.parametrize("msg", MESSAGES, ids=lambda m: type(m).__name__)
def test_every_message_round_trips_in_one_80_byte_frame(msg):
    data = encode(msg)
    assert len(data) == FRAME_LEN and data.rstrip(b" ").endswith(b"#")
    assert Decoder().feed(data) == [msg]


def test_numbers_are_written_with_the_protocol_decimals():
    assert encode(Pose(1, 0, 0, (1.23456, -0.00001, 2, 3.14159265, 0, -1))).startswith(
        b"1 p 0 0 1.235 0.000 2.000 3.1416 0.0000 -1.0000#")
    assert b"e" not in encode(MovJ(1, (1e-9, 0, 0, 0, 0, 0)))


@pytest.mark.parametrize("chunking", ["whole", "halves", "bytes"])
def test_recorded_frames_whole_split_and_byte_by_byte(chunking):
    d = Decoder()
    if chunking == "whole":
        chunks = [RECORDED]
    elif chunking == "halves":
        chunks = [RECORDED[k:k + 40] for k in range(0, len(RECORDED), 40)]
    else:
        chunks = [RECORDED[k:k + 1] for k in range(len(RECORDED))]
    out = [m for c in chunks for m in d.feed(c)]
    assert [type(m).__name__ for m in out] == ["Helo", "Ack", "Joints", "Pose", "Done"]
    assert out[2].values[0] == -53.6383 and out[3].flag == 2
    assert d.pending_bytes == 0


@pytest.mark.parametrize(("raw", "error"), [
    (b"1 HELO 1".ljust(80), "no '#'"),
    (b"1 HELO 1#  x".ljust(80), "other than spaces"),
    (b"1 HELO\x00 1#".ljust(80), "non-printable"),
    (b"#".ljust(80), "empty payload"),
])
def test_framing_errors_are_fatal(raw, error):
    d = Decoder()
    with pytest.raises(FramingError, match=error):
        d.feed(raw)
    with pytest.raises(FramingError, match="stopped"):
        d.feed(encode(Stat(1)))


@pytest.mark.parametrize(("payload", "code"), [
    ("1 FLY", 11), ("1 HELO x", 12), ("1 MOVJ 1 2 3", 12), ("1 MOVJ 1 2 3 4 5 1e3", 12),
    ("1 MOVJ 1 2 3 4 5 +6", 12), ("0 STAT", 10), ("1  STAT", 10), ("1 j 3 0 1 2 3 4 5 6", 12),
    ("1 LOAD CAL x", 12), ("1 RUN CAL FAST", 12), ("1,000 STAT", 10),
])
def test_bad_payloads_carry_the_err_code(payload, code):
    with pytest.raises(PayloadError) as err:
        parse_payload(payload)
    assert err.value.code == code


def test_a_bad_payload_does_not_lose_its_neighbours():
    d = Decoder()
    data = encode(Stat(1)) + frame("2 FLY") + encode(Stat(3))
    assert d.feed(data) == [Stat(1)]
    with pytest.raises(PayloadError) as err:
        d.feed()
    assert err.value.seq == 2
    assert d.feed() == [Stat(3)]


def test_payload_limits():
    with pytest.raises(ValueError, match="1-79"):
        frame("x" * 80)
    with pytest.raises(ValueError, match="without '#'"):
        frame("1 ERR 12 bad#text")


@settings(max_examples=400)
@given(st.lists(st.binary(max_size=200), max_size=8))
def test_any_garbage_decodes_or_raises_the_codecs_own_error(chunks):
    d = Decoder()
    for c in chunks:
        try:
            d.feed(c)
        except ProtocolError:
            pass


@settings(max_examples=300)
@given(st.text(alphabet=st.characters(min_codepoint=0x20, max_codepoint=0x7E,
                                      blacklist_characters="#"), min_size=1, max_size=79))
def test_any_printable_payload_parses_or_raises_payload_error(payload):
    try:
        msg = parse_payload(payload)
    except PayloadError:
        return
    try:
        data = encode(msg)  # numbers are rounded to the protocol's decimals...
    except ValueError:
        return  # ...and a value too long for a frame is refused, never sent
    again = Decoder().feed(data)
    assert len(again) == 1 and encode(again[0]) == data  # re-encoding is stable
