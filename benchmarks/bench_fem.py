"""FE benchmarks.

1. Accuracy and cost per level (issue 14): the library case ``cattaneo`` (Hertz cylinder in
   stage 1, Cattaneo-Mindlin in stages 2-3) under uniform refinement, each level in a fresh
   process: DOFs, interface nodes of the contact model, history time, peak memory (RSS growth
   of the process), edge error (stage-1 end) and stick-edge error (max over the samples), both
   relative to the contact width, beside a reference row measured with Kratos (below).  Then
   least-squares exponents of time and memory against the number of interface nodes.
2. Cost on the default mesh (issue 4): Hertz and double wedge, DOFs, assembly time, one plain
   factorisation + solve (reference), the whole three-stage history (>= 40 increments) and the
   ratio history / (factorisation + solve).  Targets: ratio <= 5, whole default Hertz history
   <= 20 s on 2 cores.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_fem.py [--levels 0 1 2 3] [--no-cost]
Timings on a shared machine are noisy: compare ratios within one run.
"""

from __future__ import annotations

import argparse
import resource
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np

import fem
from fem.bulk import discretise, free_dofs, reduced_stiffness
from fem.linsolve import factorize
from fem.mesh import build_mesh

E, NU, MU = 1.0, 0.3, 0.5
A = 4 * (1 - NU**2) / E
R, P_HERTZ = 100.0, 0.01
A_HERTZ = np.sqrt(2 * A * P_HERTZ * R / np.pi)
C_WEDGE, PHI1, PHI2, P_WEDGE = 1.0, 0.11, 0.07, 0.02


def hertz_gap(x):
    """Cylinder h0 = x^2 / (2R)."""
    return x**2 / (2 * R)


def wedge_gap(x):
    """Double wedge h0 = tan(phi1)(c - |x|) for |x| < c, tan(phi2)(|x| - c) outside."""
    ax = np.abs(x)
    return np.where(ax < C_WEDGE, np.tan(PHI1) * (C_WEDGE - ax), np.tan(PHI2) * (ax - C_WEDGE))


CASES = {
    "hertz": dict(h0=hertz_gap, P0=P_HERTZ, window=(-1.3 * A_HERTZ, 1.3 * A_HERTZ), kinks=()),
    "double wedge": dict(
        h0=wedge_gap, P0=P_WEDGE, window=(-1.6, 1.6), kinks=(-C_WEDGE, 0.0, C_WEDGE)
    ),
}


def reference_factorisation(window, kinks, spec: fem.MeshSpec) -> float:
    """Seconds for one plain (fill-reducing) factorisation + one solve of the bulk."""
    disc = discretise(build_mesh(spec, window, kinks), spec.order, E, NU)
    free, _ = free_dofs(disc)
    K = reduced_stiffness(disc, free)
    t0 = time.perf_counter()
    factorize(K).solve(np.ones(K.shape[0]))
    return time.perf_counter() - t0


def run(name: str, case: dict, spec: fem.MeshSpec) -> dict:
    """Solve one case and collect its timings."""
    t0 = time.perf_counter()
    h = fem.solve_history(
        case["h0"],
        case["P0"],
        0.5 * MU * case["P0"],
        MU,
        E,
        NU,
        mesh=spec,
        window=case["window"],
        kinks=case["kinks"],
    )
    wall = time.perf_counter() - t0
    ref = reference_factorisation(case["window"], case["kinks"], spec)
    zones = h.stage(1)[-1].contact_zones
    return dict(
        case=name,
        order=spec.order,
        dofs=h.n_dofs,
        steps=len(h.steps),
        backend=h.backend,
        assembly=h.timings["assembly"],
        fact=ref,
        history=h.timings["history"],
        wall=wall,
        ratio=h.timings["history"] / ref,
        zones=len(zones),
    )


#: Kratos Multiphysics 10.3 on the same Hertz/Cattaneo problem (frictional mortar ALM contact,
#: linear triangles), as reported in issue 14: element size a/20, a/40, a/80; wall time of the
#: whole history (s); edge and stick-edge errors relative to the contact width.  Constants: the
#: run is not repeated here (see compare/external for the driver).
KRATOS = ((20, 15.6, 7.7e-4, 3.5e-3), (40, 75.0, 3.9e-4, 2.9e-3), (80, 406.0, 1.9e-4, 2.2e-3))


