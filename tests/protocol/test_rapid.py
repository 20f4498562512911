"""What can be checked of the RAPID server without a controller."""

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
             "bad_text": 0, "p": 0}


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
    sent = set(re.findall(r'" (ACK|ERR|STAT|WAIT|DONE) ', TEXT)) | set(
        re.findall(r'"(j|p) "', TEXT))
    verbs = {*codec.REQUEST_VERBS, *codec.REPLY_VERBS, *codec.DATA_VERBS}
    assert sent <= verbs and {"ACK", "ERR", "STAT", "WAIT", "DONE", "j", "p"} <= sent


def test_it_reads_exact_frames_and_recovers_from_socket_errors():
    assert "\\ReadNoOfBytes:=FRAME_LEN" in TEXT
    main = TEXT[TEXT.index("PROC main()"):TEXT.index("ENDPROC")]
    assert "ERR_SOCK_TIMEOUT" in main and "ERR_SOCK_CLOSED" in main
    assert "TRYNEXT" in main and "RETRY" not in main  # a motion is never executed twice
    for call in ("SocketCreate", "SocketBind", "SocketListen", "SocketAccept", "CJointT",
                 "CRobT", "EulerZYX", "MoveAbsJ"):
        assert call in TEXT, call


@pytest.mark.parametrize("limit", ["-180,-90,-245,-200,-115,-400", "180,150,65,200,115,400"])
def test_its_joint_limits_are_the_irb1600s(limit):
    assert f"[{limit}]" in TEXT


# -- the module's state machine, read from its routines ---------------------------------------

def routines() -> dict[str, str]:
    """Every PROC/FUNC of the module: name -> its body (comments dropped, one line)."""
    found = re.finditer(r"\b(?:PROC|FUNC \w+) (\w+)\(.*?\)(.*?)\bEND(?:PROC|FUNC)\b", FLAT)
    return {m.group(1): m.group(2) for m in found}


ROUTINES = routines()


def calls(name: str) -> set[str]:
    """The module's routines that `name` calls (procedure calls and function uses)."""
    body = ROUTINES[name]
    return {r for r in ROUTINES if r != name and re.search(rf"\b{r}\b", body)}


def reaches(name: str, target: str, seen: frozenset[str] = frozenset()) -> bool:
    return target in calls(name) or any(reaches(r, target, seen | {name})
                                        for r in calls(name) - seen - {name})


def test_only_receive_request_reads_the_client():
    readers = [r for r, body in ROUTINES.items() if "SocketReceive" in body]
    assert readers == ["ReceiveRequest"]
    # every place that waits for the client goes through it: idle, LOAD, between moves, GO
    for waiting in ("main", "DoLoad", "BetweenMoves", "WaitGo"):
        assert reaches(waiting, "ReceiveRequest"), waiting


def test_an_idle_owner_is_dropped_and_a_newcomer_told_busy():
    body = ROUTINES["ReceiveRequest"]
    wait = body[body.index("WHILE SocketPeek(client_socket) < FRAME_LEN DO"):
                body.index("ENDWHILE")]
    assert "RefuseNewcomer" in wait and "IF quiet >= IDLE_S THEN Relisten; RETURN;" in wait
    assert body.index("ENDWHILE") < body.index("SocketReceive")  # reads only a whole frame
    assert re.search(r"CONST num IDLE_S := 60;", TEXT)
    refuse = ROUTINES["RefuseNewcomer"]
    assert 'SendTo busy_socket, "0 ERR 16 busy"; SocketClose busy_socket;' in refuse
    assert "SocketAccept server_socket, busy_socket \\Time:=POLL_S" in refuse
    assert "ERR_SOCK_TIMEOUT" in refuse  # no newcomer: back to waiting for the owner
    assert f"0 ERR {codec.BUSY} busy" in TEXT


def test_load_refuses_a_bad_count_before_reading_any_packet():
    body = ROUTINES["DoLoad"]
    loop = body.index("FOR k FROM 0 TO n - 1 DO")
    for check, code in (("IF n > MAX_LIST THEN", 14), ("IF n < 1 OR n <> Trunc(n) THEN", 12)):
        at = body.index(check)
        assert at < loop and f"SendErr load_seq, {code}," in body[at:body.index("RETURN", at)]


def test_a_request_mid_load_discards_the_list_and_moves_nothing():
    body = ROUTINES["DoLoad"]
    branch = body[body.index('IF tok{2} <> "j" AND tok{2} <> "p" THEN'):]
    branch = branch[:branch.index("ENDIF")]
    assert "SendErr seq, 13," in branch and "SendErr load_seq, 13," in branch
    assert branch.rstrip().endswith("RETURN;")
    assert "Dispatch" not in body and "MoveAbsJ" not in body  # never runs the request
    # the lists change only after every packet was read and found good
    assert body.index("bad_code <> 0") < body.index("cal_list{k} := load_buf{k}")


def test_load_checks_every_packets_seq_flag_and_idx():
    body = ROUTINES["DoLoad"]
    assert re.search(r"seq <> load_seq OR ntok <> 10 OR tok\{3\} <> NumToStr\(Flag\(k, n\), 0\) "
                     r"OR tok\{4\} <> NumToStr\(k, 0\) THEN bad_code := 12;", body)


def test_no_token_of_an_earlier_request_survives():
    body = ROUTINES["Tokenize"]
    clear = body.index('tok{i} := "";')
    assert clear < body.index("WHILE start <= StrLen(payload)")
    assert "FOR i FROM 1 TO 10 DO" in body and "VAR string tok{10};" in TEXT
    assert [r for r, b in ROUTINES.items() if "Tokenize;" in b] == ["ReceiveRequest"]


def test_motion_only_after_its_checks():
    run = ROUTINES["DoRun"]
    assert run.index("WaitGo(run_seq, i)") < run.index("MoveAbsJ")  # STEP: GO first
    assert run.index("BetweenMoves(run_seq)") < run.index("MoveAbsJ")  # ABRT honoured
    move = ROUTINES["DoMove"]
    assert move.index("InLimits(jt)") < move.index("MoveAbsJ")
    zero = ROUTINES["DoZero"]
    assert zero.index("InLimits(jt)") < zero.index("MoveAbsJ") < zero.index("WaitGo(zero_seq, 0)")
