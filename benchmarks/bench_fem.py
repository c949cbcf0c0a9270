"""FE benchmarks.

1. Accuracy and cost per level (issues 14, 28): the library case ``cattaneo`` (Hertz cylinder
   in stage 1, Cattaneo-Mindlin in stages 2-3) under refinement, on the graded ring mesh
   (fem.rings at the case's growth: the rings' rate falls with the level by itself; the default
   elements, Q1 with incompatible modes) and on the tensor mesh of plain Q1 (the default before
   issue 28; growth refined with the level, compare.convergence.refined_growth), each level
   run in a fresh process with its address space capped (``--max-gb``; a level that runs out
   of memory says "does not fit" and the table goes on): DOFs, interface nodes n of the
   contact model, the CPU seconds of every phase (mesh, assembly, factorisation +
   condensation, increments, recovery, the whole history, the comparison's metrics; CPU, not
   wall: on the shared 2-core machine wall times are mostly waiting), the process's peak RSS
   (and its peak at the end of the FE history, before the comparison's metrics: 'FE MB'),
   edge error (stage-1 end) and stick-edge error (max over the samples), both relative to the
   contact width, beside a reference row measured with Kratos (wall seconds, below).  Then
   least-squares exponents of every phase's time and of the memory growth against n (levels
   >= FIT_FROM), the local exponents of the history time, the cheapest ring run that reaches
   the tensor mesh's finest accuracy with its time and memory ratios (then the same two runs
   repeated alternately, ``--ratio-pairs``, with the medians and ranges of the ratios), and the
   cheapest ring run at level-4 accuracy against the tensor level 4 of issue 28.  The ring
   ladder runs at the case's growth; ``--scan-growths`` adds ring runs at the finest tensor
   level with other growths (the accuracy / cost study behind the level-3 ratios: a coarser
   grading that still reaches the tensor's accuracy is the cheaper mesh for it), marked in the
   'g' column and left out of the exponents.
2. Cost on the default mesh (issue 4): Hertz and double wedge, DOFs, assembly time, one plain
   factorisation + solve (reference), the whole three-stage history (>= 40 increments) and the
   ratio history / (factorisation + solve).  Targets: ratio <= 5, whole default Hertz history
   <= 20 s on 2 cores.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_fem.py [--levels 0 1 2 3 4 5 6]
         [--tensor-levels 0 1 2 3] [--scan-growths 1.3 1.4] [--ratio-pairs 3] [--max-gb 8]
         [--no-cost]
(tensor level 4 needs ~14 GB: do not run it on a shared machine).
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


def cap_memory(max_gb: float) -> None:
    """Cap this process's address space (a level that needs more raises MemoryError)."""
    limit = int(max_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def level_row(level: int, layout: str, growth: float | None = None) -> dict:
    """One refinement level of the library case cattaneo (run in a fresh process): CPU seconds
    per phase (on a shared machine the CPU time is the stable one), the process's peak RSS and
    its growth over the run, errors; ``{'failed': ...}`` if it does not fit.  ``growth``: the
    rings' growth (None: the case's)."""
    from compare.analytic_side import solve_case
    from compare.cases import load_case
    from compare.convergence import refined_growth
    from compare.fem_side import kinks, run_fem, window
    from compare.run import evaluate

    case = load_case("cattaneo").with_fem(layout=layout)
    if layout == "tensor":  # the tensor mesh as issue 28 measured it, the default before: plain Q1
        case = case.with_fem(incompatible=False)
    if growth is not None and layout == "rings":
        case = case.with_fem(growth=growth)
    case = case.with_fem(level=level, growth=refined_growth(case, level))
    an = solve_case(case)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    try:
        hist = run_fem(case, an.normal)
        rss_fe = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        c0 = time.process_time()
        metrics = evaluate(case, an, hist)[0]
        compare = time.process_time() - c0
    except MemoryError as exc:
        return dict(layout=layout, level=level, failed=f"does not fit ({type(exc).__name__})")
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    c0 = time.process_time()
    spec = fem.MeshSpec(level=level, growth=case.fem.growth, layout=layout)
    build_mesh(spec, window(case, an.normal), kinks(case))
    a, b = an.normal.zones[0]
    t = hist.timings["cpu"]
    return dict(layout=layout, level=level, growth=case.fem.growth,
                a_over_h=0.5 * (b - a) / hist.h_min,
                dofs=hist.n_dofs, nodes=hist.n_candidates, mesh=time.process_time() - c0,
                assembly=t["assembly"], factor=t["factorisation+condensation"],
                increments=t["increments"], recovery=t["recovery"], history=t["history"],
                compare=compare, peak=rss1 / 1024.0, fe_peak=rss_fe / 1024.0,
                memory=max(rss1 - rss0, 1) / 1024.0, fe_memory=max(rss_fe - rss0, 1) / 1024.0,
                base=rss0 / 1024.0,
                edge=metrics["edge_error_max"], stick=metrics["stick_edge_error_max"])


def run_level(level: int, layout: str, max_gb: float, growth: float | None = None) -> dict:
    """level_row in a fresh capped process; {'failed': why} if it does not fit or fails."""
    ctx = get_context("spawn")
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=ctx, initializer=cap_memory,
                                 initargs=(max_gb,)) as pool:
            row = pool.submit(level_row, level, layout, growth).result()
    except MemoryError:
        row = dict(layout=layout, level=level, failed="does not fit")
    except BrokenProcessPool:
        row = dict(layout=layout, level=level, failed="process killed (out of memory?)")
    except Exception as exc:  # a failed level is reported, the table goes on  # noqa: BLE001
        why = f"{type(exc).__name__}: {exc}"
        row = dict(layout=layout, level=level,
                   failed="does not fit" if out_of_memory(why) else why[:120])
    if "failed" in row and row["failed"].startswith("does not fit"):
        row["failed"] += f" in {max_gb:g} GB"
    return row


