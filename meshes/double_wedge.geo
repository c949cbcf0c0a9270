// Double wedge: gap h0 = tan(0.11) (1 - |x|) for |x| < 1, tan(0.07) (|x| - 1) outside,
// kinks at 0 and +-1 (nodes on them); mesh window +-1.6.
// Mesh: gmsh -2 double_wedge.geo -setnumber level 1 -o double_wedge_graded_L1.msh (graded:
// graded_bodies.inc; -setnumber layout 0: fem's tensor layout, two_bodies.inc)
DefineConstant[
  xmin = {-1.6, Name "window left end"},
  xmax = {1.6, Name "window right end"}
];
kinks[] = {-1, 0, 1};
DefineConstant[
  layout = {1, Name "mesh layout: 1 graded (graded_bodies.inc), 0 tensor (two_bodies.inc)"}
];
If (layout == 0)
  Include "two_bodies.inc";
Else
  Include "graded_bodies.inc";
EndIf
