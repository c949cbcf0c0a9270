"""FE cost benchmark (issue 4): Hertz and double wedge on the default mesh.

Prints DOFs, assembly time, one plain factorisation + solve (reference), the whole
three-stage history (>= 40 increments) and the ratio history / (factorisation + solve).
Targets: ratio <= 5, whole default Hertz history <= 20 s on 2 cores.
Run: OPENBLAS_NUM_THREADS=1 python benchmarks/bench_fem.py
"""

from __future__ import annotations

import time

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


def main() -> None:
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


if __name__ == "__main__":
    main()