def out_of_memory(why: str) -> bool:
    """Whether an error's text says it ran out of memory (CHOLMOD's own errors, e.g.)."""
    return "outofmemory" in why.lower().replace(" ", "")


def local_order(prev: dict | None, row: dict, key: str) -> float:
    """Order of ``key`` between two successive levels (nan for the first)."""
    if prev is None or "failed" in prev:
        return float("nan")
    return float(np.log(prev[key] / row[key]) / np.log(row["a_over_h"] / prev["a_over_h"]))


def exponent(n: list[float], y: list[float]) -> float:
    """Least-squares slope of log y against log n."""
    return float(np.polyfit(np.log(n), np.log(y), 1)[0])


HEAD = (f"{'mesh':<7}{'lvl':>4}{'g':>7}{'a/h':>6}{'DOFs':>9}{'n':>6}{'mesh s':>8}{'asm s':>7}"
        f"{'fact s':>8}{'incr s':>8}{'rec s':>7}{'hist s':>8}{'cmp s':>7}{'peak MB':>9}{'FE MB':>7}"
        f"{'edge %':>9}{'stick %':>9}{'ord e':>7}{'ord s':>7}")
#: Ring growths tried at the finest tensor level besides the case's: coarser gradings reach the
#: tensor level 3's accuracy with fewer DOFs there, while the default stays for levels 0-2 (the
#: measurements are beside fem.settings.GROWTH).
SCAN_GROWTHS = (1.3, 1.4)
#: Alternating repeats of the ratio's two runs (the ring run's history is about a second at
#: level 3, and its ratio scattered between 3.8x and 5.3x over single runs, README).
RATIO_PAIRS = 3
#: Levels from which the growth exponents are fitted (issue 28: history time from level 1 on).
FIT_FROM = 1
#: Phases whose growth exponent in n is printed.
PHASES = ("assembly", "factor", "increments", "recovery", "history", "compare")


def row_text(r: dict, prev: dict | None) -> str:
    """One line of the accuracy table (or what stopped the level)."""
    if "failed" in r:
        return f"{r['layout']:<7}{r['level']:>4}  {r['failed']}"
    return (f"{r['layout']:<7}{r['level']:>4}{r['growth']:>7.4g}{r['a_over_h']:>6.0f}"
            f"{r['dofs']:>9}{r['nodes']:>6}"
            f"{r['mesh']:>8.2f}{r['assembly']:>7.2f}{r['factor']:>8.2f}{r['increments']:>8.2f}"
            f"{r['recovery']:>7.2f}{r['history']:>8.2f}{r['compare']:>7.2f}{r['peak']:>9.0f}"
            f"{r['fe_peak']:>7.0f}"
            f"{100 * r['edge']:>9.4f}{100 * r['stick']:>9.4f}"
            f"{local_order(prev, r, 'edge'):>7.2f}{local_order(prev, r, 'stick'):>7.2f}")


def local_exponent(a: dict, b: dict) -> float:
    """Exponent of the history time in n between two levels."""
    return exponent([a["nodes"], b["nodes"]], [a["history"], b["history"]])


