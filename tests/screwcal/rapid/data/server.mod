MODULE PartServer
  ! A socket server in the forms public ABB server modules use: a listening
  ! socket, raw bytes, a TRAP on a signal, error handlers that retry.
  CONST num PORT := 5000;
  CONST string GREETING := "ready";
  VAR socketdev listener;
  VAR socketdev client;
  VAR rawbytes buffer;
  VAR intnum stop_int;
  VAR num errors := 0;
  VAR bool running := TRUE;
  VAR string reply;
  LOCAL VAR num codes{3} := [1, 2, 3];
  PERS num last_code := 0;

  PROC main()
    VAR num n;
    IDelete stop_int;
    CONNECT stop_int WITH OnStop;
    ISignalDI diStop, 1, stop_int;
    SocketCreate listener;
    SocketBind listener, "127.0.0.1", PORT;
    SocketListen listener;
    SocketAccept listener, client \Time:=WAIT_MAX;
    SocketSend client \Str:=GREETING;
    WHILE running DO
      ClearRawBytes buffer;
      SocketReceive client \RawData:=buffer \ReadNoOfBytes:=4 \Time:=10;
      UnpackRawBytes buffer, 1, n \IntX:=DINT;
      Serve n;
    ENDWHILE
    SocketClose client;
  ERROR (ERR_SOCK_TIMEOUT, ERR_SOCK_CLOSED)
    IF ERRNO = ERR_SOCK_TIMEOUT THEN
      RETRY;
    ELSEIF ERRNO = ERR_SOCK_CLOSED THEN
      SocketClose client;
      SocketClose listener;
      ExitCycle;
    ELSE
      RAISE;
    ENDIF
  UNDO
    SocketClose client;
    SocketClose listener;
  ENDPROC

  PROC Serve(num code)
    TEST code
    CASE 1, 2, 3:
      last_code := code;
      reply := "OK " + NumToStr(code, 0);
    CASE 10:
      running := FALSE;
      reply := "BYE";
    DEFAULT:
      Incr errors;
      reply := "ERR";
    ENDTEST
    IF errors > 3 GOTO done;
    SocketSend client \Str:=reply;
    RETURN;
    done:
    SocketSend client \Str:="too many errors";
  ERROR
    TRYNEXT;
  ENDPROC

  FUNC num Checked(num value, \num Low | switch Positive)
    IF Present(Low) AND value < Low RETURN Low;
    IF Present(Positive) AND value < 0 RETURN 0;
    RETURN value;
  ERROR
    RETURN -1;
  ENDFUNC

  PROC Dispatch(string name)
    %"Do" + name%;
  ENDPROC

  PROC DoNothing()
  ENDPROC

  TRAP OnStop
    running := FALSE;
    TPWrite "stop requested" \Num:=errors;
  ENDTRAP
ENDMODULE
