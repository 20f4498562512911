MODULE Welding
  ! A motion module: robtarget arrays, values over several lines, tools and
  ! work objects, joint targets, searching and triggering.
  PERS tooldata tTorch:=[TRUE,[[10.5,0,350],[0.9659258,0,0.258819,0]],
                         [2.5,[0,0,120],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wFixture:=[FALSE,TRUE,"",[[1000,-200,500],[1,0,0,0]],
                                [[0,0,0],[1,0,0,0]]];
  CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pSeam{2,2}:=[
    [[[10,0,5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],
     [[110,0,5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]],
    ! the second seam
    [[[10,80,5],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]],
     [[110,80,5],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]]]];
  LOCAL CONST robtarget pApproach:=[[60,40,100],[0,0.7071068,0.7071068,0],[0,-1,0,1],
                                    [9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  VAR robtarget pFound;
  VAR triggdata arcOn;
  CONST speeddata vWeld:=[12,500,5000,1000];
  CONST zonedata zSmall:=[FALSE,0.3,0.3,0.3,0.03,0.3,0.03];

  PROC main()
    MoveAbsJ jHome, v1000, fine, tool0;
    ConfL \Off;
    FOR seam FROM 1 TO 2 DO
      WeldSeam seam;
    ENDFOR
    FOR k FROM 10 TO 0 STEP -2 DO
      WaitTime 0.01 * k;
    ENDFOR
    MoveAbsJ jHome \NoEOffs, v1000, fine, tool0;
  ENDPROC

  PROC WeldSeam(num seam)
    MoveJ pApproach, v500, z20, tTorch \WObj:=wFixture;
    SearchL \Stop, diTouch, pFound, Offs(pSeam{seam, 1}, 0, 0, -10), v20, tTorch \WObj:=wFixture;
    TriggIO arcOn, 0 \Start \DOp:=doArc, 1;
    TriggL pSeam{seam, 1}, vWeld, arcOn, fine, tTorch \WObj:=wFixture;
    MoveL pSeam{seam, 2}, vWeld \V:=15, zSmall, tTorch \WObj:=wFixture;
    MoveC RelTool(pSeam{seam, 2}, 0, 10, 0 \Rz:=5), pSeam{seam, 1}, vWeld, fine, tTorch
      \WObj:=wFixture;
    MoveL Offs(pSeam{seam, 1}, 0, 0, 50), v200, z10, tTorch \WObj:=wFixture;
  ERROR
    IF ERRNO = ERR_WHLSEARCH THEN
      TPWrite "no seam found at seam " \Num:=seam;
      RETURN;
    ENDIF
  ENDPROC

  FUNC bool Near(robtarget a, robtarget b, \num Limit)
    VAR num d;
    d := Distance(a.trans, b.trans);
    IF Present(Limit) THEN
      RETURN d < Limit;
    ENDIF
    RETURN d < 1;
  ENDFUNC

  PROC Shift(INOUT robtarget p, PERS tooldata t, VAR num offsets{*})
    p := Offs(p, offsets{1}, offsets{2}, offsets{3});
    p.trans.z := p.trans.z + t.tframe.trans.z / 100;
  ENDPROC
ENDMODULE
