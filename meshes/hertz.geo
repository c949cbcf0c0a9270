// Hertz: cylinder R = 100 on a flat, E = 1, nu = 0.3, P = 0.01: contact half-width
// a = sqrt(8 (1 - nu^2) P R / (pi E)) = 1.5223; mesh window +-1.3 a, no kinks.
// Mesh: gmsh -2 hertz.geo -setnumber level 1 -o hertz_graded_L1.msh (graded: graded_bodies.inc;
// -setnumber layout 0: fem's tensor layout, two_bodies.inc)
DefineConstant[
  xmin = {-1.3 * Sqrt(8 * (1 - 0.3^2) * 0.01 * 100 / Pi), Name "window left end"},
  xmax = {1.3 * Sqrt(8 * (1 - 0.3^2) * 0.01 * 100 / Pi), Name "window right end"}
];
kinks[] = {};
DefineConstant[
  layout = {1, Name "mesh layout: 1 graded (graded_bodies.inc), 0 tensor (two_bodies.inc)"}
];
If (layout == 0)
  Include "two_bodies.inc";
Else
  Include "graded_bodies.inc";
EndIf
