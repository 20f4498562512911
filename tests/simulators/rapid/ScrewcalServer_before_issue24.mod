MODULE ScrewcalServer
  !*********************************************************************
  ! screwcal wire protocol v1 server for an ABB IRC5 (RobotWare 6,
  ! option "PC Interface"). The controller is the server, the PC the
  ! client (thesis 4.4, Algorithms 1 and 2). Every frame is 80 chars:
  ! payload, "#", spaces. A socket time-out or close drops the client,
  ! listens again and goes on; a request is never executed twice.
  ! One client owns the controller: a newcomer gets "0 ERR 16 busy" and
  ! is closed; an owner silent for IDLE_S (STAT counts) is dropped.
  ! Joint limits below are the IRB 1600's: adapt them to the robot.
  !*********************************************************************
  CONST num PORT := 4012;
  CONST num FRAME_LEN := 80;
  CONST num MAX_LIST := 200;
  CONST num IDLE_S := 60;
  CONST num POLL_S := 0.1;
  CONST num J_MIN{6} := [-180,-90,-245,-200,-115,-400];
  CONST num J_MAX{6} := [180,150,65,200,115,400];
  CONST speeddata MOVE_SPEED := v100;

  VAR socketdev server_socket;
  VAR socketdev client_socket;
  VAR socketdev busy_socket;
  VAR string client_ip;
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
  VAR string tok{10};
  VAR num ntok := 0;
  VAR num seq := 0;
  VAR bool have_req := FALSE;
  VAR bool ok := FALSE;

  PROC main()
    Listen;
    WHILE TRUE DO
      have_req := FALSE;
      ReceiveRequest;
      IF have_req THEN
        Dispatch;
      ENDIF
    ENDWHILE
  ERROR
    IF ERRNO = ERR_SOCK_TIMEOUT OR ERRNO = ERR_SOCK_CLOSED THEN
      ! Drop the client, listen again; TRYNEXT never repeats a motion.
      Relisten;
      TRYNEXT;
    ENDIF
  ENDPROC

  PROC Listen()
    SocketCreate server_socket;
    SocketBind server_socket, GetSysInfo(\LanIp), PORT;
    SocketListen server_socket;
    SocketAccept server_socket, client_socket \ClientAddress:=client_ip \Time:=WAIT_MAX;
  ENDPROC

  PROC Relisten()
    SocketClose client_socket;
    SocketClose server_socket;
    IF state = "MOVING" OR state = "WAITING" state := "IDLE";
    Listen;
  ENDPROC

  ! The one place that reads the client: one 80-char frame -> payload
  ! and tokens. Until a whole frame is there, a newcomer is told busy
  ! and an owner silent for IDLE_S is dropped (half a frame is silence).
  ! A bad frame drops the link.
  PROC ReceiveRequest()
    VAR num hash;
    VAR num quiet := 0;
    WHILE SocketPeek(client_socket) < FRAME_LEN DO
      RefuseNewcomer;
      quiet := quiet + POLL_S;
      IF quiet >= IDLE_S THEN
        Relisten;
        RETURN;
      ENDIF
    ENDWHILE
    SocketReceive client_socket \Str:=frm \ReadNoOfBytes:=FRAME_LEN \Time:=1;
    hash := StrFind(frm, 1, "#");
    IF hash <= 1 OR hash > StrLen(frm) THEN
      Relisten;
      RETURN;
    ENDIF
    payload := StrPart(frm, 1, hash - 1);
    Tokenize;
    ok := StrToVal(tok{1}, seq);
    IF NOT ok OR ntok < 2 THEN
      Relisten;
      RETURN;
    ENDIF
    have_req := TRUE;
  ENDPROC

  ! Another client while one owns the controller: told busy, closed.
  ! Waits at most POLL_S for one.
  PROC RefuseNewcomer()
    SocketAccept server_socket, busy_socket \Time:=POLL_S;
    SendTo busy_socket, "0 ERR 16 busy";
    SocketClose busy_socket;
  ERROR
    IF ERRNO = ERR_SOCK_TIMEOUT THEN
      RETURN;
    ENDIF
    SocketClose busy_socket;
    RETURN;
  ENDPROC

  ! Every request's tokens start empty: nothing of an earlier one is
  ! ever read as this one's.
  PROC Tokenize()
    VAR num start := 1;
    VAR num sp;
    FOR i FROM 1 TO 10 DO
      tok{i} := "";
    ENDFOR
    ntok := 0;
    WHILE start <= StrLen(payload) AND ntok < 10 DO
      sp := StrFind(payload, start, " ");
      Incr ntok;
      tok{ntok} := StrPart(payload, start, sp - start);
      start := sp + 1;
    ENDWHILE
  ENDPROC

  PROC SendFrame(string p)
    SendTo client_socket, p;
  ENDPROC

  ! Every frame goes out here: payload, "#", spaces up to 80 chars.
  PROC SendTo(VAR socketdev sock, string p)
    VAR string f;
    IF StrLen(p) > FRAME_LEN - 1 THEN
      f := NumToStr(seq, 0) + " ERR 12 reply too long#";
    ELSE
      f := p + "#";
    ENDIF
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

  ! The thesis's packets (Table 12): encoders (CJointT) and tool0 (CRobT).
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

  ! Six numbers from tok{first..first+5} into a jointtarget.
  FUNC bool TokJoints(num first, INOUT jointtarget jt)
    VAR num v{6};
    FOR i FROM 1 TO 6 DO
      IF NOT StrToVal(tok{first + i - 1}, v{i}) RETURN FALSE;
    ENDFOR
    jt := CJointT();
    jt.robax := [v{1}, v{2}, v{3}, v{4}, v{5}, v{6}];
    RETURN TRUE;
  ENDFUNC

  ! Six numbers x y z rx ry rz into a jointtarget by the controller's IK.
  FUNC bool TokPose(num first, INOUT jointtarget jt)
    VAR num v{6};
    VAR robtarget rt;
    FOR i FROM 1 TO 6 DO
      IF NOT StrToVal(tok{first + i - 1}, v{i}) RETURN FALSE;
    ENDFOR
    rt := CRobT(\Tool:=tool0 \WObj:=wobj0);
    rt.trans := [v{1}, v{2}, v{3}];
    rt.rot := OrientZYX(v{6}, v{5}, v{4});
    jt := CalcJointT(rt, tool0 \WObj:=wobj0);
    RETURN TRUE;
  ERROR
    IF ERRNO = ERR_ROBLIMIT OR ERRNO = ERR_OUTSIDE_REACH THEN
      RETURN FALSE;
    ENDIF
  ENDFUNC

  PROC Dispatch()
    VAR jointtarget jt;
    TEST tok{2}
    CASE "HELO":
      IF ntok = 3 AND tok{3} = "1" THEN
        SendFrame NumToStr(seq, 0) + " ACK HELO 1";
      ELSE
        SendErr seq, 15, "version";
      ENDIF
    CASE "STAT":
      SendStat seq;
    CASE "LOAD":
      DoLoad;
    CASE "RUN":
      DoRun;
    CASE "MOVJ":
      IF ntok <> 8 OR NOT TokJoints(3, jt) THEN
        SendErr seq, 12, "bad arguments";
      ELSE
        DoMove seq, "MOVJ", jt;
      ENDIF
    CASE "HOME":
      jt := CJointT();
      jt.robax := [0, 0, 0, 0, 0, 0];
      DoMove seq, "HOME", jt;
    CASE "ZERO":
      DoZero;
    CASE "ABRT":
      SendAck seq, "ABRT";
    CASE "BYE":
      SendAck seq, "BYE";
      Relisten;
    CASE "GO":
      SendErr seq, 13, "no step waiting";
    DEFAULT:
      SendErr seq, 11, "unknown verb";
    ENDTEST
    IF tok{2} <> "STAT" AND tok{2} <> "GO" last_seq := seq;
  ENDPROC

  PROC SendStat(num s)
    SendFrame NumToStr(s, 0) + " STAT " + state + " " + mode + " " + cur_list + " "
      + NumToStr(cur_idx, 0) + " " + NumToStr(cur_count, 0) + " " + NumToStr(last_seq, 0);
  ENDPROC

  PROC DoLoad()
    VAR num n;
    VAR num load_seq;
    VAR string lst;
    VAR num bad_code := 0;
    VAR string bad_text := "";
    VAR jointtarget jt;
    load_seq := seq;
    lst := tok{3};
    ok := StrToVal(tok{4}, n);
    IF ntok <> 4 OR NOT ok OR (lst <> "CAL" AND lst <> "PERF") THEN
      SendErr load_seq, 12, "bad arguments";
      RETURN;
    ENDIF
    IF n > MAX_LIST THEN
      SendErr load_seq, 14, "list too long";
      RETURN;
    ENDIF
    IF n < 1 OR n <> Trunc(n) THEN
      SendErr load_seq, 12, "a list holds 1 to 200 poses";
      RETURN;
    ENDIF
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
      IF seq <> load_seq OR ntok <> 10 OR tok{3} <> NumToStr(Flag(k, n), 0)
          OR tok{4} <> NumToStr(k, 0) THEN
        bad_code := 12;
        bad_text := "packet out of order";
      ELSEIF tok{2} = "j" AND TokJoints(5, jt) THEN
        load_buf{k + 1} := jt;
      ELSEIF tok{2} = "p" AND TokPose(5, jt) THEN
        load_buf{k + 1} := jt;
      ELSE
        bad_code := 20;
        bad_text := "pose " + NumToStr(k, 0) + " unreachable";
      ENDIF
      IF bad_code = 0 AND NOT InLimits(load_buf{k + 1}) THEN
        bad_code := 20;
        bad_text := "pose " + NumToStr(k, 0) + " outside joint limits";
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

  ! Requests that arrived during the move: STAT answered, ABRT stops.
  FUNC bool BetweenMoves(num run_seq)
    WHILE SocketPeek(client_socket) >= FRAME_LEN DO
      have_req := FALSE;
      ReceiveRequest;
      IF NOT have_req RETURN FALSE;
      IF tok{2} = "ABRT" THEN
        SendErr run_seq, 22, "aborted";
        SendAck seq, "ABRT";
        RETURN FALSE;
      ELSEIF tok{2} = "STAT" THEN
        SendStat seq;
      ELSE
        SendErr seq, 13, "a run is active";
      ENDIF
    ENDWHILE
    RETURN TRUE;
  ENDFUNC

  ! STEP mode: the operator's go-ahead (thesis: manual mode). The
  ! client's STAT keep-alive holds the link while the operator decides.
  FUNC bool WaitGo(num run_seq, num idx)
    state := "WAITING";
    SendFrame NumToStr(run_seq, 0) + " WAIT " + NumToStr(idx, 0);
    WHILE TRUE DO
      have_req := FALSE;
      ReceiveRequest;
      IF NOT have_req RETURN FALSE;
      IF tok{2} = "GO" AND tok{3} = NumToStr(idx, 0) RETURN TRUE;
      IF tok{2} = "ABRT" THEN
        SendErr run_seq, 22, "aborted";
        SendAck seq, "ABRT";
        state := "IDLE";
        RETURN FALSE;
      ELSEIF tok{2} = "STAT" THEN
        SendStat seq;
      ELSE
        SendErr seq, 13, "waiting for GO";
      ENDIF
    ENDWHILE
  ENDFUNC

  PROC DoRun()
    VAR num run_seq;
    VAR num n;
    run_seq := seq;
    IF tok{3} = "CAL" n := cal_count;
    IF tok{3} = "PERF" n := perf_count;
    IF n = 0 THEN
      SendErr run_seq, 13, "no list loaded";
      RETURN;
    ENDIF
    mode := tok{4};
    cur_list := tok{3};
    cur_count := n;
    cur_idx := 0;
    SendAck run_seq, "RUN";
    FOR i FROM 0 TO n - 1 DO
      IF NOT BetweenMoves(run_seq) THEN
        state := "IDLE";
        RETURN;
      ENDIF
      IF mode = "STEP" THEN
        IF NOT WaitGo(run_seq, i) RETURN;
      ENDIF
      state := "MOVING";
      IF cur_list = "CAL" THEN
        MoveAbsJ cal_list{i + 1}, MOVE_SPEED, fine, tool0;
      ELSE
        MoveAbsJ perf_list{i + 1}, MOVE_SPEED, fine, tool0;
      ENDIF
      state := "IDLE";
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
    state := "MOVING";
    MoveAbsJ jt, MOVE_SPEED, fine, tool0;
    state := "IDLE";
    SendPose s, 2, 0;
    SendDone s, verb;
  ENDPROC

  ! Correction (thesis 4.5): move there, wait while the operator updates
  ! the revolution counters / calibration offsets, GO 0 continues.
  PROC DoZero()
    VAR jointtarget jt;
    VAR num zero_seq;
    zero_seq := seq;
    IF ntok <> 8 OR NOT TokJoints(3, jt) THEN
      SendErr zero_seq, 12, "bad arguments";
      RETURN;
    ENDIF
    IF NOT InLimits(jt) THEN
      SendErr zero_seq, 20, "target outside joint limits";
      RETURN;
    ENDIF
    SendAck zero_seq, "ZERO";
    state := "MOVING";
    MoveAbsJ jt, MOVE_SPEED, fine, tool0;
    IF NOT WaitGo(zero_seq, 0) RETURN;
    state := "IDLE";
    SendDone zero_seq, "ZERO";
  ENDPROC
ENDMODULE
