"""docs/protocol.md's request rules, each against the interpreted module: raw frames in, the
module's answers out."""

from __future__ import annotations

import pytest

from tests.simulators.rapid.test_findings import controller, exchange

J = "10.0000 20.0000 -30.0000 40.0000 50.0000 60.0000"


@pytest.mark.parametrize(("request_", "answer"), [
    ("2 FOO", "2 ERR 11 unknown verb"),
    ("2 HELO 2", "2 ERR 15 version"),
    ("2 HELO x", "2 ERR 12 bad arguments"),
    (f"2 j 2 0 {J}", "2 ERR 13 data packet outside LOAD"),
    ("2 GO 0", "2 ERR 13 no step waiting"),
    ("2 LOAD CAL 201", "2 ERR 14 list too long"),
    ("2 LOAD CAL 123456789", "2 ERR 14 list too long"),
    ("2 LOAD CAL 0", "2 ERR 12 a list holds 1 to 200 poses"),
    ("2 LOAD XYZ 1", "2 ERR 12 bad arguments"),
    ("2 RUN CAL AUTO", "2 ERR 13 no CAL list loaded"),
    ("2 RUN CAL FAST", "2 ERR 12 bad arguments"),
    ("2 MOVJ 1e3 0 0 0 0 0", "2 ERR 12 bad arguments"),
    ("2 MOVJ +1 0 0 0 0 0", "2 ERR 12 bad arguments"),
    ("2 MOVJ 3601 0 0 0 0 0", "2 ERR 12 bad arguments"),
    ("2 MOVJ 0 0 0 0 0", "2 ERR 12 bad arguments"),
    ("2 MOVJ 181 0 0 0 0 0", "2 ERR 20 target outside joint limits"),
    ("2 HOME x", "2 ERR 12 bad arguments"),
    ("2 ABRT", "2 ACK ABRT"),
    ("2 STAT", "2 STAT IDLE AUTO NONE 0 0 1"),
])
async def test_a_request_and_its_answer(request_, answer):
    async with controller(None) as emu:
        out = await exchange(emu, ["1 HELO 1", request_], 2)
    assert out == ["1 ACK HELO 1", answer]


@pytest.mark.parametrize("bad", ["1  HELO 1", " 1 HELO 1", "0 HELO 1", "1234567 HELO 1",
                                 "x HELO 1", "1"])
async def test_a_frame_without_a_seq_to_answer_drops_the_link(bad):
    async with controller(None) as emu:
        assert await exchange(emu, [bad], 1, timeout=1.0) == []
        assert (await exchange(emu, ["1 HELO 1"], 1)) == ["1 ACK HELO 1"]  # it goes on


async def test_load_checks_every_packets_seq_flag_and_idx():
    async with controller(None) as emu:
        out = await exchange(emu, ["1 HELO 1", "2 LOAD CAL 2", f"2 j 0 0 {J}", f"2 j 1 1 {J}",
                                   "3 STAT"], 3)
    assert out[1] == "2 ERR 12 packet 1 out of order" and out[2].startswith("3 STAT IDLE")
