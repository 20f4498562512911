"""What can be checked of the RAPID server by reading it: every frame it can build fits 80
characters, whatever the input. Its behaviour is tested by running it: the emulator executes it
(tests/simulators), and tests/simulators/rapid holds the findings of issue 24."""

import re

import pytest

from protocol import codec
from protocol.rapid import module_text

TEXT = module_text()
# The code without comment lines, on one line: calls are found wherever they stand.
FLAT = re.sub(r"\s+", " ", "\n".join(line for line in TEXT.splitlines()
                                     if not line.strip().startswith("!")))

# The widest text each piece can produce. NumToStr(x, 0): a SEQ (<= 999999) unless the argument
# is known narrower (FLAG 0-2, list indices and counts <= 200, ERR codes < 100);
# NumToStr(x, 3): tool0 x, y, z ("-9999.999"); NumToStr(x, 4): joints and EulerZYX angles
# ("-400.0000").
NUM_WIDTH = {"0": 6, "3": 9, "4": 9}
INT_WIDTH = {"flag": 1, "idx": 3, "i": 3, "k": 3, "cur_idx": 3, "cur_count": 3, "code": 2}
VARIABLES = {"h": 7, "state": 7, "mode": 4, "cur_list": 4, "verb": 4, "text": 0,
             "bad_text": 0, "p": 0, "tok{3}": 4, "busy": len("waiting for the FlexPendant")}


def literals():
    return re.findall(r'"([^"]*)"', TEXT)


def test_every_string_literal_fits_a_rapid_string():
    assert literals()
    assert max(len(s) for s in literals()) <= 80


def _split_plus(expr: str) -> list[str]:
    parts, depth, quoted, cur = [], 0, False, ""
    for c in expr:
        if c == '"':
            quoted = not quoted
        elif not quoted and c == "(":
            depth += 1
        elif not quoted and c == ")":
            depth -= 1
        if c == "+" and depth == 0 and not quoted:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += c
    parts.append(cur.strip())
    return parts


def width(expr: str) -> int:
    total = 0
    for term in _split_plus(expr):
        if term.startswith('"'):
            total += len(term.strip('"'))
        elif term.startswith("NumToStr("):
            arg, decimals = (x.strip() for x in term[len("NumToStr("):-1].rsplit(",", 1))
            total += INT_WIDTH.get(arg, NUM_WIDTH[decimals]) if decimals == "0" else \
                NUM_WIDTH[decimals]
        elif term in VARIABLES:
            total += VARIABLES[term]
        else:
            raise AssertionError(f"cannot bound the width of {term!r}")
    return total


def _texts_for(call: str) -> list[str]:
    """The argument text of every `call ...;` in the module."""
    return [m.group(1).strip() for m in re.finditer(rf"\b{call} ([^;]*);", FLAT)]


def test_every_frame_it_can_build_fits_80_characters():
    # Texts passed to SendErr (literals and the bad_text expressions).
    bad_texts = [m.group(1) for m in re.finditer(r"\bbad_text := ([^;]*);", FLAT)]
    VARIABLES["bad_text"] = max(width(t) for t in bad_texts)
    err_texts = [args.split(",", 2)[2].strip() for args in _texts_for("SendErr")]
    VARIABLES["text"] = max(width(t) for t in err_texts)
    frames = {}
    for args in _texts_for("SendFrame"):
        frames[args] = width(args)
    for args in _texts_for("SendTo"):
        frames[args] = width(args.split(",", 1)[1])
    for args in _texts_for("SendAck"):
        frames["ACK " + args] = NUM_WIDTH["0"] + len(" ACK ") + width(args.split(",", 1)[1])
    for args in _texts_for("SendDone"):
        frames["DONE " + args] = NUM_WIDTH["0"] + len(" DONE ") + width(args.split(",", 1)[1])
    for args in _texts_for("SendErr"):
        frames["ERR " + args] = (NUM_WIDTH["0"] + len(" ERR ") + 2 + 1
                                 + width(args.split(",", 2)[2]))
    assert len(frames) > 15
    too_long = {k: v for k, v in frames.items() if v > codec.FRAME_LEN - 1}
    assert not too_long, too_long
    # ...and the one place that sends pads every payload to exactly 80 with '#'.
    assert _texts_for("SocketSend") == ["sock \\Str:=f"]
    assert "WHILE StrLen(f) < FRAME_LEN DO" in TEXT and "CONST num FRAME_LEN := 80" in TEXT


def test_it_handles_exactly_the_codecs_request_verbs():
    dispatch = TEXT[TEXT.index("PROC Dispatch()"):TEXT.index("ENDPROC", TEXT.index(
        "PROC Dispatch()"))]
    handled = set(re.findall(r'CASE "([A-Z]+)":', dispatch))
    assert handled == set(codec.REQUEST_VERBS)
    # data packets outside LOAD and the controller's own verbs are answered, not unknown
    assert 'CASE "j", "p":' in dispatch and 'CASE "ACK", "ERR", "WAIT", "DONE":' in dispatch
    sent = set(re.findall(r'" (ACK|ERR|STAT|WAIT|DONE) ', TEXT)) | set(
        re.findall(r'"(j|p) "', TEXT))
    verbs = {*codec.REQUEST_VERBS, *codec.REPLY_VERBS, *codec.DATA_VERBS}
    assert sent <= verbs and {"ACK", "ERR", "STAT", "WAIT", "DONE", "j", "p"} <= sent


def test_it_reads_exact_frames_and_survives_every_error():
    assert "\\ReadNoOfBytes:=FRAME_LEN" in TEXT
    main = TEXT[TEXT.index("PROC main()"):TEXT.index("ENDPROC")]
    assert "TRYNEXT" in main and "RETRY" not in main  # a motion is never executed twice
    assert "UNDO" in main  # PP to Main closes the sockets


@pytest.mark.parametrize("limit", ["-180,-90,-245,-200,-115,-400", "180,150,65,200,115,400"])
def test_its_joint_limits_are_the_irb1600s(limit):
    assert f"[{limit}]" in TEXT
