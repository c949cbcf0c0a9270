"""Timing and accuracy table of the analytic normal solver (issue 2, "Performance").

Run: ``python benchmarks/bench_analytic.py``. Times are the best of REPEATS wall-clock runs
(single-threaded BLAS; the analytic solves and the BEM get the same number of runs, the load
curve and the cycle three): on a shared 2-core VM single runs scatter by +-30 %, the best of many
is the reproducible figure. Rows and targets:

- n = 2, all edges nonsingular: Gladwell's bi-quadratic punch at half its merging load, edge
  error against the closed form (``a^2 + b^2 = 2 c^2``, ``P = pi (b^2-a^2)^2 / (16 A R c^2)``)
  relative to the zone width; target <= 5 ms at <= 1e-10.
- n = 3: three rigidly connected cylinders with unequal lifts (no closed form: the scaled
  residual of the solved equations is shown); target <= 15 ms.
- a 200-point load curve of the bi-quadratic punch (0.5 % .. 99 % of the merging load);
  target <= 0.5 s.
- the n = 2 case by the discretised check ``compare.bem`` at N = 1024 (time, edge error) and the
  ratios; target: analytic >= 20x faster and >= 1000x more accurate.
- a stick cycle ``analytic.cycle(normal, mu, Q0, n=100)`` on the n = 2 case; target <= 0.5 s.
- the a-posteriori self-check (:mod:`analytic.selfcheck`, run inside every solve above) alone on
  the n = 2 and n = 3 solutions, as a fraction of the solve without it; target <= +25 %.

Every row prints the measured number and PASS/MISS against its target.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # threaded BLAS on 2 cores is 30-100x slower

import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

import analytic  # noqa: E402
from analytic import profiles  # noqa: E402
from analytic.selfcheck import check_normal  # noqa: E402
from compare.bem import solve_normal_bem  # noqa: E402

A, C, R = 1.0, 1.0, 1.0
P_MERGE = np.pi * C**2 / (4 * A * R)
P2 = 0.5 * P_MERGE
REPEATS = 20
ERROR_FLOOR = 1e-16
"""Floor of the analytic edge error in the accuracy ratio (it can round to exactly 0)."""


def best_time(fn: Callable[[], object], repeats: int = REPEATS) -> float:
    """Best wall time of ``repeats`` calls [s]."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def gladwell_edges(P: float) -> np.ndarray:
    """Exact ``[-b, -a, a, b]``: ``P = pi (c^2 - a^2)^2 / (4 A R c^2)``, ``a^2 + b^2 = 2c^2``."""
    a2 = C**2 - np.sqrt(4 * A * R * C**2 * P / np.pi)
    a, b = np.sqrt(a2), np.sqrt(2 * C**2 - a2)
    return np.array([-b, -a, a, b])


def edge_error(zones, exact: np.ndarray) -> float:
    """Max edge error relative to the zone width."""
    return float(np.max(np.abs(np.ravel(zones) - exact)) / (exact[3] - exact[2]))


def three_cylinders() -> profiles.Profile:
    return profiles.union(profiles.cylinder(1.0, center=-1.5),
                          profiles.cylinder(0.5, center=0.2, lift=0.01),
                          profiles.cylinder(2.0, center=1.8, lift=0.03))


def selfcheck_of(sol: analytic.NormalSolution) -> None:
    """The a-posteriori check that every solve runs (:func:`analytic.selfcheck.check_normal`)."""
    check_normal(sol.profile, sol.zones, sol.singular, sol.zone_loads, sol.P, None, sol.theta,
                 sol.A, sol.pressure)


def verdict(ok: bool) -> str:
    return "PASS" if ok else "MISS"


def rows() -> list[tuple[str, str, str, str]]:
    prof2 = profiles.biquadratic(C, R)
    exact = gladwell_edges(P2)
    t2 = best_time(lambda: analytic.solve_normal(prof2, P2, A))
    sol2 = analytic.solve_normal(prof2, P2, A)
    err2 = edge_error(sol2.zones, exact)
    out = [("solve n=2 (biquadratic, nonsingular)", f"{1e3 * t2:9.2f} ms, edge err {err2:.1e}",
            "<= 5 ms, <= 1e-10", verdict(t2 <= 5e-3 and err2 <= 1e-10))]

    prof3 = three_cylinders()
    t3 = best_time(lambda: analytic.solve_normal(prof3, 0.5, A))
    sol3 = analytic.solve_normal(prof3, 0.5, A)
    res3 = sol3.residuals["equations"]
    out.append(("solve n=3 (three cylinders)", f"{1e3 * t3:9.2f} ms, residual {res3:.1e}",
                "<= 15 ms", verdict(t3 <= 15e-3)))

    c2, c3 = best_time(lambda: selfcheck_of(sol2)), best_time(lambda: selfcheck_of(sol3))
    g2, g3 = c2 / (t2 - c2), c3 / (t3 - c3)
    out.append(("self-check (in every solve), n=2 / n=3",
                f"{1e3 * c2:.2f} / {1e3 * c3:.2f} ms, +{g2:.0%} / +{g3:.0%} of the solve",
                "<= +25 %", verdict(g2 <= 0.25 and g3 <= 0.25)))

    loads = np.linspace(0.005, 0.99, 200) * P_MERGE
    tc = best_time(lambda: analytic.load_curve(prof2, loads, A), repeats=3)
    curve = analytic.load_curve(prof2, loads, A)
    errc = max(edge_error(s.zones, gladwell_edges(P)) for s, P in zip(curve, loads, strict=True))
    out.append(("load curve, 200 points (n=2)", f"{tc:9.3f} s, max edge err {errc:.1e}",
                "<= 0.5 s", verdict(tc <= 0.5)))

    tb = best_time(lambda: solve_normal_bem(prof2.h0, (-2.0, 2.0), 1024, P2, A))
    bem = solve_normal_bem(prof2.h0, (-2.0, 2.0), 1024, P2, A)
    errb = edge_error(bem.zones, exact)
    speed, accuracy = tb / t2, errb / max(err2, ERROR_FLOOR)
    out.append(("compare.bem N=1024, same n=2 case", f"{1e3 * tb:9.2f} ms, edge err {errb:.1e}",
                "reference", ""))
    out.append(("ratio bem/analytic: time", f"{speed:9.1f} x", ">= 20 x", verdict(speed >= 20)))
    out.append(("ratio bem/analytic: edge error", f"{accuracy:9.1e} x", ">= 1000 x",
                verdict(accuracy >= 1000)))

    if hasattr(analytic, "cycle"):
        mu = 0.3
        tcy = best_time(lambda: analytic.cycle(sol2, mu, 0.5 * mu * P2, n=100), repeats=3)
        out.append(("stick cycle n=100 (n=2, Q0 = mu P / 2)", f"{tcy:9.3f} s", "<= 0.5 s",
                    verdict(tcy <= 0.5)))
    else:
        out.append(("stick cycle n=100", "analytic.cycle not available", "<= 0.5 s", "n/a"))
    return out


def main() -> None:
    table = rows()
    widths = [max(len(r[i]) for r in table) for i in range(4)]
    head = ("case", "measured", "target", "")
    print("  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)))
    print("  ".join("-" * w for w in widths))
    for r in table:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)))


if __name__ == "__main__":
    main()
