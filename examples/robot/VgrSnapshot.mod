MODULE VgrSnapshot
  ! ABB RAPID, eye-in-hand: the camera is on the flange. At the snapshot pose the robot
  ! sends its flange pose with the request, "TRIG,<job>,[[x,y,z],[q1,q2,q3,q4]]#" (abb
  ! dialect, port 50011): ValToStr of a pose, mm and the orient quaternion, the frame the
  ! hand-eye calibration's robot poses were given in (tool0 in wobj0: the flange in the
  ! base frame). vgrd maps the image with T_base_flange * X and answers like VgrPick.mod:
  ! "<status>,<cycle>,<x>,<y>,<z>,<rz>,<ry>,<rx>" (at most 80 characters, no terminator).
  ! Three SocketSends make one request: vgrd reads up to the '#'.
  VAR socketdev sock;
  VAR string reply;
  VAR num vals{8};
  PERS tooldata tGripper := [TRUE, [[0,0,150],[1,0,0,0]], [1,[0,0,50],[1,0,0,0],0,0,0]];
  CONST robtarget pSnap := [[400,0,450],[0,1,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];

  PROC main()
    VAR robtarget pPart;
    VAR robtarget pNow;
    VAR pose flange;
    SocketCreate sock;
    SocketConnect sock, "192.168.1.10", 50011;
    WHILE TRUE DO
      MoveJ pSnap, v1000, fine, tool0 \WObj:=wobj0;
      WaitTime 0.2;
      pNow := CRobT(\Tool:=tool0 \WObj:=wobj0);
      flange := [pNow.trans, pNow.rot];
      SocketSend sock \Str:="TRIG,1,";
      SocketSend sock \Str:=ValToStr(flange);
      SocketSend sock \Str:="#";
      SocketReceive sock \Str:=reply \Time:=5;
      IF ParseReply(reply) AND vals{1} = 0 THEN
        pPart := [[vals{3}, vals{4}, vals{5}], OrientZYX(vals{6}, vals{7}, vals{8}),
                  [0,0,0,0], [9E9,9E9,9E9,9E9,9E9,9E9]];
        MoveJ Offs(pPart, 0, 0, 100), v1000, z50, tGripper \WObj:=wobj0;
        MoveL pPart, v200, fine, tGripper \WObj:=wobj0;
        ! close the gripper here
        MoveL Offs(pPart, 0, 0, 100), v1000, z50, tGripper \WObj:=wobj0;
      ELSE
        TPWrite "vgr status " \Num:=vals{1};
        WaitTime 0.5;
      ENDIF
    ENDWHILE
  ERROR
    IF ERRNO = ERR_SOCK_TIMEOUT THEN
      RETRY;
    ENDIF
  ENDPROC

  ! Splits the comma-separated reply into vals{1..8} with StrToVal.
  FUNC bool ParseReply(string s)
    VAR num start := 1;
    VAR num comma;
    FOR i FROM 1 TO 8 DO
      comma := StrFind(s, start, ",");
      IF NOT StrToVal(StrPart(s, start, comma - start), vals{i}) RETURN FALSE;
      start := comma + 1;
    ENDFOR
    RETURN TRUE;
  ENDFUNC
ENDMODULE
