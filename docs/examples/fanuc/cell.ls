/PROG  CELL
/ATTR
OWNER		= MNEDITOR;
DEFAULT_GROUP	= 1,*,*,*,*;
/MN
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=1 ;
   3:J P[1] 100% FINE    ;
   4:J P[2] 100% FINE    ;
   5:J P[3] 100% FINE    ;
   6:J P[4] 100% FINE    ;
/POS
P[1]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   247.976  mm,	Y =   -27.699  mm,	Z =    99.395  mm,
	W =   180.000 deg,	P =   -25.000 deg,	R =   -30.000 deg
};
P[2]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 1',
	X =   396.741  mm,	Y =    84.679  mm,	Z =   137.645  mm,
	W =  -130.629 deg,	P =    10.323 deg,	R =  -143.627 deg
};
P[3]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'F U T, 0, 0, 0',
	X =   -15.938  mm,	Y =  -227.747  mm,	Z =   454.384  mm,
	W =   -30.274 deg,	P =   -10.244 deg,	R =   155.479 deg
};
P[4]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, -1',
	X =   408.770  mm,	Y =  -107.021  mm,	Z =   164.071  mm,
	W =   178.396 deg,	P =    67.227 deg,	R =   121.125 deg
};
/END