def growth_text(layout: str, rows: list[dict]) -> str:
    """Least-squares exponents in n of every phase's CPU time and of the memory growth (levels
    >= FIT_FROM), and the local exponent of the history time between successive levels."""
    ok = [r for r in rows if r["layout"] == layout and r["level"] >= FIT_FROM
          and not r["scan"]]
    if len(ok) < 2:
        return f"{layout}: fewer than two levels >= {FIT_FROM}: no exponents"
    n = [r["nodes"] for r in ok]
    fits = ", ".join(f"{k} n^{exponent(n, [max(r[k], 1e-3) for r in ok]):.2f}" for k in PHASES)
    local = ", ".join(
        f"{a['level']}->{b['level']} n^{local_exponent(a, b):.2f}"
        for a, b in zip(ok, ok[1:], strict=False))
    lv = f"levels {ok[0]['level']}-{ok[-1]['level']}"
    return (f"{layout}, {lv}: CPU time {fits}; memory growth n^"
            f"{exponent(n, [r['memory'] for r in ok]):.2f}\n  history time local: {local}")


def accuracy_table(levels: list[int], tensor_levels: list[int], max_gb: float,
                   growth: float | None = None, scan: tuple[float, ...] = (),
                   pairs: int = RATIO_PAIRS) -> None:
    runs = ([(lv, "rings", growth, False) for lv in levels]
            + [(lv, "tensor", None, False) for lv in tensor_levels]
            + [(max(tensor_levels), "rings", g, True) for g in scan if tensor_levels])
    rows = []
    for lv, layout, g, is_scan in runs:
        rows.append(run_level(lv, layout, max_gb, g) | {"scan": is_scan})
        print(row_text(rows[-1], None), flush=True)
    print()
    print("Hertz (stage 1) + Cattaneo (stages 2-3), library case cattaneo; CPU seconds per "
          "phase (one BLAS thread), peak RSS of the run's process (FE: at the end of the FE "
          "history, before the comparison's metrics), errors of the width; ring "
          f"growth {'of the case' if growth is None else growth}")
    print(HEAD)
    for layout, is_scan in (("rings", False), ("tensor", False), ("rings", True)):
        prev = None
        for r in (r for r in rows if r["layout"] == layout and r["scan"] == is_scan):
            print(row_text(r, None if is_scan else prev))
            prev = r
    for a_h, wall, edge, stick in KRATOS:
        print(f"{'Kratos':<7}{'':>11}{a_h:>6}{'':>69}{wall:>8.1f}{'':>23}{100 * edge:>9.4f}"
              f"{100 * stick:>9.4f}   (wall s)")
    done = [r for r in rows if "failed" not in r]
    for layout in ("rings", "tensor"):
        print(growth_text(layout, done))
    print(target_text(done))
    compared = {id(best): (ref, best) for ref, best in (ratio_pair(done, bar) for bar in
                                                        (None, ISSUE_L3_ACCURACY)) if best}
    for ref, best in compared.values() if pairs > 0 else ():
        print(f"ring level {best['level']}, growth {best['growth']:g}: "
              + repeated_ratio_text(repeated_ratios(ref, best, pairs, max_gb)))


def target_text(rows: list[dict]) -> str:
    """The cheapest ring run at least as accurate (edge and stick) as the finest tensor run,
    with its history-time and peak-memory ratios (issue 28 target: >= 5x and >= 4x at level 3),
    and the cheapest ring run at level-4 accuracy against the tensor level 4 of the issue."""
    return "\n".join((tensor_ratio_text(rows), tensor_ratio_text(rows, ISSUE_L3_ACCURACY),
                      level4_text(rows)))


#: Issue 28's level-3 accuracy bar as the issue states it (edge, stick of the width: "today's
#: level-3 accuracy", the tensor level 3 then); the finest tensor run of a bench run is read
#: with today's wider edge bands and sets a stricter bar (0.0040 / 0.0070 %).
ISSUE_L3_ACCURACY = (7e-5, 9e-5)


def ratio_pair(rows: list[dict], bar: tuple[float, float] | None = None
               ) -> tuple[dict | None, dict | None]:
    """(finest tensor run, cheapest ring run at least as accurate in edge and stick as ``bar``,
    by default the tensor run's own errors); None for what is missing."""
    tensor = [r for r in rows if r["layout"] == "tensor"]
    if not tensor:
        return None, None
    ref = max(tensor, key=lambda r: r["level"])
    edge, stick = bar or (ref["edge"], ref["stick"])
    good = [r for r in rows if r["layout"] == "rings" and r["edge"] <= edge
            and r["stick"] <= stick]
    return ref, min(good, key=lambda r: r["history"]) if good else None


