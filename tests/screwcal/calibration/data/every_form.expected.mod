MODULE EveryForm
    ! Every robtarget declaration form a RAPID module may hold.
    CONST robtarget pHome:=[[895.4875,-29.0017,946.6778],[0.068462229,0.056553267,0.995868500,0.018988985],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PERS robtarget pPers := [[856.9419, -149.6833, 745.1189], [0.061756418, 0.438710733, 0.895829424, 0.034766074],
        [-1, 0, 0, 0], [9E+09, 9E+09, 9E+09, 9E+09, 9E+09, 9E+09]];
    VAR robtarget pVar:=[[817.9136,75.3895,693.1301],[0.065775963,0.064187521,0.995428312,0.025999247],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    LOCAL CONST robtarget pLocal:=[[781.1472,-75.2872,864.4889],[0.069532266,0.059541713,0.995696187,0.014462041],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    TASK PERS robtarget pTask:=[[769.1587,35.9438,803.7231],[0.066797651,0.061300719,0.995594764,0.023903179],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pArr{2}:=[[[704.3168,-22.3820,842.8346],[0.068466476,0.060105138,0.995663701,0.018801846],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        ! a comment between the elements
        [[726.8059,7.0879,823.0881],[0.067631449,0.060732245,0.995627542,0.021526251],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]];
    CONST robtarget pTool:=[[848.3024,-22.4480,646.3157],[0.068472150,0.061387519,0.995589759,0.018551793],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pWobj:=[[116.5109,22.2210,242.0053],[0.069434771,0.065519840,0.995351491,0.012703263],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pTwice:=[[830,0,650],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pStationary:=[[840,0,640],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pMoving:=[[10,0,40],[0,0,1,0],[0,0,0,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    VAR robtarget pRuntime;
    PERS tooldata tGun:=[TRUE,[[0,0,150],[1,0,0,0]],[2,[0,0,80],[1,0,0,0],0,0,0]];
    PERS tooldata tFixed:=[FALSE,[[900,0,500],[1,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]];
    TASK PERS wobjdata wTable:=[FALSE,TRUE,"",[[700,-100,400],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
    TASK PERS wobjdata wConveyor:=[FALSE,FALSE,"CNV1",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];

    PROC main()
        MoveJ pHome, v1000, z50, tool0;
        MoveL pPers, v500, fine, tool0;
        MoveL pVar, v500 \V:=600, z10, tool0 \WObj:=wobj0;
        MoveJ pLocal, v500, z10, tool0;
        MoveC pTask, pArr{1}, v200, z10, tool0;
        MoveL pArr{2}, v200, fine, tool0;
        MoveL pTool, v200, fine, tGun;
        MoveL pWobj, v200, fine, tool0 \WObj:=wTable;
        MoveL pTwice, v200, fine, tool0;
        MoveL pTwice, v200, fine, tGun;
        MoveL pStationary, v200, fine, tFixed;
        MoveL pMoving, v200, fine, tool0 \WObj:=wConveyor;
        MoveL Offs(pHome, 0, 0, 50), v200, fine, tool0;
        MoveL RelTool(pHome, 0, 0, -20), v200, fine, tool0;
        pRuntime := CRobT(\Tool:=tool0);
        MoveL [[810,0,700],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]], v200, fine, tool0;
    ENDPROC
ENDMODULE
