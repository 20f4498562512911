MODULE EveryForm
    ! Every robtarget declaration form a RAPID module may hold.
    CONST robtarget pHome:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PERS robtarget pPers := [[850.5, -120.25, 700], [0, 0.3826834, 0.9238795, 0],
        [-1, 0, 0, 0], [9E+09, 9E+09, 9E+09, 9E+09, 9E+09, 9E+09]];
    VAR robtarget pVar:=[[800,100,650],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
    LOCAL CONST robtarget pLocal:=[[780,-50,820],[0,0,1,0],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    TASK PERS robtarget pTask:=[[760,60,760],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pArr{2}:=[[[700,0,800],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        ! a comment between the elements
        [[720,30,780],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]];
    CONST robtarget pTool:=[[820,0,600],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pWobj:=[[100,50,200],[0,0,1,0],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
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
