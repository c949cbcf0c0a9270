// Hertz: cylinder R = 100 on a flat, E = 1, nu = 0.3, P = 0.01: contact half-width
// a = sqrt(8 (1 - nu^2) P R / (pi E)) = 1.5223; mesh window +-1.3 a, no kinks.
// Mesh: gmsh -2 hertz.geo -setnumber level 1 -o hertz_L1.msh   (parameters: two_bodies.inc)
DefineConstant[
  xmin = {-1.3 * Sqrt(8 * (1 - 0.3^2) * 0.01 * 100 / Pi), Name "window left end"},
  xmax = {1.3 * Sqrt(8 * (1 - 0.3^2) * 0.01 * 100 / Pi), Name "window right end"}
];
kinks[] = {};
Include "two_bodies.inc";
