/PROG  VGR_PICK
/ATTR
COMMENT		= "vgr pick";
DEFAULT_GROUP	= 1,*,*,*,*;
/MN
   1:  !vgrd via KAREL task VGR_BG ;
   2:  !UFRAME 1 is taught AT the ;
   3:  !reference part, so Offset,PR ;
   4:  !moves every point with the part ;
   5:  UFRAME_NUM=1 ;
   6:  UTOOL_NUM=1 ;
   7:  RUN VGR_BG ;
   8:  LBL[1] ;
   9:  !ask for the next part ;
  10:  R[12:vgr flag]=0 ;
  11:  WAIT R[12:vgr flag]=1 TIMEOUT,LBL[9] ;
  12:  !R[10] status 0 = part found ;
  13:  IF R[10:vgr status]<>0,JMP LBL[1] ;
  14:J P[1:above pick] 100% CNT50 Offset,PR[10:vgr offset] ;
  15:L P[2:pick] 200mm/sec FINE Offset,PR[10:vgr offset] ;
  16:  !close the gripper here ;
  17:L P[1:above pick] 1000mm/sec CNT50 Offset,PR[10:vgr offset] ;
  18:  JMP LBL[1] ;
  19:  LBL[9] ;
  20:  !no answer from the KAREL task ;
  21:  UALM[1] ;
/POS
/END
