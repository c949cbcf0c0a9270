"""User-facing settings: mesh specification, contact parameters and load path.

All are frozen dataclasses, validated by :func:`validate_*` helpers that raise
:class:`fem.errors.InputError` with a message naming the bad value.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError

#: Elements across the contact window at level 0 (the default mesh is level 1).
N_WINDOW_LEVEL0 = 48
#: Default half-width and depth as multiples of the window half-width. With the half-plane boundary
#: the Hertz width does not depend on it beyond the far-field multipole truncation: level 3 moment
#: width -0.0811 / -0.0872 / -0.0891 / -0.0888 % at 3 / 6 / 12.5 / 100.  The ring layout (cattaneo,
#: level 2, size 4 / 8 / 16 / 32 / 64): edge error 8.75 / 8.71 / 8.70 / 8.72 / 8.73e-5, stick 2.11 /
#: 2.10 / 2.10 / 2.10 / 2.10e-4 of the width, pressure L2 0.143 % at every size, with 55.7k / 64.3k
#: / 72.2k / 81.3k / 89.8k DOFs (+13 % per doubling); applied_moment, level 1, size 4 / 8 / 16 / 32:
#: edge 1.228 / 1.230 / 1.229 / 1.229e-3, pressure L2 0.561 / 0.559 / 0.560 / 0.560 % with 20.9k /
#: 24.7k / 28.7k / 33.5k DOFs. A bigger ring body buys nothing measurable, a smaller one saves 13 %
#: of the DOFs for a truncation error that grows like (a / W)^3 (applied_moment pressure 2e-5 at 4;
#: the tensor's level-3 moment width 0.0016 % at 6, 0.0077 % at 3): 8 for both layouts.
SIZE_FACTOR = 8.0
#: Mesh layouts (MeshSpec.layout): graded rings around the windows (fem.rings) or the tensor
#: product of an x axis and a depth axis.  The default is 'rings' with incompatible modes
#: (INCOMPATIBLE_MODES; issue 28).  Hertz, signed edge error of the width (> 0: the FE zone
#: narrower; benchmarks/grading_study.py, tests/verification/test_ring_grading.py) is the sum of
#: (a) the contact's own error, widening, O(h^2) (the nodal contact: rings at growth 1.02, plain
#: Q1, phase-locked -2.61e-3 / -6.53e-4 / -1.81e-4 at levels -1 / 0 / 1; not the penalty: the
#: augmented Lagrangian moves cattaneo's level-3 edge by < 7e-6); (b) the grading's narrowing,
#: order ~1 by the rate (GROWTH): the stiffness of plain Q1 where the grading makes it coarse,
#: +6.1e-4 / +3.3e-4 / +1.7e-4 at levels -1 / 0 / 1; (c) an O(h) phase error of either sign.  With
#: plain Q1 (b) overtakes (a) between levels 0 and 1: the free ring error changes sign there and
#: falls only 1.5x (-1.29e-3 / -2.27e-4 / +1.47e-4 at levels -1..1, local order 0.63 <
#: MIN_EDGE_ORDER of tests/verification/test_compare_convergence.py), and none of the grading's
#: knobs (body size 4-16, fine margin 0.15-0.5, fem.rings.TRANSITION_TRIGGER 3-9, transitions at
#: 3x with rates 1.1-1.15) moved the crossing at less than the tensor's level-1 cost; a rate that
#: keeps (b) below (a) at every level (1 + 0.1 2^-(level+1)) costs 6.5k / 19.8k / 60k / 200k DOFs
#: at levels -1..2 against the tensor's 1.9k / 6.3k / 26.5k / 125k.  With the modes (b) is 0.39x as
#: large (level 0) and overtakes (a) only between levels 3 and 4, below 2e-6 of the width:
#: edge offsets (+ where the FE zone is wider, as `converge` prints them) phase-locked +2.77e-3 /
#: +7.13e-4 / +2.02e-4 / +5.56e-5 / +1.99e-6 / +1.49e-6 at levels -1..4, free +2.27e-3 /
#: +9.18e-4 / +9.69e-5 at -1..1.  The tensor mesh of plain Q1 (the default before) crosses too
#: (phase-locked -1.0e-3 / -1.2e-4 / +4.3e-5 / +2.6e-5 at levels -1..2); its free
#: study stayed on one side by its level-1 phase error.  Cost: at the library's level 1 the rings
#: with the modes give cattaneo edge / stick 9.7e-5 / 2.6e-4 of the width with 25.0k DOFs, the
#: plain tensor 1.1e-4 / 5.8e-4 with 26.5k; from level 2 the rings need half the DOFs or fewer,
#: and at level 3 the tensor's accuracy costs several times less time and memory (README,
#: benchmarks/bench_fem.py).  gmsh's unstructured quads with the rings' size law
#: (meshes/graded_bodies.inc) give Hertz a like half-width at equal DOFs but a peak pressure
#: that scatters at 7e-5-6e-4 of p0 with no order, where the rings' falls to 2e-5: 15-35x / 3-6x
#: / 3.6x farther at 25k / 60k / 150k DOFs (benchmarks/gmsh_graded_study.py).
LAYOUTS = ("rings", "tensor")
DEFAULT_LAYOUT = "rings"
#: Default growth. The rings grow by ``1 + (growth - 1) 2**(-(level + 1) / 2)`` per layer
#: (fem.mesh.near_growth: 1.1 / 1.07 / 1.05 at levels 1 / 2 / 3, the grading error then falls
#: with h).  Accuracy / DOF study on cattaneo (edge / stick error of the width; rings with a
#: transition at 3x the spacing): level 3, growth 1.4 / 1.2 / 1.1: 50k DOFs 1.2e-4 / 1.2e-4,
#: 102k 1.1e-5 / 2.5e-5, 220k 5.3e-5 / 7.4e-5 (no better: the level's h limits it); level 2:
#: 21k 4.6e-4 / 1.7e-4, 41k 1.4e-4 / 1.6e-4, 89k 4.4e-5 / 2.6e-4.  1.2 is the coarsest that
#: reaches the tensor mesh's level-3 accuracy (7e-5 / 9e-5) at level 3.  With the wide edge bands
#: of fem.results (EDGE_FIT_MAX, GAP_FIT_MAX; the numbers above read the FE's smeared edge tail,
#: an O(h) 0.013-0.036 element) level 3 at growth 1.1 / 1.2 / 1.4, signed (+: FE zone wider):
#: edge +3.0e-5 / +3.9e-6 / -7.7e-5, worst stick edge +6.1e-5 / +3.1e-5 / -6.1e-5 (the contact's
#: own error widens, the grading narrows; at 1.2 they nearly cancel at levels 3-4, README).
#: Read that way the coarsest rate at level 3 is 1.3 (98k DOFs, edge 3.2e-5, stick 1.6e-5; 1.35:
#: 82k, 5.3e-5 / 3.8e-5), and it reaches level-4 accuracy at level 4 with 258k DOFs instead of
#: 402k; but at levels 0-2 1.2 is the more accurate per DOF (Hertz level 1 at 1.2 beats level 2
#: at 1.3 in half-width and peak pressure with 0.64x the DOFs), and the library's tensor meshes
#: share this default: 1.2 stays, and benchmarks/bench_fem.py --scan-growths measures the
#: coarser rates at level 3 beside it (README).  These are plain Q1's numbers; with the
#: incompatible modes (the default elements, INCOMPATIBLE_MODES) cattaneo at growth 1.15 / 1.2 /
#: 1.3 / 1.4, edge / stick of the width: level 3 219k DOFs 3.8e-5 / 4.0e-5, 154k 3.1e-5 /
#: 4.9e-5, 98k 1.45e-5 / 7.1e-5, 72k 7.4e-6 / 9.7e-5; level 1 35k 1.3e-4 / 2.2e-4, 25k 9.7e-5 /
#: 2.6e-4, 17k 2.5e-5 / 3.7e-4, 13k 3.5e-5 / 4.7e-4: the grading narrows the zone less, and
#: coarser rates shift the edge error onto the stick edge; 1.2 stays.
GROWTH = 1.2
#: Q1 elements with incompatible modes (MeshSpec.incompatible; fem.bulk.mode_gradients: the
#: Wilson-Taylor modes in Simo-Rifai's form, as Abaqus's CPE4I; condensed per element, no DOFs
#: added, the stresses recovered with them).  Plain Q1 is stiff where the grading makes it coarse,
#: and that stiffness is DEFAULT_LAYOUT's (b): Hertz level 0, phase-locked, the left edge moves by
#: +2.9e-4 of the width from growth 1.05 to 1.2 with plain Q1, +1.1e-4 with the modes, +1.6e-6
#: with Q2.  With the cancellation of (a) by (b) gone, the rings' edges are farther off at levels
#: 3-4 than plain Q1's (cattaneo, growth 1.2, levels 0..4, modes against plain Q1: edge 9.2e-4 /
#: 9.7e-5 / 5.9e-5 / 3.1e-5 / 1.45e-5 against 2.3e-4 / 1.5e-4 / 8.7e-5 / 3.9e-6 / 2.8e-6; stick
#: 3.7e-3 / 2.6e-4 / 1.5e-4 / 4.9e-5 / 1.8e-5 against 3.4e-3 / 7.3e-4 / 2.1e-4 / 3.1e-5 / 1.1e-5),
#: still within issue 28's level-3 and level-4 targets; the pressure inside the zone is closer
#: (mean error at level 3 / 4: 1.6e-5 / 6.8e-6 of p0 against 3.9e-5 / 1.8e-5), the pressure L2
#: error is set by the nodes next to the edges (3.2e-3 / 1.7e-3 / 1.05e-3 / 1.11e-3 / 4.6e-4
#: against 4.5e-3 / 2.6e-3 / 1.4e-3 / 6.6e-4 / 2.4e-4: where the edge falls between nodes, level 3
#: lands worse).
INCOMPATIBLE_MODES = True


@dataclass(frozen=True)
class MeshSpec:
    """Graded quad mesh of the two bodies.

    level: refinement level; the fine element size in the window is
        ``(xmax - xmin) / (n_window * 2**level)``.
    order: 1 (ElementQuad1) or 2 (ElementQuad2, 9-node Lagrange).
    W: half-width of both bodies (length), centred on the window centre;
        default ``size_factor`` times the window half-width.
    H: depth of each body (length); default = W.
    n_window: elements across the window at level 0.
    growth: geometric growth ratio of element sizes away from the windows (> 1).  Rings: size
        ``h + (g - 1) d`` at distance d in every direction with the level's rate
        ``g = 1 + (growth - 1) 2**(-(level+1)/2)`` (fem.mesh.near_growth: the error of the
        grading then falls with h).  Tensor: along x and in depth; in depth down to
        NEAR_DEPTH times the widest window ``1 + (growth - 1) 2**(-(level+1)/2)``
        (fem.mesh.near_growth: the Q1 error of the graded near field then falls with h).
    margin: fine-mesh margin on each side of the window, fraction of its width.
    size_factor: default W, H as multiples of the window half-width.
    boundary: 'half-plane' (the outer boundary of each body moves as a half-plane loaded
        by the interface forces, fem.farfield: no finite-body error) or 'clamped' (body 1's
        top tied to the plate, body 2's bottom clamped, sides free).
    layout: 'rings' (graded rings around the windows with conforming 3:1 transitions,
        fem.rings; the default, DEFAULT_LAYOUT says why) or 'tensor' (the tensor product of an
        x and a depth axis).
    incompatible: Q1 elements with incompatible modes (INCOMPATIBLE_MODES, the default; no
        effect on Q2).
    """

    level: int = 1
    order: int = 1
    W: float | None = None
    H: float | None = None
    n_window: int = N_WINDOW_LEVEL0
    growth: float = GROWTH
    margin: float = 0.15
    size_factor: float = SIZE_FACTOR
    boundary: str = "half-plane"
    layout: str = DEFAULT_LAYOUT
    incompatible: bool = INCOMPATIBLE_MODES


@dataclass(frozen=True)
class MeshFile:
    """A meshio-readable two-body quad mesh with named boundaries.

    The file must contain 'quad' cells for two disconnected bodies and line cells
    tagged (gmsh physical names / meshio cell sets) ``contact_upper``,
    ``contact_lower``, ``top`` and ``bottom``; the interface lies on y = 0 and the
    two contact node rows must have the same x coordinates (node-to-node).
    order: polynomial order of the elements built on the quads (1 or 2).
    boundary: 'half-plane' (every boundary node off y = 0 moves as a half-plane, see
        MeshSpec) or 'clamped' (top tied to the plate, bottom clamped).
    incompatible: Q1 elements with incompatible modes (INCOMPATIBLE_MODES; no effect on Q2).
    """

    path: Path
    order: int = 1
    boundary: str = "half-plane"
    incompatible: bool = INCOMPATIBLE_MODES


@dataclass(frozen=True)
class ContactSettings:
    """Penalty / augmented-Lagrangian contact and Newton settings.

    k_n, k_t: normal / tangential penalty stiffness (stress per length); default
        ``penalty_factor * E / h`` with h the fine element size.
    augmented: if True, Uzawa updates of the normal multiplier until the largest
        penetration is below ``pen_tol`` (length; default 1e-4 * h).
    max_uzawa: maximum number of Uzawa updates per increment.
    newton_tol: relative residual tolerance of the semi-smooth Newton iteration.
    max_newton: Newton iterations per increment before a step cut-back.
    max_cutbacks: halvings of an increment before :class:`ConvergenceError`.
    """

    k_n: float | None = None
    k_t: float | None = None
    penalty_factor: float = 100.0
    augmented: bool = False
    pen_tol: float | None = None
    max_uzawa: int = 30
    newton_tol: float = 1e-10
    max_newton: int = 40
    max_cutbacks: int = 8


@dataclass(frozen=True)
class LoadPath:
    """Increments of the three load stages (paper, Table 1).

    n_normal: increments of stage 1 (P: 0 -> P0, equal steps).
    stage2: Q values of stage 2 (increasing, ending at Q0); default
        ``n_tangential`` equal steps. Every value is hit exactly by a step.
    stage3: Q values of stage 3 (decreasing from Q0, ending at -Q0); default
        ``2 * n_tangential`` equal steps.
    """

    n_normal: int = 10
    stage2: tuple[float, ...] | None = None
    stage3: tuple[float, ...] | None = None
    n_tangential: int = 12

    def q_values(self, Q0: float) -> tuple[np.ndarray, np.ndarray]:
        """Return the (stage-2, stage-3) Q sample values for amplitude Q0."""
        s2 = (
            np.linspace(0.0, Q0, self.n_tangential + 1)[1:]
            if self.stage2 is None
            else np.asarray(self.stage2, float)
        )
        s3 = (
            np.linspace(Q0, -Q0, 2 * self.n_tangential + 1)[1:]
            if self.stage3 is None
            else np.asarray(self.stage3, float)
        )
        return s2, s3


def validate_path(path: LoadPath, Q0: float) -> tuple[np.ndarray, np.ndarray]:
    """Check the load path and return the stage-2 and stage-3 Q values."""
    if path.n_normal < 1:
        raise InputError(f"n_normal={path.n_normal} is not allowed: need >= 1")
    s2, s3 = path.q_values(Q0)
    tol = 1e-12 * max(abs(Q0), 1.0)
    if s2.size < 1 or abs(s2[-1] - Q0) > tol or np.any(np.diff(np.r_[0.0, s2]) < -tol):
        raise InputError(
            f"stage2={s2.tolist()} is not allowed: need Q values increasing "
            f"from 0 and ending at Q0={Q0:g}"
        )
    if s3.size < 1 or abs(s3[-1] + Q0) > tol or np.any(np.diff(np.r_[Q0, s3]) > tol):
        raise InputError(
            f"stage3={s3.tolist()} is not allowed: need Q values decreasing "
            f"from Q0={Q0:g} and ending at -Q0"
        )
    return s2, s3


#: Outer boundary conditions of the two bodies (MeshSpec.boundary, MeshFile.boundary).
BOUNDARIES = ("half-plane", "clamped")


def validate_boundary(boundary: str) -> None:
    """Raise InputError unless boundary is one of BOUNDARIES."""
    if boundary not in BOUNDARIES:
        raise InputError(f"boundary={boundary!r} is not allowed: need one of {list(BOUNDARIES)}")


def validate_mesh_spec(spec: MeshSpec) -> None:
    """Raise InputError for an impossible mesh specification."""
    validate_boundary(spec.boundary)
    if spec.order not in (1, 2):
        raise InputError(f"order={spec.order!r} is not allowed: need 1 or 2")
    if spec.level < -3 or spec.level > 6:
        raise InputError(f"level={spec.level!r} is not allowed: need -3 <= level <= 6")
    if spec.layout not in LAYOUTS:
        raise InputError(f"layout={spec.layout!r} is not allowed: need one of {list(LAYOUTS)}")
    if not 1.0 < spec.growth <= 2.0:
        raise InputError(f"growth={spec.growth!r} is not allowed: need 1 < growth <= 2")
    for name in ("W", "H"):
        val = getattr(spec, name)
        if val is not None and (not np.isfinite(val) or val <= 0):
            raise InputError(f"{name}={val!r} is not allowed: need a positive length")
