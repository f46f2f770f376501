/PROG  VGR_PICK
/ATTR
COMMENT		= "vgr pick";
DEFAULT_GROUP	= 1,*,*,*,*;
/MN
   1:  !vgrd via KAREL task VGR_BG ;
   2:  !UFRAME 1 = cell.yaml robots[].frame ;
   3:  !P[1], P[2] taught with the ;
   4:  !reference part lying there: ;
   5:  !Offset,PR[10] moves them onto ;
   6:  !the part found ;
   7:  UFRAME_NUM=1 ;
   8:  UTOOL_NUM=1 ;
   9:  RUN VGR_BG ;
  10:  LBL[1] ;
  11:  !ask for the next part ;
  12:  R[12:vgr flag]=0 ;
  13:  WAIT R[12:vgr flag]=1 TIMEOUT,LBL[9] ;
  14:  !R[10] status 0 = part found ;
  15:  IF R[10:vgr status]<>0,JMP LBL[1] ;
  16:J P[1:above pick] 100% CNT50 Offset,PR[10:vgr offset] ;
  17:L P[2:pick] 200mm/sec FINE Offset,PR[10:vgr offset] ;
  18:  !close the gripper here ;
  19:L P[1:above pick] 1000mm/sec CNT50 Offset,PR[10:vgr offset] ;
  20:  JMP LBL[1] ;
  21:  LBL[9] ;
  22:  !no answer from the KAREL task ;
  23:  UALM[1] ;
/POS
P[1:"above pick"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =     0.000  mm,	Y =  -212.132  mm,	Z =   100.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   -45.000 deg
};
P[2:"pick"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =     0.000  mm,	Y =  -212.132  mm,	Z =     0.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =   -45.000 deg
};
/END
