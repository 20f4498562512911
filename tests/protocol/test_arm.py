import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from protocol.arm import (
    ArmLineDecoder,
    ArmNotMeasured,
    ArmPoint,
    ArmProblem,
    ArmReader,
    checksum,
    encode_not_measured,
    encode_point,
    parse_line,
)
from protocol.errors import ArmLineError, LinkTimeoutError


def test_checksum_is_the_nmea_xor():
    body = "PT,1,P1,100.0000,-20.5000,3.2500"
    cs = 0
    for c in body:
        cs ^= ord(c)
    assert checksum(body) == f"{cs:02X}"
    line = encode_point(1, "P1", (100.0, -20.5, 3.25))
    assert line == f"${body}*{cs:02X}\r\n".encode()


def test_lines_split_anywhere_decode_in_order():
    data = b"".join(encode_point(k, f"P{k}", (k, -k, 0.5)) for k in (1, 2, 3))
    data += encode_not_measured(4, "P1", "OUT_OF_REACH")
    d = ArmLineDecoder()
    items = [i for k in range(len(data)) for i in d.feed(data[k:k + 1])]
    assert [type(i) for i in items] == [ArmPoint, ArmPoint, ArmPoint, ArmNotMeasured]
    assert items[1] == ArmPoint(2, "P2", (2.0, -2.0, 0.5))


@pytest.mark.parametrize(("line", "reason"), [
    (encode_point(1, "P1", (1, 2, 3)).replace(b"*", b"*0"), "bad checksum"),
    (encode_point(1, "P1", (1, 2, 3)).replace(b"1.0000", b"1.0001"), "bad checksum"),
    (b"$PT,1,P1,1,2*" + checksum("PT,1,P1,1,2").encode() + b"\r\n", "field count"),
    (b"hello\r\n", "not a"),
])
def test_bad_lines_are_reported_never_used(line, reason):
    items = ArmLineDecoder().feed(line)
    assert len(items) == 1 and isinstance(items[0], ArmProblem) and reason in items[0].reason


def test_a_seq_gap_is_reported():
    d = ArmLineDecoder()
    items = d.feed(encode_point(1, "P1", (0, 0, 0)) + encode_point(3, "P2", (0, 0, 0))
                   + encode_point(4, "P3", (0, 0, 0)))
    assert isinstance(items[1], ArmProblem) and "SEQ gap" in items[1].reason
    assert isinstance(items[2], ArmPoint)


@given(st.lists(st.binary(max_size=120), max_size=10))
def test_any_bytes_give_items_never_exceptions(chunks):
    d = ArmLineDecoder()
    for c in chunks:
        for item in d.feed(c):
            assert isinstance(item, ArmPoint | ArmNotMeasured | ArmProblem)


def test_drain_drops_everything_already_received():
    with ArmReader("loop://") as arm:
        arm.port.write(b"".join(encode_point(k + 1, f"P{k + 1}", (k, 0, 0)) for k in range(3)))
        assert arm.drain() == 3
        arm.port.write(b"".join(encode_point(k + 4, f"P{k + 1}", (9, k, 0)) for k in range(3)))
        assert arm.read_holes(2.0).seqs == (4, 5, 6)


def test_reader_over_loop_url():
    with ArmReader("loop://") as arm:
        arm.port.write(encode_point(1, "P3", (9, 9, 9)) + b"$junk*00\r\n"
                       + b"".join(encode_point(k + 2, f"P{k + 1}", (k, 0, 0)) for k in range(3)))
        holes = arm.read_holes(timeout_s=2)
        np.testing.assert_allclose(holes.points_mm, [[0, 0, 0], [1, 0, 0], [2, 0, 0]])
        assert len(arm.problems) == 2  # the lone P3 and the junk line
        with pytest.raises(LinkTimeoutError):
            arm.read_holes(timeout_s=0.2)
        arm.port.write(encode_not_measured(5, "P1", "OUT_OF_REACH"))
        with pytest.raises(ArmLineError, match="P1 not measured"):
            arm.read_holes(timeout_s=2)


def _line(body: str, cs: str | None = None, end: bytes = b"\r\n") -> bytes:
    return f"${body}*{checksum(body) if cs is None else cs}".encode() + end


# a body whose checksum has a hex letter in it, for the lower-case case
LETTERED = next(b for k in range(1, 99) if not checksum(
    b := f"PT,{k},P1,1.0000,2.0000,3.0000").isdigit())


@pytest.mark.parametrize(("line", "reason"), [
    (_line("PT,1,P1,1.0000,2.0000,3.0000", end=b"\n"), "CR LF"),  # LF only
    (_line(LETTERED, checksum(LETTERED).lower()), "checksum"),
    (_line("PT,1,P1,100.0,-20.5000,3.2500"), "4 decimals"),
    (_line("PT,1,P1,100.00000,-20.5000,3.2500"), "4 decimals"),
    (_line("PT,1,P1,100.0000,-20.5000,9000.0000"), "beyond"),
    (_line("PT,1,P1,1000000000000.0000,0.0000,0.0000"), "coordinate"),
    (_line("PT,01,P1,1.0000,2.0000,3.0000"), "bad SEQ"),
])
def test_the_line_is_read_exactly_as_the_spec_writes_it(line, reason):
    with pytest.raises(ArmLineError, match=reason):
        parse_line(line)
    assert isinstance(parse_line(_line("PT,1,P1,1.0000,2.0000,3.0000")), ArmPoint)


@pytest.mark.parametrize(("labels", "used"), [
    (["P1", "P2", "P2", "P3", "P1", "P2", "P3"], (5, 6, 7)),  # P2 twice: that triple is void
    (["P1", "P9", "P2", "P3", "P1", "P2", "P3"], (5, 6, 7)),  # a foreign label inside
    (["P1", "P2", "P1", "P2", "P3"], (3, 4, 5)),  # a restart at P1 starts a new triple
    (["P2", "P3", "P1", "P2", "P3"], (3, 4, 5)),  # the tail of an earlier triple
])
def test_read_holes_takes_only_a_clean_p1_p2_p3_triple(labels, used):
    with ArmReader("loop://") as arm:
        arm.port.write(b"".join(encode_point(k + 1, lab, (k, 0, 0))
                                for k, lab in enumerate(labels)))
        holes = arm.read_holes(2.0)
        assert holes.seqs == used
        assert arm.problems  # what was skipped is said