def tensor_ratio_text(rows: list[dict], bar: tuple[float, float] | None = None) -> str:
    ref, best = ratio_pair(rows, bar)
    if ref is None:
        return "no tensor run: no ratios"
    edge, stick = bar or (ref["edge"], ref["stick"])
    what = "issue 28's level-3 accuracy" if bar else f"tensor level {ref['level']} accuracy"
    if best is None:
        return f"no ring run reaches {what} (edge {100 * edge:.4f} %, stick {100 * stick:.4f} %)"
    return (f"{what} (edge {100 * edge:.4f} %, stick "
            f"{100 * stick:.4f} %) at ring level {best['level']}, growth "
            f"{best['growth']:g}: "
            f"{ref['history'] / best['history']:.2f}x less history time, "
            f"{ref['peak'] / best['peak']:.2f}x less peak memory "
            f"({ref['fe_peak'] / best['fe_peak']:.1f}x in the FE history alone; "
            f"{ref['fe_memory'] / best['fe_memory']:.1f}x in the FE's own growth above the "
            f"process's {best['base']:.0f} MB of interpreter, libraries and analytic solution), "
            f"{ref['dofs'] / best['dofs']:.1f}x fewer DOFs, than the tensor level {ref['level']}")


def repeated_ratios(ref: dict, best: dict, pairs: int, max_gb: float) -> list[tuple]:
    """(history ratio, peak ratio, FE-growth ratio) of ``pairs`` alternating fresh runs of the
    ring run ``best`` and the tensor run ``ref``."""
    out = []
    for _ in range(pairs):
        ring = run_level(best["level"], "rings", max_gb, best["growth"])
        tensor = run_level(ref["level"], "tensor", max_gb)
        if "failed" in ring or "failed" in tensor:
            continue
        out.append((tensor["history"] / ring["history"], tensor["peak"] / ring["peak"],
                    tensor["fe_memory"] / ring["fe_memory"]))
    return out


def repeated_ratio_text(ratios: list[tuple]) -> str:
    """Medians and ranges of :func:`repeated_ratios`."""
    if not ratios:
        return "no repeated pair ran"
    cols = np.array(ratios)
    parts = [f"{name} {np.median(c):.2f}x ({c.min():.2f}-{c.max():.2f}x)" for name, c in
             zip(("history time", "peak memory", "FE's own memory"), cols.T, strict=True)]
    return f"{len(ratios)} alternating pairs, median (range): " + ", ".join(parts)


#: Tensor level 4 as measured in issue 28 (main 53e2816, CHOLMOD, one BLAS thread): history
#: seconds and peak GB; the target is level-4 accuracy (LEVEL4_ACCURACY of the width, edge and
#: stick) in a tenth of that time and at most 2 GB.  Not re-run here: it needs ~14 GB.
TENSOR_L4_SECONDS, TENSOR_L4_GB = 184.0, 14.0
LEVEL4_ACCURACY = 2e-5


def level4_text(rows: list[dict]) -> str:
    good = [r for r in rows if r["layout"] == "rings" and r["edge"] <= LEVEL4_ACCURACY
            and r["stick"] <= LEVEL4_ACCURACY]
    if not good:
        return (f"no ring run reaches level-4 accuracy (edge and stick <= "
                f"{100 * LEVEL4_ACCURACY:g} % of the width)")
    best = min(good, key=lambda r: r["history"])
    return (f"level-4 accuracy at ring level {best['level']}, growth {best['growth']:g}: "
            f"history {best['history']:.1f} s "
            f"CPU ({TENSOR_L4_SECONDS / best['history']:.1f}x less than the tensor level 4's "
            f"{TENSOR_L4_SECONDS:g} s), peak {best['peak'] / 1024:.2f} GB (tensor "
            f"{TENSOR_L4_GB:g} GB)")


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
    ap.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3, 4, 5, 6],
                    help="ring-mesh levels")
    ap.add_argument("--tensor-levels", type=int, nargs="*", default=[0, 1, 2, 3],
                    help="tensor-mesh levels (today's reference; level 4 needs ~14 GB)")
    ap.add_argument("--max-gb", type=float, default=8.0,
                    help="address-space cap per run (GB); a level that needs more says so")
    ap.add_argument("--growth", type=float, default=None,
                    help="growth of the ring meshes (default: the case's)")
    ap.add_argument("--scan-growths", type=float, nargs="*", default=list(SCAN_GROWTHS),
                    help="ring runs at the finest tensor level with these growths")
    ap.add_argument("--ratio-pairs", type=int, default=RATIO_PAIRS,
                    help="alternating repeats of the tensor-accuracy ratio's two runs")
    ap.add_argument("--no-cost", action="store_true", help="skip the default-mesh cost table")
    args = ap.parse_args()
    accuracy_table(args.levels, args.tensor_levels, args.max_gb, args.growth,
                   tuple(args.scan_growths), args.ratio_pairs)
    if not args.no_cost:
        print()
        cost_table()


if __name__ == "__main__":
    main()
