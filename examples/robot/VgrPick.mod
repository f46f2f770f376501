MODULE VgrPick
  ! ABB RAPID: pick each part vgrd finds with a program displacement (abb dialect, port
  ! 50011). The endpoint in cell.yaml delivers offsets in this program's work object:
  !   robots: [{name: irb, dialect: abb, port: 50011, deliver: offset,
  !             frame: {name: wConveyor, x_mm: 400, y_mm: -200, z_mm: 0, rz_deg: 90}}]
  ! (the frame's pose is wConveyor's uframe below; docs/protocols.md, "Offsets and frames").
  ! Requests: "JOB,1#" once (status 0: this robot now works on job 1), then "GET#" (the
  ! next part of the current job). Reply "<status>,<cycle>,<x>,<y>,<z>,<rz>,<ry>,<rx>": the
  ! displacement in wConveyor that moves the job's taught reference part onto this part,
  ! mm and Z-Y-X Euler degrees (OrientZYX order), 3 decimals, at most 80 characters, so one
  ! SocketReceive \Str gets all of it; no terminator follows it.
  ! PDispSet with it displaces every target taught in wConveyor while the reference part
  ! lay there (pPick) onto the part found; Offs(pPick, 0, 0, 100) is the approach above it.
  ! Status 0 = OK, 1 = no part, 2 = not ready, 3 = no new trigger, -9 = outside the job's
  ! limits (nothing to pick: the part is not delivered), other < 0 = error.
  VAR socketdev sock;
  VAR string reply;
  VAR num vals{8};
  VAR pose disp;
  PERS tooldata tGripper := [TRUE, [[0,0,150],[1,0,0,0]], [1,[0,0,50],[1,0,0,0],0,0,0]];
  PERS wobjdata wConveyor := [FALSE, TRUE, "", [[400,-200,0],[0.70710678,0,0,0.70710678]], [[0,0,0],[1,0,0,0]]];
  ! Taught in wConveyor with the reference part (cell.yaml jobs[].reference) lying there,
  ! the gripper pointing down onto its grasp point.
  CONST robtarget pPick := [[200,0,0],[0,0.70710678,-0.70710678,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];

  PROC main()
    SocketCreate sock;
    SocketConnect sock, "192.168.1.10", 50011;
    SocketSend sock \Str:="JOB,1#";
    SocketReceive sock \Str:=reply \Time:=5;
    IF NOT ParseReply(reply) OR vals{1} <> 0 THEN
      TPWrite "vgr: JOB,1 refused";
      Stop;
    ENDIF
    WHILE TRUE DO
      SocketSend sock \Str:="GET#";
      SocketReceive sock \Str:=reply \Time:=5;
      IF ParseReply(reply) AND vals{1} = 0 THEN
        disp := [[vals{3}, vals{4}, vals{5}], OrientZYX(vals{6}, vals{7}, vals{8})];
        PDispSet disp;
        MoveJ Offs(pPick, 0, 0, 100), v1000, z50, tGripper \WObj:=wConveyor;
        MoveL pPick, v200, fine, tGripper \WObj:=wConveyor;
        ! close the gripper here
        MoveL Offs(pPick, 0, 0, 100), v1000, z50, tGripper \WObj:=wConveyor;
        PDispOff;
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
