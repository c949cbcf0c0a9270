"""multicontact.fem -- finite element model of frictional plane contact (scikit-fem).

Two plane-strain elastic bodies (same E, nu): body 1 (upper, carries the profile via
the initial gap h0(x)) and body 2 (lower, flat, bottom clamped); the top of body 1 is
tied to a rigid plate (u, v, theta about the point (0, 0)) loaded by (Q, P, M) or with
theta locked. Node-to-node penalty contact (optional augmented Lagrangian) and
Coulomb friction with a return mapping, loaded along the paper's Table 1 path:
stage 1 P: 0 -> P0 (Q = 0), stage 2 Q: 0 -> Q0, stage 3 Q: Q0 -> -Q0.

Public API
----------
solve_history(h0, P0, Q0, mu, E, nu, *, M=None, mesh=None, contact=None,
              increments=None, kinks=(), window=None, vtk_dir=None,
              backend="auto") -> FemHistory
    h0: vectorised callable x -> initial gap >= 0 (np.inf: contact impossible).
    M: None = vertical indentation (rotation locked, M reported), else applied moment.
    mesh: MeshSpec(level=1, order=1|2, W=None, H=None, n_window=48, growth=1.2,
          margin=0.15, size_factor=8, boundary="half-plane"|"clamped",
          layout="rings"|"tensor", incompatible=True) |
          MeshFile(path, order=1, boundary=..., incompatible=True) | path (str/Path) of a
          meshio file with line sets contact_upper, contact_lower, top, bottom.
          incompatible: Q1 elements with incompatible modes (condensed per element).
    contact: ContactSettings(k_n=None, k_t=None, penalty_factor=100, augmented=False,
          pen_tol=None, max_uzawa=30, newton_tol=1e-10, max_newton=40,
          max_cutbacks=8); defaults k = 100 E / h, pen_tol = 1e-4 h.
    increments: LoadPath(n_normal=10, stage2=None, stage3=None, n_tangential=12):
          stage2 / stage3 are exact Q sample values (each becomes a step).
    kinks: x of profile slope discontinuities (mesh nodes are put there).
    window: (xmin, xmax) expected contact window, or one window per expected zone
          ((xmin, xmax), ...): each is refined relative to its own width, graded across
          the gaps (required for MeshSpec).
    vtk_dir: if given, write_vtk(history, vtk_dir).
write_vtk(history, directory, steps="all") -> Path of the .pvd time series (steps="ends": the
    last step of each stage).
    backend: sparse solver ("auto" = cholmod > pypardiso > scipy-splu; the one that
          ran is FemHistory.backend).
FemHistory: steps, n_dofs, order, backend, timings (seconds: assembly,
    factorisation+condensation, increments, recovery, history = all after
    assembly), mu, E, nu, P0, Q0, h_min, n_candidates; .stage(k),
    .at(stage, Q=..) (stages 2, 3) / .at(1, P=..), .displacement(step) -> (u1, u2)
    dof vectors, .stress(step) -> per body (sxx, syy, sxy, szz) at nodal dofs.
FemStep: index, stage, t, P, Q, M, interface (FemInterface: x, w, p, q, status
    0 open / 1 stick / 2 slip, slip, penetration, gap), contact_zones ((a, b), ...),
    stick_zones ((c, d) | None per contact zone), plate (u, v, theta),
    reactions (P, Q, M), residuals, iterations.
Errors: InputError(ValueError), ConvergenceError(RuntimeError) in fem.errors.

Model notes: both bodies are flat rectangles [-W, W] x [0, H] / [-H, 0] around the
window centre; the profile enters only through h0 in the gap (small-slope,
half-plane assumption shared with the analytic solution). boundary="half-plane"
(default): the outer boundary of each body moves as a half-plane loaded by its
interface forces (Flamant multipoles of the pair forces, fem.farfield; body 1 plus
the plate's rigid motion), so there is no finite-body error; "clamped": body 1's top
tied to the plate, body 2's bottom clamped. The prescribed dofs are fixed in the bulk
problem (rigid motion is stress free), so one CHOLMOD factorisation with the contact
dofs ordered last gives the interface compliance directly (Schur complement), plus a
rank-6 far-field term; every Newton (active-set) iteration is then a small dense
solve. Only interface nodes with finite h0 inside
the window +- half its width are contact candidates; any other node penetrating
raises "window too small". Equilibrium: the plate reactions recovered from the full
field (K1 u1 on body 1's prescribed dofs) must equal (P, Q, M) to 1e-8 relative (M:
relative to P0 times the largest lever arm of those forces) at every step.
"""

from .errors import ConvergenceError, InputError
from .history import FemHistory, solve_history
from .linsolve import available_backends
from .results import FemInterface, FemStep
from .settings import ContactSettings, LoadPath, MeshFile, MeshSpec
from .vtk import write_vtk

__all__ = [
    "solve_history",
    "write_vtk",
    "FemHistory",
    "FemStep",
    "FemInterface",
    "MeshSpec",
    "MeshFile",
    "ContactSettings",
    "LoadPath",
    "InputError",
    "ConvergenceError",
    "available_backends",
]
