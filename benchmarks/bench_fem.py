"""FE benchmarks.

1. Accuracy and cost per level (issues 14, 28): the library case ``cattaneo`` (Hertz cylinder
   in stage 1, Cattaneo-Mindlin in stages 2-3) under uniform refinement, each level in a fresh
   process: DOFs, interface nodes n of the contact model, history time (wall-clock and CPU),
   peak memory (RSS growth of the process), edge error (stage-1 end) and stick-edge error (max
   over the samples), both relative to the contact width, beside a reference row measured with
   Kratos (below); a level that does not fit says so.  Then the time split per level (mesh,
   assembly, factorisation+condensation, increments, recovery, metrics; wall-clock / CPU: on a
   shared machine the CPU seconds are the stable figure) and least-squares exponents of time
   and memory against n.
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
from concurrent.futures.process import BrokenProcessPool
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


#: Phases of one level: the FE history's (fem.solve_history timings) and the comparison's
#: metrics (compare.run.evaluate: interface, error and stress metrics).
PHASES = ("mesh", "assembly", "factorisation+condensation", "increments", "recovery", "metrics")
#: Column heads of PHASES.
PHASE_HEADS = ("mesh", "assembly", "fact+cond", "increments", "recovery", "metrics")


def level_row(level: int) -> dict:
    """One refinement level of the library case cattaneo (run in a fresh process): sizes,
    wall-clock and CPU seconds per phase, peak memory (RSS growth of the process) and errors."""
    from compare.analytic_side import solve_case
    from compare.cases import load_case
    from compare.convergence import refined_growth
    from compare.fem_side import run_fem
    from compare.run import evaluate

    case = load_case("cattaneo")
    case = case.with_fem(level=level, growth=refined_growth(case, level))
    an = solve_case(case)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    c0 = time.process_time()
    hist = run_fem(case, an.normal)
    c1, w1 = time.process_time(), time.perf_counter()
    metrics = evaluate(case, an, hist)[0]
    c2, w2 = time.process_time(), time.perf_counter()
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    a, b = an.normal.zones[0]
    cpu = dict(hist.timings.get("cpu", {}))
    cpu["metrics"] = c2 - c1
    wall = {k: hist.timings.get(k, float("nan")) for k in PHASES[:-1]}
    wall["metrics"] = w2 - w1
    return dict(level=level, a_over_h=0.5 * (b - a) / hist.h_min, dofs=hist.n_dofs,
                nodes=hist.n_candidates, history=hist.timings["history"],
                cpu_history=cpu.get("history", float("nan")), cpu_fem=c1 - c0, wall=wall, cpu=cpu,
                memory=max(rss1 - rss0, 1) / 1024.0, edge=metrics["edge_error_max"],
                stick=metrics["stick_edge_error_max"])


def local_order(prev: dict | None, row: dict, key: str) -> float:
    """Order of ``key`` between two successive levels (nan for the first)."""
    if prev is None:
        return float("nan")
    return float(np.log(prev[key] / row[key]) / np.log(row["a_over_h"] / prev["a_over_h"]))


def exponent(n: list[float], y: list[float]) -> float:
    """Least-squares slope of log y against log n."""
    return float(np.polyfit(np.log(n), np.log(y), 1)[0])


def run_level(level: int) -> dict | str:
    """level_row in a fresh process, or the reason it did not run (a level too large for the
    machine must say so, not crash the table)."""
    ctx = get_context("spawn")
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx) as pool:
            return pool.submit(level_row, level).result()
    except (MemoryError, BrokenProcessPool) as exc:
        return f"did not fit ({type(exc).__name__}: the worker ran out of memory or was killed)"


def accuracy_table(levels: list[int]) -> None:
    rows = []
    print("Hertz (stage 1) + Cattaneo (stages 2-3), library case cattaneo, uniform refinement")
    print(f"{'':<8}{'a/h':>6}{'DOFs':>9}{'iface':>7}{'history s':>10}{'CPU s':>8}{'FE CPU s':>9}"
          f"{'memory MB':>10}{'edge %':>9}{'stick %':>9}{'edge order':>11}{'stick order':>12}")
    prev = None
    for level in levels:
        r = run_level(level)
        if isinstance(r, str):
            print(f"{'level ' + str(level):<8} {r}")
            continue
        rows.append(r)
        print(f"{'level ' + str(r['level']):<8}{r['a_over_h']:>6.0f}{r['dofs']:>9}"
              f"{r['nodes']:>7}{r['history']:>10.2f}{r['cpu_history']:>8.2f}{r['cpu_fem']:>9.2f}"
              f"{r['memory']:>10.0f}"
              f"{100 * r['edge']:>9.4f}{100 * r['stick']:>9.4f}"
              f"{local_order(prev, r, 'edge'):>11.2f}{local_order(prev, r, 'stick'):>12.2f}",
              flush=True)
        prev = r
    for a_h, wall, edge, stick in KRATOS:
        print(f"{'Kratos':<8}{a_h:>6}{'':>9}{'':>7}{wall:>10.1f}{'':>17}{'':>10}{100 * edge:>9.4f}"
              f"{100 * stick:>9.4f}")
    phase_table(rows)


def phase_table(rows: list[dict]) -> None:
    """Time split per level (wall / CPU seconds) and the growth exponents in n."""
    if not rows:
        return
    print("\ntime split per level, wall-clock / CPU seconds (history = fact+cond + increments + "
          "recovery)")
    print(f"{'':<8}{'n':>6}" + "".join(f"{h:>17}" for h in PHASE_HEADS))
    for r in rows:
        cells = "".join(f"{r['wall'][k]:>9.2f}/{r['cpu'].get(k, float('nan')):<7.2f}"
                        for k in PHASES)
        print(f"{'level ' + str(r['level']):<8}{r['nodes']:>6}{cells}")
    if len(rows) < 2:
        return
    n = [r["nodes"] for r in rows]
    fits = [f"history {exponent(n, [r['history'] for r in rows]):.2f}",
            f"history CPU {exponent(n, [r['cpu_history'] for r in rows]):.2f}",
            f"FE CPU {exponent(n, [r['cpu_fem'] for r in rows]):.2f}"]
    fits += [f"{h} CPU {exponent(n, [max(r['cpu'][k], 1e-3) for r in rows]):.2f}"
             for k, h in zip(PHASES, PHASE_HEADS, strict=True) if all(k in r["cpu"] for r in rows)]
    fits.append(f"memory {exponent(n, [r['memory'] for r in rows]):.2f}")
    print("growth with interface nodes n (least-squares exponent of t ~ n^k): " + ", ".join(fits))


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
