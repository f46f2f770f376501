MODULE VgrPick
  ! ABB RAPID: ask vgrd for the next part (abb dialect, port 50011).
  ! Request "GET,<job>#"; reply "<status>,<cycle>,<x>,<y>,<z>,<rz>,<ry>,<rx>" in mm and
  ! Z-Y-X Euler degrees (OrientZYX order), 3 decimals, never longer than 80 characters, so
  ! one SocketReceive \Str gets all of it. No terminator follows the reply.
  ! Status 0 = OK, 1 = no part, 2 = not ready, 3 = no new trigger, < 0 = error.
  VAR socketdev sock;
  VAR string reply;
  VAR num vals{8};
  PERS tooldata tGripper := [TRUE, [[0,0,150],[1,0,0,0]], [1,[0,0,50],[1,0,0,0],0,0,0]];
  PERS wobjdata wConveyor := [FALSE, TRUE, "", [[0,0,0],[1,0,0,0]], [[0,0,0],[1,0,0,0]]];

  PROC main()
    VAR robtarget pPart;
    SocketCreate sock;
    SocketConnect sock, "192.168.1.10", 50011;
    WHILE TRUE DO
      SocketSend sock \Str:="GET,1#";
      SocketReceive sock \Str:=reply \Time:=5;
      IF ParseReply(reply) AND vals{1} = 0 THEN
        pPart := [[vals{3}, vals{4}, vals{5}], OrientZYX(vals{6}, vals{7}, vals{8}),
                  [0,0,0,0], [9E9,9E9,9E9,9E9,9E9,9E9]];
        MoveJ Offs(pPart, 0, 0, 100), v1000, z50, tGripper \WObj:=wConveyor;
        MoveL pPart, v200, fine, tGripper \WObj:=wConveyor;
        ! close the gripper here
        MoveL Offs(pPart, 0, 0, 100), v1000, z50, tGripper \WObj:=wConveyor;
      ELSEIF vals{1} < 0 THEN
        TPWrite "vgr error " \Num:=vals{1};
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