def level_row(level: int) -> dict:
    """One refinement level of the library case cattaneo (run in a fresh process)."""
    from compare.cases import load_case
    from compare.convergence import refined_growth
    from compare.run import run_case

    case = load_case("cattaneo")
    case = case.with_fem(level=level, growth=refined_growth(case, level))
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    res = run_case(case)
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    a, b = res.analytic.normal.zones[0]
    return dict(level=level, a_over_h=0.5 * (b - a) / res.fem.h_min, dofs=res.fem.n_dofs,
                nodes=res.fem.n_candidates, history=res.fem.timings["history"],
                memory=max(rss1 - rss0, 1) / 1024.0, edge=res.metrics["edge_error_max"],
                stick=res.metrics["stick_edge_error_max"])


def local_order(prev: dict | None, row: dict, key: str) -> float:
    """Order of ``key`` between two successive levels (nan for the first)."""
    if prev is None:
        return float("nan")
    return float(np.log(prev[key] / row[key]) / np.log(row["a_over_h"] / prev["a_over_h"]))


def exponent(n: list[float], y: list[float]) -> float:
    """Least-squares slope of log y against log n."""
    return float(np.polyfit(np.log(n), np.log(y), 1)[0])


def accuracy_table(levels: list[int]) -> None:
    rows = []
    ctx = get_context("spawn")
    for level in levels:
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            rows.append(pool.submit(level_row, level).result())
    print("Hertz (stage 1) + Cattaneo (stages 2-3), library case cattaneo, uniform refinement")
    print(f"{'':<8}{'a/h':>6}{'DOFs':>9}{'iface':>7}{'history s':>10}{'memory MB':>10}"
          f"{'edge %':>9}{'stick %':>9}{'edge order':>11}{'stick order':>12}")
    prev = None
    for r in rows:
        print(f"{'level ' + str(r['level']):<8}{r['a_over_h']:>6.0f}{r['dofs']:>9}"
              f"{r['nodes']:>7}{r['history']:>10.2f}{r['memory']:>10.0f}"
              f"{100 * r['edge']:>9.4f}{100 * r['stick']:>9.4f}"
              f"{local_order(prev, r, 'edge'):>11.2f}{local_order(prev, r, 'stick'):>12.2f}")
        prev = r
    for a_h, wall, edge, stick in KRATOS:
        print(f"{'Kratos':<8}{a_h:>6}{'':>9}{'':>7}{wall:>10.1f}{'':>10}{100 * edge:>9.4f}"
              f"{100 * stick:>9.4f}")
    if len(rows) >= 2:
        n = [r["nodes"] for r in rows]
        print(f"growth with interface nodes n: history time ~ n^"
              f"{exponent(n, [r['history'] for r in rows]):.2f}, memory ~ n^"
              f"{exponent(n, [r['memory'] for r in rows]):.2f}")


def cost_table() -> None:
    rows = [
        run(name, case, fem.MeshSpec(order=order))
        for order in (1, 2)
        for name, case in CASES.items()
    ]
    head = (
        f"{'case':<13}{'Q':>2}{'DOFs':>8}{'steps':>6}{'backend':>9}{'assembly s':>11}"
        f"{'fact+solve s':>13}{'history s':>10}{'ratio':>7}{'zones':>6}"
    )
    print(head)
    for r in rows:
        print(
            f"{r['case']:<13}{r['order']:>2}{r['dofs']:>8}{r['steps']:>6}{r['backend']:>9}"
            f"{r['assembly']:>11.2f}{r['fact']:>13.3f}{r['history']:>10.2f}{r['ratio']:>7.1f}"
            f"{r['zones']:>6}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--no-cost", action="store_true", help="skip the default-mesh cost table")
    args = ap.parse_args()
    accuracy_table(args.levels)
    if not args.no_cost:
        print()
        cost_table()


if __name__ == "__main__":
    main()
