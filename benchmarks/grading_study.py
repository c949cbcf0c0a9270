"""Why the graded ring mesh is the default with incompatible modes (issue 28, item 1): the Hertz
edge error split into the contact's own discretisation error and the stiffening error of the
grading, for Q1 elements with incompatible modes (the default) and plain Q1.

The library case ``hertz`` at each level, the FE contact edge of the full normal load against
the analytic edge, *signed* (left edge, FE minus analytic, relative to the contact width: > 0
the FE zone is narrower, i.e. the FE bodies are stiffer), in two refinements:

- ``locked``: a mesh node on each analytic edge (``edge_nodes``, ``converge --phase-locked``):
  no phase error, what is left is the contact error (O(h^2), the FE zone wider) plus the
  grading error (the coarse elements away from the contact stiffen the bodies: narrower);
- ``free``: the library refinement (the edge falls anywhere inside its element: an O(h) phase
  error of either sign adds to it).

Meshes: ``rings`` (fem.rings at the default growth, its rate falling with the level), ``tensor``
(growth refined with the level as ``converge`` does, compare.convergence.refined_growth) and
``rings-fine`` (rings at growth FINE_GROWTH: the grading error negligible, so the ``locked``
column is the contact error alone), each with the modes and, suffixed ``-q1``, with plain Q1
(``tensor-q1``: the default before issue 28).  The grading error of a mesh is its ``locked``
value minus the ``rings-fine`` one of the same element and level.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/grading_study.py [--levels -1 0 1 2]
         [--fine-levels -1 0 1]
(``rings-fine`` at level 1 has ~290k DOFs; at level 2 it does not fit a shared machine.)
The measured table is beside fem.settings.DEFAULT_LAYOUT and INCOMPATIBLE_MODES.
"""

from __future__ import annotations

import argparse
import time

from compare.analytic_side import solve_case
from compare.cases import load_case
from compare.convergence import refined_growth
from compare.fem_side import run_fem
from compare.run import normal_metrics

#: Growth of the reference ring mesh whose grading error is negligible (measured: the phase-
#: locked Hertz edge moves by 3.9e-5 of the width from growth 1.05 to 1.02 at level 0, against a
#: contact error of 6.5e-4 there).
FINE_GROWTH = 1.02
#: The meshes in the order they run (the fine references first).
MESHES = ("rings-fine", "rings", "tensor", "rings-fine-q1", "rings-q1", "tensor-q1")


def fem_settings(case, mesh: str, level: int) -> dict:
    """The [fem] changes of one mesh of the study at ``level``."""
    incompatible = not mesh.endswith("-q1")
    layout = mesh.removesuffix("-q1").removesuffix("-fine")
    if mesh.removesuffix("-q1").endswith("-fine"):
        return dict(layout=layout, growth=FINE_GROWTH, level=level, incompatible=incompatible)
    base = case.with_fem(layout=layout)
    return dict(layout=layout, growth=refined_growth(base, level), level=level,
                incompatible=incompatible)


def fine_of(mesh: str) -> str:
    """The fine reference of a mesh's element."""
    return "rings-fine-q1" if mesh.endswith("-q1") else "rings-fine"


def edge_row(case, an, mesh: str, level: int, locked: bool) -> dict:
    """Signed relative left-edge error, DOFs and time of one run."""
    c = case.with_fem(edge_nodes=locked, **fem_settings(case, mesh, level))
    t0 = time.perf_counter()
    hist = run_fem(c, an.normal)
    _, zones = normal_metrics(c, an, hist.stage(1)[-1])
    (a, b), fe = zones[0]["analytic"], zones[0]["fem"]
    return dict(mesh=mesh, level=level, locked=locked, dofs=hist.n_dofs,
                edge=(fe[0] - a) / (b - a), seconds=time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[-1, 0, 1, 2])
    ap.add_argument("--fine-levels", type=int, nargs="+", default=[-1, 0, 1])
    args = ap.parse_args()
    case = load_case("hertz")
    an = solve_case(case)
    print(f"{'mesh':>14} {'level':>5} {'DOFs':>8} {'locked':>10} {'free':>10} {'grading':>10}")
    fine = {}
    for mesh in MESHES:
        levels = args.fine_levels if "-fine" in mesh else args.levels
        for level in levels:
            locked = edge_row(case, an, mesh, level, True)
            free = edge_row(case, an, mesh, level, False)
            if "-fine" in mesh:
                fine[mesh, level] = locked["edge"]
            ref = fine.get((fine_of(mesh), level))
            grading = float("nan") if ref is None else locked["edge"] - ref
            print(f"{mesh:>14} {level:>5} {free['dofs']:>8} {locked['edge']:>+10.2e} "
                  f"{free['edge']:>+10.2e} {grading:>+10.2e}", flush=True)


if __name__ == "__main__":
    main()
