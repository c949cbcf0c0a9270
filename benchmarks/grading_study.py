"""Why the graded ring mesh is not the default (issue 28, item 1): the Hertz edge error split into
the contact's own discretisation error and the stiffening error of the grading.

The library case ``hertz`` at each level, the FE contact edge of the full normal load against
the analytic edge, *signed* (left edge, FE minus analytic, relative to the contact width: > 0
the FE zone is narrower, i.e. the FE bodies are stiffer), in two refinements:

- ``locked``: a mesh node on each analytic edge (``edge_nodes``, ``converge --phase-locked``):
  no phase error, what is left is the contact error (O(h^2), the FE zone wider) plus the
  grading error (the coarse elements away from the contact stiffen the bodies: narrower);
- ``free``: the library refinement (the edge falls anywhere inside its element: an O(h) phase
  error of either sign adds to it).

Meshes: ``rings`` (fem.rings at the default growth, its rate falling with the level), ``tensor``
(the default layout, growth refined with the level as ``converge`` does,
compare.convergence.refined_growth) and ``rings-fine`` (rings at growth FINE_GROWTH: the
grading error negligible, so the ``locked`` column is the contact error alone).  The grading
error of a mesh is its ``locked`` value minus the ``rings-fine`` one of the same level.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/grading_study.py [--levels -1 0 1 2]
         [--fine-levels -1 0 1]
(``rings-fine`` at level 1 has ~290k DOFs; at level 2 it does not fit a shared machine.)
The measured table is beside fem.settings.DEFAULT_LAYOUT.
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
MESHES = ("rings", "tensor", "rings-fine")


def fem_settings(case, mesh: str, level: int) -> dict:
    """The [fem] changes of one mesh of the study at ``level``."""
    if mesh == "rings-fine":
        return dict(layout="rings", growth=FINE_GROWTH, level=level)
    base = case.with_fem(layout=mesh)
    return dict(layout=mesh, growth=refined_growth(base, level), level=level)


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
    print(f"{'mesh':>10} {'level':>5} {'DOFs':>8} {'locked':>10} {'free':>10} {'grading':>10}")
    fine = {}
    for mesh in ("rings-fine", "rings", "tensor"):
        levels = args.fine_levels if mesh == "rings-fine" else args.levels
        for level in levels:
            locked = edge_row(case, an, mesh, level, True)
            free = edge_row(case, an, mesh, level, False)
            if mesh == "rings-fine":
                fine[level] = locked["edge"]
            grading = locked["edge"] - fine[level] if level in fine else float("nan")
            print(f"{mesh:>10} {level:>5} {free['dofs']:>8} {locked['edge']:>+10.2e} "
                  f"{free['edge']:>+10.2e} {grading:>+10.2e}", flush=True)


if __name__ == "__main__":
    main()
