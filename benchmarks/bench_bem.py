"""Timing table of the discretised check solver ``compare.bem`` (best of 3 runs).

Run: ``python benchmarks/bench_bem.py``. Target: an N = 1024 normal solve well under 1 s.
Cases: Hertz (vertical indentation), two cylinders with unequal lift (2 zones), the same
in applied-moment mode, and the Cattaneo-Mindlin stages 2 and 3 on the Hertz contact.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # threaded BLAS on 2 cores is 30-100x slower

import time  # noqa: E402
from collections.abc import Callable  # noqa: E402

import numpy as np  # noqa: E402

from compare import bem, bem_tangential  # noqa: E402

A, R, P, MU = 1.0, 1.0, 0.5, 0.3
A_HERTZ = np.sqrt(2 * A * P * R / np.pi)
REPEATS = 3


def best_time(fn: Callable[[], object]) -> float:
    """Best wall time of REPEATS calls [ms]."""
    times = []
    for _ in range(REPEATS):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * min(times)


def hertz(x: np.ndarray) -> np.ndarray:
    return x**2 / (2 * R)


def two_cylinders(x: np.ndarray) -> np.ndarray:
    return np.minimum((x + 1) ** 2 / 2, (x - 1.2) ** 2 + 0.02)


def row(n: int) -> tuple[float, ...]:
    window = (-1.5 * A_HERTZ, 1.5 * A_HERTZ)
    normal = bem.solve_normal_bem(hertz, window, n, P, A)
    stage2 = bem_tangential.solve_tangential_bem(normal, MU, 0.5 * MU * P)
    edge_err = abs(normal.zones[0][1] - A_HERTZ) / normal.dx
    return (
        best_time(lambda: bem.solve_normal_bem(hertz, window, n, P, A)),
        best_time(lambda: bem.solve_normal_bem(two_cylinders, (-2.5, 2.5), n, 0.2, A)),
        best_time(lambda: bem.solve_normal_bem(two_cylinders, (-2.5, 2.5), n, 0.3, A,
                                               M=-0.05)),
        best_time(lambda: bem_tangential.solve_tangential_bem(normal, MU, 0.5 * MU * P)),
        best_time(lambda: bem_tangential.solve_tangential_bem(normal, MU, -0.5 * MU * P,
                                                   q_start=stage2.q, Q_start=0.5 * MU * P)),
        edge_err,
    )


def main() -> None:
    header = ("N", "hertz ms", "2cyl ms", "2cyl+M ms", "stage2 ms", "stage3 ms", "edge err/dx")
    print(" ".join(f"{h:>11}" for h in header))
    for n in (128, 256, 512, 1024, 2048):
        values = row(n)
        print(f"{n:>11d} " + " ".join(f"{v:>11.2f}" for v in values[:-1])
              + f" {values[-1]:>11.4f}")


if __name__ == "__main__":
    main()
