MODULE CellLink
  ! A socket server in the form public PC-link modules take (written for these tests):
  ! requests "code p1 p2 ... #", replies "code ok data"; PERS tool and work object the client
  ! sets; the listening socket closed and bound again after each client (close-and-rebind);
  ! one ERROR (LONG_JMP_ALL_ERR) handler for everything.
  PERS tooldata linkTool := [TRUE,[[0,0,0],[1,0,0,0]],[0.5,[0,0,1],[1,0,0,0],0,0,0]];
  PERS wobjdata linkWobj := [FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  VAR speeddata linkSpeed := [200, 100, 0, 0];
  VAR zonedata linkZone;
  VAR socketdev listener;
  VAR socketdev peer;
  PERS string linkAddress := "127.0.0.1";
  PERS num linkPort := 5000;
  VAR num code;
  VAR num arg{10};
  VAR num nArg;
  VAR robtarget viaPoint;
  VAR num sessions := 0;
  VAR num status;

  PROC Split(string text)
    VAR num at := 1;
    VAR num next;
    VAR num stop;
    VAR bool ok;
    stop := StrMatch(text, 1, "#");
    nArg := 0;
    next := StrMatch(text, at, " ");
    ok := StrToVal(StrPart(text, at, next - at), code);
    IF NOT ok THEN
      code := -1;
      RETURN;
    ENDIF
    at := next + 1;
    more:
    next := StrMatch(text, at, " ");
    IF next >= stop RETURN;
    Incr nArg;
    ok := StrToVal(StrPart(text, at, next - at), arg{nArg});
    at := next + 1;
    GOTO more;
  ENDPROC

  PROC Serve()
    VAR string who;
    SocketCreate listener;
    SocketBind listener, linkAddress, linkPort;
    SocketListen listener;
    SocketAccept listener, peer \ClientAddress:=who \Time:=WAIT_MAX;
    Incr sessions;
  ENDPROC

  FUNC string Pose(robtarget p)
    RETURN NumToStr(p.trans.x,2) + " " + NumToStr(p.trans.y,2) + " " + NumToStr(p.trans.z,2)
      + " " + NumToStr(p.rot.q1,3) + " " + NumToStr(p.rot.q2,3) + " "
      + NumToStr(p.rot.q3,3) + " " + NumToStr(p.rot.q4,3);
  ENDFUNC

  FUNC robtarget Target()
    RETURN [[arg{1},arg{2},arg{3}],[arg{4},arg{5},arg{6},arg{7}],[0,0,0,0],
            [9E9,9E9,9E9,9E9,9E9,9E9]];
  ENDFUNC

  PROC main()
    VAR string request;
    VAR string reply;
    VAR jointtarget joints;
    VAR robtarget here;
    ConfL \Off;
    ConfJ \Off;
    SingArea \Wrist;
    linkZone := fine;
    Serve;
    WHILE TRUE DO
      SocketReceive peer \Str:=request \Time:=WAIT_MAX;
      Split request;
      reply := "";
      status := 1;
      TEST code
      CASE 1:
        MoveL Target(), linkSpeed, linkZone, linkTool \WObj:=linkWobj;
      CASE 2:
        joints := [[arg{1},arg{2},arg{3},arg{4},arg{5},arg{6}],[9E9,9E9,9E9,9E9,9E9,9E9]];
        MoveAbsJ joints, linkSpeed, linkZone, linkTool \WObj:=linkWobj;
      CASE 3:
        here := CRobT(\Tool:=linkTool \WObj:=linkWobj);
        reply := Pose(here);
      CASE 4:
        joints := CJointT();
        reply := NumToStr(joints.robax.rax_1,2) + " " + NumToStr(joints.robax.rax_2,2) + " "
          + NumToStr(joints.robax.rax_3,2) + " " + NumToStr(joints.robax.rax_4,2) + " "
          + NumToStr(joints.robax.rax_5,2) + " " + NumToStr(joints.robax.rax_6,2);
      CASE 5:
        viaPoint := Target();
      CASE 6:
        MoveC viaPoint, Target(), linkSpeed, linkZone, linkTool \WObj:=linkWobj;
      CASE 7:
        linkTool.tframe := [[arg{1},arg{2},arg{3}],[arg{4},arg{5},arg{6},arg{7}]];
      CASE 8:
        linkWobj.oframe := [[arg{1},arg{2},arg{3}],[arg{4},arg{5},arg{6},arg{7}]];
      CASE 9:
        MoveJ Target(), linkSpeed, linkZone, linkTool \WObj:=linkWobj;
      CASE 99:
        SocketClose peer;
        SocketClose listener;
        Serve;
        code := -99;
      DEFAULT:
        reply := "?";
      ENDTEST
      IF code <> -99 SocketSend peer \Str:=NumToStr(code,0) + " " + NumToStr(status,0) + " "
        + reply;
    ENDWHILE
  ERROR (LONG_JMP_ALL_ERR)
    IF ERRNO = ERR_SOCK_CLOSED THEN
      SocketClose peer;
      SocketClose listener;
      Serve;
      RETRY;
    ENDIF
    IF ERRNO = ERR_ROBLIMIT OR ERRNO = ERR_OUTSIDE_REACH OR ERRNO = ERR_ARGVALERR THEN
      status := 0;
      reply := NumToStr(ERRNO,0);
      TRYNEXT;
    ENDIF
  ENDPROC
ENDMODULE
