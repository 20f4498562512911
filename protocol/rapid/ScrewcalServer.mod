MODULE ScrewcalServer
  !*********************************************************************
  ! screwcal wire protocol v1 server for an ABB IRC5 (RobotWare 6 with
  ! the option "PC Interface", which brings Socket Messaging). The
  ! controller is the server, the PC the client (thesis 4.4,
  ! Algorithms 1 and 2). Every frame is 80 chars: payload, "#", spaces
  ! (docs/protocol.md). A session ends (the client is closed, the
  ! listening socket kept) on a socket time-out or close, a bad frame,
  ! an owner silent for IDLE_S, BYE, or any error: the program itself
  ! never stops for a client. A request is never executed twice.
  ! One client owns the controller: a newcomer gets "0 ERR 16 busy".
  ! Adapt to the cell: BIND_ADDRESS (the controller's address the PC
  ! reaches: 192.168.125.1 on the service port, or the LAN address),
  ! PORT, and the joint limits J_MIN/J_MAX (the IRB 1600's below).
  !*********************************************************************
  PERS string BIND_ADDRESS := "192.168.125.1";
  CONST num PORT := 4012;
  CONST num FRAME_LEN := 80;
  CONST num MAX_LIST := 200;
  CONST num MAX_SEQ := 999999;
  CONST num IDLE_S := 60;
  CONST num POLL_S := 0.1;
  CONST num NEWCOMER_S := 0.01;
  CONST num J_MIN{6} := [-180,-90,-245,-200,-115,-400];
  CONST num J_MAX{6} := [180,150,65,200,115,400];
  CONST speeddata MOVE_SPEED := v100;
  CONST jointtarget HOME_JT := [[0,0,0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  ! The printable characters 0x20..0x7E, in two strings of at most 80.
  CONST string PRINT_A := " !""#$%&'()*+,-./0123456789:;<=>?@ABCDEFGHIJKLMNO";
  CONST string PRINT_B := "PQRSTUVWXYZ[\\]^_`abcdefghijklmnopqrstuvwxyz{|}~";

  VAR socketdev server_socket;
  ! The owner's connection is conn{owner}, a newcomer's the other one.
  VAR socketdev conn{2};
  VAR num owner := 1;
  VAR bool connected := FALSE;
  VAR bool busy_open := FALSE;
  VAR string client_ip;
  VAR clock idle_clk;
  VAR jointtarget cal_list{MAX_LIST};
  VAR jointtarget perf_list{MAX_LIST};
  VAR jointtarget load_buf{MAX_LIST};
  VAR num cal_count := 0;
  VAR num perf_count := 0;
  VAR string state := "IDLE";
  VAR string mode := "AUTO";
  VAR string cur_list := "NONE";
  VAR num cur_idx := 0;
  VAR num cur_count := 0;
  VAR num last_seq := 0;
  VAR string frm;
  VAR string payload;
  VAR num hash := 0;
  VAR string tok{10};
  VAR num ntok := 0;
  VAR num seq := 0;
  VAR num vals{6};
  VAR bool have_req := FALSE;
  VAR bool ok := FALSE;

  PROC main()
    Listen;
    WHILE TRUE DO
      IF NOT connected AcceptClient;
      have_req := FALSE;
      ReceiveRequest;
      IF have_req Dispatch;
    ENDWHILE
  ERROR
    ! Whatever ends a session ends only the session: the client is
    ! closed, the listening socket kept, the program goes on.
    IF ERRNO = ERR_SOCK_ADDR_INVALID RAISE;
    IF ERRNO = ERR_SOCK_TIMEOUT OR ERRNO = ERR_SOCK_CLOSED THEN
      SkipWarn;
    ELSE
      ErrWrite \W, "ScrewcalServer", "A session ended on an error"
        \RL2:="ERRNO " + ValToStr(ERRNO);
    ENDIF
    DropClient;
    TRYNEXT;
  UNDO
    ! PP to Main mid-session: nothing stays open for the next start.
    SocketClose conn{1};
    SocketClose conn{2};
    SocketClose server_socket;
  ENDPROC

  ! Bind and listen; a port still held (TIME_WAIT after a restart) is
  ! tried again every second.
  PROC Listen()
    VAR num tries := 0;
    WHILE NOT TryBind() DO
      IF tries = 0 ErrWrite \W, "ScrewcalServer", "Port in use, trying again";
      Incr tries;
      WaitTime 1;
    ENDWHILE
    SocketListen server_socket;
  ENDPROC

  FUNC bool TryBind()
    SocketClose server_socket;
    SocketCreate server_socket;
    SocketBind server_socket, BIND_ADDRESS, PORT;
    RETURN TRUE;
  ERROR
    IF ERRNO = ERR_SOCK_ADDR_INUSE THEN
      SkipWarn;
      RETURN FALSE;
    ENDIF
  ENDFUNC

  PROC AcceptClient()
    SocketClose conn{owner};
    SocketAccept server_socket, conn{owner} \ClientAddress:=client_ip \Time:=WAIT_MAX;
    connected := TRUE;
    ClkReset idle_clk;
    ClkStart idle_clk;
  ENDPROC

  ! The session ends: the client is closed, the listening socket kept
  ! (closing and binding it again fails while the port is in TIME_WAIT).
  PROC DropClient()
    FlushClient;
    SocketClose conn{owner};
    connected := FALSE;
    have_req := FALSE;
    IF state = "MOVING" OR state = "WAITING" state := "IDLE";
  ENDPROC

  ! What the client sent and nobody will read is read and dropped
  ! before the close: a close with unread data resets the connection,
  ! and the client would lose the replies still on their way.
  PROC FlushClient()
    VAR string junk;
    VAR num n := 0;
    WHILE n < 64 AND SocketPeek(conn{owner}) > 0 DO
      SocketReceive conn{owner} \Str:=junk \Time:=0.1;
      Incr n;
    ENDWHILE
  ERROR
    SkipWarn;
    RETURN;
  ENDPROC

  ! The one place that reads the client: one 80-char frame -> payload
  ! and tokens. It waits at most POLL_S at a time for the frame's first
  ! byte (a request is read the moment it arrives); between waits a
  ! newcomer is told busy and an owner silent for IDLE_S is dropped.
  ! Half a frame is silence: the rest must come within the idle time.
  ! A bad frame (docs/protocol.md) drops the link: no guessing.
  PROC ReceiveRequest()
    VAR string first;
    VAR string rest;
    ClkReset idle_clk;
    ClkStart idle_clk;
    WHILE NOT FirstByte(first) DO
      RefuseNewcomer;
      IF ClkRead(idle_clk) >= IDLE_S THEN
        DropClient;
        RETURN;
      ENDIF
    ENDWHILE
    IF NOT RestOfFrame(rest) THEN
      DropClient;
      RETURN;
    ENDIF
    frm := first + rest;
    ! Two tests, not one OR: RAPID evaluates both sides of an OR.
    IF NOT FrameOk() THEN
      DropClient;
      RETURN;
    ENDIF
    IF NOT Tokenize() THEN
      DropClient;
      RETURN;
    ENDIF
    IF NOT IsInt(tok{1}) OR StrLen(tok{1}) > 6 THEN
      DropClient;
      RETURN;
    ENDIF
    ok := StrToVal(tok{1}, seq);
    IF ntok < 2 OR (seq = 0 AND tok{2} <> "ERR") THEN
      DropClient;
      RETURN;
    ENDIF
    have_req := TRUE;
  ENDPROC

  ! The next frame's first byte, waiting at most POLL_S for it.
  FUNC bool FirstByte(INOUT string first)
    SocketReceive conn{owner} \Str:=first \ReadNoOfBytes:=1 \Time:=POLL_S;
    RETURN TRUE;
  ERROR
    IF ERRNO = ERR_SOCK_TIMEOUT THEN
      SkipWarn;
      RETURN FALSE;
    ENDIF
  ENDFUNC

  ! The frame's other 79 bytes, within what is left of the idle time.
  FUNC bool RestOfFrame(INOUT string rest)
    VAR num left;
    left := IDLE_S - ClkRead(idle_clk);
    IF left < 0.01 left := 0.01;
    SocketReceive conn{owner} \Str:=rest \ReadNoOfBytes:=FRAME_LEN - 1 \Time:=left;
    RETURN TRUE;
  ERROR
    IF ERRNO = ERR_SOCK_TIMEOUT THEN
      SkipWarn;
      RETURN FALSE;
    ENDIF
  ENDFUNC

  ! 80 bytes, each printable, "#" after 1..79 of them, then spaces.
  FUNC bool FrameOk()
    VAR num p := 1;
    VAR num a;
    IF StrLen(frm) <> FRAME_LEN RETURN FALSE;
    WHILE p <= FRAME_LEN DO
      a := StrFind(frm, p, PRINT_A \NotInSet);
      IF a <= FRAME_LEN THEN
        IF NOT StrMemb(frm, a, PRINT_B) RETURN FALSE;
      ENDIF
      p := a + 1;
    ENDWHILE
    hash := StrFind(frm, 1, "#");
    IF hash <= 1 OR hash > FRAME_LEN RETURN FALSE;
    IF hash < FRAME_LEN THEN
      IF StrFind(frm, hash + 1, " " \NotInSet) <= FRAME_LEN RETURN FALSE;
    ENDIF
    payload := StrPart(frm, 1, hash - 1);
    RETURN TRUE;
  ENDFUNC

  ! Tokens separated by single spaces (none leading, none trailing);
  ! every request's tokens start empty. More than 10: ntok = 11.
  FUNC bool Tokenize()
    VAR num start := 1;
    VAR num sp;
    FOR i FROM 1 TO 10 DO
      tok{i} := "";
    ENDFOR
    ntok := 0;
    IF StrPart(payload, StrLen(payload), 1) = " " RETURN FALSE;
    WHILE start <= StrLen(payload) DO
      sp := StrFind(payload, start, " ");
      IF sp = start RETURN FALSE;
      IF ntok = 10 THEN
        ntok := 11;
        RETURN TRUE;
      ENDIF
      Incr ntok;
      tok{ntok} := StrPart(payload, start, sp - start);
      start := sp + 1;
    ENDWHILE
    RETURN TRUE;
  ENDFUNC

  ! Digits only.
  FUNC bool IsInt(string t)
    IF StrLen(t) = 0 RETURN FALSE;
    RETURN StrFind(t, 1, STR_DIGIT \NotInSet) > StrLen(t);
  ENDFUNC

  ! A protocol number: optional "-", digits, optional "." and digits.
  FUNC bool IsNum(string t)
    VAR num s := 1;
    VAR num d;
    IF StrLen(t) = 0 RETURN FALSE;
    IF StrPart(t, 1, 1) = "-" s := 2;
    d := StrFind(t, s, STR_DIGIT \NotInSet);
    IF d = s RETURN FALSE;
    IF d > StrLen(t) RETURN TRUE;
    IF StrPart(t, d, 1) <> "." OR d = StrLen(t) RETURN FALSE;
    RETURN StrFind(t, d + 1, STR_DIGIT \NotInSet) > StrLen(t);
  ENDFUNC

  ! An integer token within lo..hi into n.
  FUNC bool IntIn(string t, num lo, num hi, INOUT num n)
    IF NOT IsInt(t) OR StrLen(t) > 6 RETURN FALSE;
    ok := StrToVal(t, n);
    RETURN n >= lo AND n <= hi;
  ENDFUNC

  ! Six numbers from tok{first..first+5} into vals: the first three
  ! within +-b1, the last three within +-b2.
  FUNC bool TokSix(num first, num b1, num b2)
    IF ntok <> first + 5 RETURN FALSE;
    FOR i FROM 1 TO 6 DO
      IF NOT IsNum(tok{first + i - 1}) RETURN FALSE;
      IF NOT StrToVal(tok{first + i - 1}, vals{i}) RETURN FALSE;
      IF i <= 3 AND Abs(vals{i}) > b1 RETURN FALSE;
      IF i > 3 AND Abs(vals{i}) > b2 RETURN FALSE;
    ENDFOR
    RETURN TRUE;
  ENDFUNC

  ! Another client while one owns the controller: told busy, what it
  ! sent read and dropped (a close with unread data resets the link and
  ! the refusal would be lost), then closed. Waits NEWCOMER_S. If
  ! the owner has left meanwhile, the newcomer is the next owner.
  PROC RefuseNewcomer()
    VAR string junk;
    VAR num n := 0;
    VAR num other;
    other := 3 - owner;
    SocketAccept server_socket, conn{other} \Time:=NEWCOMER_S;
    busy_open := TRUE;
    IF OwnerGone() THEN
      SocketClose conn{owner};
      owner := other;
      busy_open := FALSE;
      have_req := FALSE;
      IF state = "MOVING" OR state = "WAITING" state := "IDLE";
      ClkReset idle_clk;
      ClkStart idle_clk;
      RETURN;
    ENDIF
    SendTo conn{other}, "0 ERR 16 busy";
    WHILE n < 64 DO
      SocketReceive conn{other} \Str:=junk \Time:=0.02;
      Incr n;
    ENDWHILE
    SocketClose conn{other};
    busy_open := FALSE;
  ERROR
    ! Nobody came (the usual case), or the newcomer is done or gone.
    SkipWarn;
    IF busy_open SocketClose conn{3 - owner};
    busy_open := FALSE;
    RETURN;
  ENDPROC

  ! The owner closed its end (its unread requests are gone with it).
  FUNC bool OwnerGone()
    VAR num n;
    n := SocketPeek(conn{owner});
    RETURN FALSE;
  ERROR
    SkipWarn;
    RETURN TRUE;
  ENDFUNC

  PROC SendFrame(string p)
    SendTo conn{owner}, p;
  ENDPROC

  ! Every frame goes out here: payload, "#", spaces up to 80 chars.
  ! Callers build payloads of at most 79 chars from bounded values.
  PROC SendTo(VAR socketdev sock, string p)
    VAR string f;
    f := p + "#";
    WHILE StrLen(f) < FRAME_LEN DO
      f := f + " ";
    ENDWHILE
    SocketSend sock \Str:=f;
  ENDPROC

  PROC SendAck(num s, string verb)
    SendFrame NumToStr(s, 0) + " ACK " + verb;
  ENDPROC

  PROC SendErr(num s, num code, string text)
    SendFrame NumToStr(s, 0) + " ERR " + NumToStr(code, 0) + " " + text;
  ENDPROC

  PROC SendDone(num s, string verb)
    SendFrame NumToStr(s, 0) + " DONE " + verb;
  ENDPROC

  FUNC num Flag(num i, num n)
    IF i = n - 1 RETURN 2;
    IF i = 0 RETURN 0;
    RETURN 1;
  ENDFUNC

  ! The thesis's packets (Table 12): encoders (CJointT) and tool0
  ! (CRobT), read after the move is in position.
  PROC SendPose(num s, num flag, num idx)
    VAR jointtarget jt;
    VAR robtarget rt;
    VAR string h;
    jt := CJointT();
    rt := CRobT(\Tool:=tool0 \WObj:=wobj0);
    h := NumToStr(s, 0) + " ";
    SendFrame h + "j " + NumToStr(flag, 0) + " " + NumToStr(idx, 0) + " "
      + NumToStr(jt.robax.rax_1, 4) + " " + NumToStr(jt.robax.rax_2, 4) + " "
      + NumToStr(jt.robax.rax_3, 4) + " " + NumToStr(jt.robax.rax_4, 4) + " "
      + NumToStr(jt.robax.rax_5, 4) + " " + NumToStr(jt.robax.rax_6, 4);
    SendFrame h + "p " + NumToStr(flag, 0) + " " + NumToStr(idx, 0) + " "
      + NumToStr(rt.trans.x, 3) + " " + NumToStr(rt.trans.y, 3) + " "
      + NumToStr(rt.trans.z, 3) + " " + NumToStr(EulerZYX(\X, rt.rot), 4) + " "
      + NumToStr(EulerZYX(\Y, rt.rot), 4) + " " + NumToStr(EulerZYX(\Z, rt.rot), 4);
  ENDPROC

  FUNC bool InLimits(jointtarget jt)
    VAR num v{6};
    v := [jt.robax.rax_1, jt.robax.rax_2, jt.robax.rax_3,
          jt.robax.rax_4, jt.robax.rax_5, jt.robax.rax_6];
    FOR i FROM 1 TO 6 DO
      IF v{i} < J_MIN{i} OR v{i} > J_MAX{i} RETURN FALSE;
    ENDFOR
    RETURN TRUE;
  ENDFUNC

  ! vals into a jointtarget.
  FUNC jointtarget ValsJoints()
    VAR jointtarget jt;
    jt := HOME_JT;
    jt.robax := [vals{1}, vals{2}, vals{3}, vals{4}, vals{5}, vals{6}];
    RETURN jt;
  ENDFUNC

  ! vals (x y z rx ry rz) into a jointtarget by the controller's IK, in
  ! the arm configuration of `near` (the pose before it in the list):
  ! never in the one the robot happens to stand in.
  FUNC bool PoseJoints(jointtarget near, INOUT jointtarget jt)
    VAR robtarget rt;
    rt := CalcRobT(near, tool0 \WObj:=wobj0);
    rt.trans := [vals{1}, vals{2}, vals{3}];
    rt.rot := OrientZYX(vals{6}, vals{5}, vals{4});
    jt := CalcJointT(rt, tool0 \WObj:=wobj0);
    RETURN TRUE;
  ERROR
    IF ERRNO = ERR_ROBLIMIT OR ERRNO = ERR_OUTSIDE_REACH THEN
      SkipWarn;
      RETURN FALSE;
    ENDIF
  ENDFUNC

  ! One move to a stop point, in position before anything is read.
  ! A motion error leaves the controller in FAULT (ERR 21 for the
  ! request) until a move succeeds.
  FUNC bool MoveTo(jointtarget jt)
    state := "MOVING";
    MoveAbsJ jt, MOVE_SPEED, fine \Inpos:=inpos50, tool0;
    state := "IDLE";
    RETURN TRUE;
  ERROR
    IF ERRNO = ERR_COLL_STOP OR ERRNO = ERR_ROBLIMIT OR ERRNO = ERR_PATH_STOP THEN
      state := "FAULT";
      RETURN FALSE;
    ENDIF
  ENDFUNC

  PROC Dispatch()
    VAR num n;
    VAR bool counted := TRUE;
    TEST tok{2}
    CASE "HELO":
      IF NOT IntIn(tok{3}, 0, 999, n) OR ntok <> 3 THEN
        SendErr seq, 12, "bad arguments";
        counted := FALSE;
      ELSEIF n <> 1 THEN
        SendErr seq, 15, "version";
      ELSE
        SendFrame NumToStr(seq, 0) + " ACK HELO 1";
      ENDIF
    CASE "STAT":
      IF ntok = 2 THEN
        SendStat seq;
      ELSE
        SendErr seq, 23, "controller-side verb";
      ENDIF
      counted := FALSE;
    CASE "LOAD":
      DoLoad;
    CASE "RUN":
      DoRun;
    CASE "MOVJ":
      IF NOT TokSix(3, 3600, 3600) THEN
        SendErr seq, 12, "bad arguments";
        counted := FALSE;
      ELSE
        DoMove seq, "MOVJ", ValsJoints();
      ENDIF
    CASE "HOME":
      IF ntok <> 2 THEN
        SendErr seq, 12, "bad arguments";
        counted := FALSE;
      ELSE
        DoMove seq, "HOME", HOME_JT;
      ENDIF
    CASE "ZERO":
      DoZero;
    CASE "ABRT":
      SendAck seq, "ABRT";
    CASE "BYE":
      SendAck seq, "BYE";
      DropClient;
    CASE "GO":
      IF ntok = 3 AND IntIn(tok{3}, 0, MAX_LIST - 1, n) THEN
        SendErr seq, 13, "no step waiting";
      ELSE
        SendErr seq, 12, "bad arguments";
      ENDIF
      counted := FALSE;
    CASE "j", "p":
      SendErr seq, 13, "data packet outside LOAD";
      counted := FALSE;
    CASE "ACK", "ERR", "WAIT", "DONE":
      SendErr seq, 23, "controller-side verb";
    DEFAULT:
      SendErr seq, 11, "unknown verb";
      counted := FALSE;
    ENDTEST
    IF counted last_seq := seq;
  ENDPROC

  PROC SendStat(num s)
    SendFrame NumToStr(s, 0) + " STAT " + state + " " + mode + " " + cur_list + " "
      + NumToStr(cur_idx, 0) + " " + NumToStr(cur_count, 0) + " " + NumToStr(last_seq, 0);
  ENDPROC

  PROC DoLoad()
    VAR num n;
    VAR num load_seq;
    VAR num v;
    VAR string lst;
    VAR num bad_code := 0;
    VAR string bad_text := "";
    VAR jointtarget jt;
    VAR jointtarget near;
    load_seq := seq;
    lst := tok{3};
    IF ntok <> 4 OR (lst <> "CAL" AND lst <> "PERF") OR NOT IsInt(tok{4}) THEN
      SendErr load_seq, 12, "bad arguments";
      RETURN;
    ENDIF
    IF StrLen(tok{4}) > 3 THEN
      SendErr load_seq, 14, "list too long";
      RETURN;
    ENDIF
    ok := StrToVal(tok{4}, n);
    IF n > MAX_LIST THEN
      SendErr load_seq, 14, "list too long";
      RETURN;
    ENDIF
    IF n < 1 THEN
      SendErr load_seq, 12, "a list holds 1 to 200 poses";
      RETURN;
    ENDIF
    near := HOME_JT;
    FOR k FROM 0 TO n - 1 DO
      have_req := FALSE;
      ReceiveRequest;
      IF NOT have_req RETURN;
      IF tok{2} <> "j" AND tok{2} <> "p" THEN
        ! Any other request mid-LOAD: refused, the partial list
        ! discarded, nothing run and nothing moved.
        SendErr seq, 13, "LOAD incomplete";
        SendErr load_seq, 13, "LOAD discarded";
        RETURN;
      ENDIF
      IF bad_code <> 0 THEN
        ! the list is refused already: the rest is read, not used
      ELSEIF seq <> load_seq OR ntok <> 10 OR tok{3} <> NumToStr(Flag(k, n), 0)
          OR tok{4} <> NumToStr(k, 0) THEN
        bad_code := 12;
        bad_text := "packet " + NumToStr(k, 0) + " out of order";
      ELSEIF tok{2} = "j" AND NOT TokSix(5, 3600, 3600) THEN
        bad_code := 12;
        bad_text := "packet " + NumToStr(k, 0) + " bad values";
      ELSEIF tok{2} = "p" AND NOT TokSix(5, 100000, 360) THEN
        bad_code := 12;
        bad_text := "packet " + NumToStr(k, 0) + " bad values";
      ELSE
        IF tok{2} = "j" THEN
          jt := ValsJoints();
          ok := TRUE;
        ELSE
          ok := PoseJoints(near, jt);
        ENDIF
        IF NOT ok THEN
          bad_code := 20;
          bad_text := "pose " + NumToStr(k, 0) + " unreachable";
        ELSEIF NOT InLimits(jt) THEN
          bad_code := 20;
          bad_text := "pose " + NumToStr(k, 0) + " outside joint limits";
        ELSE
          load_buf{k + 1} := jt;
          near := jt;
        ENDIF
      ENDIF
    ENDFOR
    IF bad_code <> 0 THEN
      SendErr load_seq, bad_code, bad_text;
      RETURN;
    ENDIF
    FOR k FROM 1 TO n DO
      IF lst = "CAL" THEN
        cal_list{k} := load_buf{k};
      ELSE
        perf_list{k} := load_buf{k};
      ENDIF
    ENDFOR
    IF lst = "CAL" cal_count := n;
    IF lst = "PERF" perf_count := n;
    SendAck load_seq, "LOAD";
  ENDPROC

  ! A request while a list runs or waits: STAT answered, ABRT ends it
  ! (FALSE), anything else refused.
  FUNC bool DuringRun(num run_seq, string busy)
    IF tok{2} = "ABRT" AND ntok = 2 THEN
      SendErr run_seq, 22, "aborted";
      SendAck seq, "ABRT";
      state := "IDLE";
      RETURN FALSE;
    ELSEIF tok{2} = "STAT" AND ntok = 2 THEN
      SendStat seq;
    ELSE
      SendErr seq, 13, busy;
    ENDIF
    RETURN TRUE;
  ENDFUNC

  ! Requests that arrived during the move.
  FUNC bool BetweenMoves(num run_seq)
    WHILE SocketPeek(conn{owner}) >= FRAME_LEN DO
      have_req := FALSE;
      ReceiveRequest;
      IF NOT have_req RETURN FALSE;
      IF NOT DuringRun(run_seq, "a run is active") RETURN FALSE;
    ENDWHILE
    RETURN TRUE;
  ENDFUNC

  ! The go-ahead for pose idx (STEP, and ZERO's operator). The client's
  ! STAT keep-alive holds the link while the operator decides.
  FUNC bool AwaitGo(num run_seq, num idx)
    WHILE TRUE DO
      have_req := FALSE;
      ReceiveRequest;
      IF NOT have_req RETURN FALSE;
      IF tok{2} = "GO" AND ntok = 3 AND tok{3} = NumToStr(idx, 0) RETURN TRUE;
      IF NOT DuringRun(run_seq, "waiting for GO " + NumToStr(idx, 0)) RETURN FALSE;
    ENDWHILE
  ENDFUNC

  FUNC bool WaitGo(num run_seq, num idx)
    state := "WAITING";
    SendFrame NumToStr(run_seq, 0) + " WAIT " + NumToStr(idx, 0);
    RETURN AwaitGo(run_seq, idx);
  ENDFUNC

  PROC DoRun()
    VAR num run_seq;
    VAR num n := 0;
    VAR jointtarget jt;
    run_seq := seq;
    IF ntok <> 4 OR (tok{3} <> "CAL" AND tok{3} <> "PERF")
        OR (tok{4} <> "AUTO" AND tok{4} <> "STEP") THEN
      SendErr run_seq, 12, "bad arguments";
      RETURN;
    ENDIF
    IF tok{3} = "CAL" n := cal_count;
    IF tok{3} = "PERF" n := perf_count;
    IF n = 0 THEN
      SendErr run_seq, 13, "no " + tok{3} + " list loaded";
      RETURN;
    ENDIF
    mode := tok{4};
    cur_list := tok{3};
    cur_count := n;
    cur_idx := 0;
    SendAck run_seq, "RUN";
    FOR i FROM 0 TO n - 1 DO
      IF NOT BetweenMoves(run_seq) THEN
        IF state <> "FAULT" state := "IDLE";
        RETURN;
      ENDIF
      IF mode = "STEP" THEN
        IF NOT WaitGo(run_seq, i) RETURN;
      ENDIF
      IF cur_list = "CAL" THEN
        jt := cal_list{i + 1};
      ELSE
        jt := perf_list{i + 1};
      ENDIF
      IF NOT MoveTo(jt) THEN
        SendErr run_seq, 21, "motion error at pose " + NumToStr(i, 0);
        RETURN;
      ENDIF
      SendPose run_seq, Flag(i, n), i;
      cur_idx := i + 1;
    ENDFOR
    SendDone run_seq, "RUN";
  ENDPROC

  PROC DoMove(num s, string verb, jointtarget jt)
    IF NOT InLimits(jt) THEN
      SendErr s, 20, "target outside joint limits";
      RETURN;
    ENDIF
    SendAck s, verb;
    IF NOT MoveTo(jt) THEN
      SendErr s, 21, "motion error";
      RETURN;
    ENDIF
    SendPose s, 2, 0;
    SendDone s, verb;
  ENDPROC

  ! Correction (thesis 4.5): move there, WAIT 0 for the operator's
  ! go-ahead (GO 0). RAPID cannot write calibration offsets or
  ! revolution counters: the FlexPendant then shows the offsets, the
  ! operator enters them and presses Done; only then DONE ZERO. Cancel
  ! on the pendant or ABRT: ERR 22, nothing reported done.
  PROC DoZero()
    VAR num zero_seq;
    VAR jointtarget jt;
    VAR num key;
    VAR errnum fk_err;
    zero_seq := seq;
    IF NOT TokSix(3, 3600, 3600) THEN
      SendErr zero_seq, 12, "bad arguments";
      RETURN;
    ENDIF
    jt := ValsJoints();
    IF NOT InLimits(jt) THEN
      SendErr zero_seq, 20, "target outside joint limits";
      RETURN;
    ENDIF
    SendAck zero_seq, "ZERO";
    IF NOT MoveTo(jt) THEN
      SendErr zero_seq, 21, "motion error";
      RETURN;
    ENDIF
    IF NOT WaitGo(zero_seq, 0) RETURN;
    TPErase;
    TPWrite "ZERO: make these joint readings the new zero";
    TPWrite "j1..j6 " + NumToStr(jt.robax.rax_1, 4) + " " + NumToStr(jt.robax.rax_2, 4)
      + " " + NumToStr(jt.robax.rax_3, 4) + " " + NumToStr(jt.robax.rax_4, 4) + " "
      + NumToStr(jt.robax.rax_5, 4) + " " + NumToStr(jt.robax.rax_6, 4);
    TPWrite "Calibration: update the offsets, then press Done.";
    ClkReset idle_clk;
    ClkStart idle_clk;
    key := 0;
    WHILE key <> 1 DO
      TPReadFK key, "Offsets entered?", "Done", stEmpty, stEmpty, stEmpty, "Cancel"
        \MaxTime:=POLL_S \BreakFlag:=fk_err;
      IF fk_err = 0 AND key = 5 THEN
        TPErase;
        SendErr zero_seq, 22, "ZERO cancelled on the FlexPendant";
        state := "IDLE";
        RETURN;
      ENDIF
      IF SocketPeek(conn{owner}) >= FRAME_LEN THEN
        have_req := FALSE;
        ReceiveRequest;
        IF NOT have_req OR NOT DuringRun(zero_seq, "waiting for the FlexPendant") THEN
          TPErase;
          RETURN;
        ENDIF
        ClkReset idle_clk;
        ClkStart idle_clk;
      ENDIF
      IF ClkRead(idle_clk) >= IDLE_S THEN
        TPErase;
        DropClient;
        RETURN;
      ENDIF
    ENDWHILE
    TPErase;
    state := "IDLE";
    SendDone zero_seq, "ZERO";
  ENDPROC
ENDMODULE
