"""Timing and accuracy table of ``analytic.stress`` (issue 17, "Performance").

Run: ``python benchmarks/bench_stress.py``.  Times are the best of REPEATS wall-clock runs
(single-threaded BLAS; single runs on the shared 2-core VM scatter by +-30 %).  Rows:

- ``stress`` on a 200 x 100 grid (the contact span plus a quarter on each side, down to 0.75
  of it) for a two-zone stage-2 stick solution (two cylinders with unequal lifts, four stick
  edges, six sub-intervals); target <= 0.5 s.
- the same grid for Hertz under Cattaneo loading, with the largest error against the closed
  form (McEwen + Smith & Liu by superposition) relative to p0 (accuracy, no target: the
  verification tests bound it).
- ``surface_stress`` at 2000 points of the two-zone solution (no target).

Every row prints the measured number and PASS/MISS against its target.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # threaded BLAS on 2 cores is 30-100x slower

import numpy as np  # noqa: E402
from bench_analytic import best_time  # noqa: E402  (run as a script: benchmarks/ on the path)

import analytic  # noqa: E402
from analytic import profiles  # noqa: E402

A, P, MU, NU = 4 * (1 - 0.3**2) / 210e3, 100.0, 0.3, 0.3
REPEATS = 10
TARGET_GRID = 0.5
"""Seconds allowed for the 200 x 100 grid of a two-zone stick solution (issue 17)."""


def grid(sol) -> tuple[np.ndarray, np.ndarray]:
    """200 x 100 points: the contact span + 25 % each side, depth 0.75 of the span."""
    zones = sol.normal.zones
    lo, hi = zones[0][0], zones[-1][1]
    w = hi - lo
    return np.meshgrid(np.linspace(lo - 0.25 * w, hi + 0.25 * w, 200),
                       np.linspace(-0.75 * w, 0.0, 100))


def two_zone_state():
    punch = profiles.union(profiles.cylinder(R=10.0, center=-1.0),
                           profiles.cylinder(R=10.0, center=1.0, lift=5e-4))
    normal = analytic.solve_normal(punch, P=P, A=A)
    return analytic.solve_stick(normal, MU, 0.45 * MU * P)


def hertz_error() -> float:
    """Max |stress - closed form| / p0 on the benchmark grid of a Cattaneo state."""
    normal = analytic.solve_normal(profiles.cylinder(R=10.0), P=P, A=A)
    a = normal.zones[0][1]
    p0 = 2 * P / (np.pi * a)
    st = analytic.solve_stick(normal, MU, 0.5 * MU * P)
    c = a * np.sqrt(0.5)
    X, Y = grid(st)
    Z = np.maximum(-Y, 1e-12 * a)
    f = analytic.stress(st, X, -Z, nu=NU)

    def field(half, amp, shear):
        m_n = np.sqrt((half**2 - X**2 + Z**2) + 2j * X * Z)
        m, n = m_n.real, m_n.imag
        r = m * m + n * n
        if not shear:
            return np.array([-(amp / half) * (m * (1 + (Z**2 + n * n) / r) - 2 * Z),
                             -(amp / half) * m * (1 - (Z**2 + n * n) / r),
                             (amp / half) * n * (m * m - Z**2) / r])
        return np.array([(amp / half) * (n * (2 - (Z**2 - m * m) / r) - 2 * X),
                         -(amp / half) * n * (m * m - Z**2) / r,
                         (amp / half) * (m * (1 + (Z**2 + n * n) / r) - 2 * Z)])

    ref = field(a, p0, False) + field(a, MU * p0, True) - field(c, MU * p0 * c / a, True)
    return float(np.max(np.abs(np.array([f.sxx, f.syy, f.sxy]) - ref)) / p0)


def main() -> None:
    st = two_zone_state()
    X, Y = grid(st)
    t_grid = best_time(lambda: analytic.stress(st, X, Y, nu=NU), REPEATS)
    xs = np.linspace(st.normal.zones[0][0], st.normal.zones[-1][1], 2000)
    t_surf = best_time(lambda: analytic.surface_stress(st, xs), REPEATS)
    err = hertz_error()
    print(f"{'row':<52} {'value':>12} {'target':>10}  verdict")
    print(f"{'stress, 200 x 100 grid, two-zone stick state [s]':<52} {t_grid:>12.4f} "
          f"{TARGET_GRID:>10.2f}  {'PASS' if t_grid <= TARGET_GRID else 'MISS'}")
    print(f"{'surface_stress, 2000 points, two-zone [s]':<52} {t_surf:>12.4f} {'-':>10}")
    print(f"{'Cattaneo grid: max error / p0 vs closed form':<52} {err:>12.2e} {'-':>10}")


if __name__ == "__main__":
    main()
