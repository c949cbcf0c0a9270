"""Hertz cylinder-on-flat (stage 1) against the plane-strain closed form.

Closed form (Johnson, Contact Mechanics, 1985, Sec. 5.5; docs/conventions.md, p >= 0):
half-width ``a = sqrt(2 A P R / pi)``, peak pressure ``p0 = a / (A R)``,
``p(x) = p0 sqrt(1 - x^2/a^2)``, ``A = 4 (1 - nu^2) / E``.
"""

import functools

import numpy as np
import pytest

import fem

E, NU, R, P, MU = 1.0, 0.3, 100.0, 0.01, 0.5
A = 4 * (1 - NU**2) / E
A_HERTZ = np.sqrt(2 * A * P * R / np.pi)
P0_HERTZ = A_HERTZ / (A * R)
WINDOW = (-1.3 * A_HERTZ, 1.3 * A_HERTZ)
#: Issue 4: FE half-width on the default mesh within 1 % of the closed form.
WIDTH_TOL = 0.01
#: Interior of the zone (fraction of a) for the convergence of the pressure error.
INTERIOR = 0.9


def hertz_gap(x):
    """Cylinder gap h0 = x^2 / (2R)."""
    return x**2 / (2 * R)


def hertz_pressure(x):
    """p(x) = p0 sqrt(1 - x^2/a^2) inside, 0 outside."""
    return P0_HERTZ * np.sqrt(np.clip(1 - (x / A_HERTZ) ** 2, 0.0, None))


def solve(level=1, order=1, **mesh_kw):
    """Stage 1 only on a mesh of the given level / order (computed once per session: level 1,
    order 1 serves test_hertz_width_default_mesh[1] and test_hertz_converges_under_refinement,
    which only read it)."""
    return _solve(level, order, tuple(sorted(mesh_kw.items())))


@functools.cache
def _solve(level: int, order: int, mesh_kw: tuple) -> fem.FemHistory:
    mesh_kw = dict(mesh_kw)
    return fem.solve_history(
        hertz_gap,
        P,
        0.0,
        MU,
        E,
        NU,
        window=WINDOW,
        mesh=fem.MeshSpec(level=level, order=order, **mesh_kw),
        increments=fem.LoadPath(n_normal=4),
    )


def pressure_l2(step, inside: float = np.inf) -> float:
    """Relative L2 (tributary-weighted) pressure error over |x| < inside * a."""
    f = step.interface
    pex = hertz_pressure(f.x)
    m = np.abs(f.x) < inside * A_HERTZ
    return float(np.sqrt(np.sum((f.w * (f.p - pex) ** 2)[m]) / np.sum(f.w * pex**2)))


@pytest.mark.parametrize("order", [1, 2])
def test_hertz_width_default_mesh(order):
    h = solve(order=order) if order == 2 else solve()
    s = h.steps[-1]
    ((a, b),) = s.contact_zones
    err = max(abs(b - A_HERTZ), abs(-a - A_HERTZ)) / A_HERTZ
    print(f"Q{order}: a_fem/a - 1 = {b / A_HERTZ - 1:+.2e}, pressure L2 error {pressure_l2(s):.2e}")
    assert err < WIDTH_TOL
    assert pressure_l2(s) < 0.02
    assert abs(np.sum(s.interface.p * s.interface.w) - P) < 1e-9 * P
    assert np.all(s.interface.p >= 0)
    assert np.all(s.interface.gap[s.interface.status == 0] >= 0)


def test_hertz_converges_under_refinement():
    """Pressure L2 error away from the edges decreases, edge error stays within half an
    element.  (The node next to an edge carries a phase-dependent error: at level 2 one node
    0.0005 a outside the edge holds 99 % of the full L2 error, which then rises.)"""
    errs, hs = [], []
    for level in (0, 1, 2):
        h = solve(level=level)
        s = h.steps[-1]
        errs.append(pressure_l2(s, inside=INTERIOR))
        hs.append(h.h_min)
        edge_err = abs(s.contact_zones[0][1] - A_HERTZ)
        assert edge_err < 0.6 * h.h_min
    print(f"pressure L2 errors {errs}")
    assert errs[2] < errs[1] < errs[0]


#: Window half-width and fine margin that put a node exactly on x = +-a at every level: the fine
#: nodes are -1.25 c + k c / (24 2**level), and a = 0.75 c is one of them.
EDGE_ON_NODE_WINDOW = (-A_HERTZ / 0.75, A_HERTZ / 0.75)
EDGE_ON_NODE_MARGIN = 0.125
#: Observed order of the whole-zone pressure L2 error with the edge on a node, levels 1-3: theory
#: 1 (the nodal error of the sqrt edge's element, ~p0 sqrt(h/a) over a length h, dominates);
#: measured 0.99 (errors 1.06e-2, 5.28e-3, 2.69e-3).
FULL_ORDER_MIN = 0.9
#: ... and of the interior (|x| < INTERIOR a) error: measured 1.39 (2.30e-4, 9.52e-5, 3.34e-5).
INTERIOR_ORDER_MIN = 1.0


@pytest.mark.slow
def test_hertz_observed_order():
    """Observed orders of the pressure L2 error over levels 1-3, with the contact edge held on a
    node at every level.  On the default window the edge falls at a different place inside its
    element at each level, and the whole-zone error, dominated by the one or two nodes next to
    the edge, swings with that phase: 2.87e-3, 4.42e-3, 1.90e-3 at levels 1-3 (an apparent order
    0.30), while error / (h/a) stays within 0.06-0.33 over levels 0-4.  Holding the phase fixed
    measures the order itself."""
    full, interior = [], []
    for level in (1, 2, 3):
        mesh = fem.MeshSpec(level=level, margin=EDGE_ON_NODE_MARGIN)
        s = fem.solve_history(hertz_gap, P, 0.0, MU, E, NU, window=EDGE_ON_NODE_WINDOW, mesh=mesh,
                              increments=fem.LoadPath(n_normal=4)).steps[-1]
        assert np.min(np.abs(s.interface.x - A_HERTZ)) < 1e-12 * A_HERTZ  # the edge is a node
        full.append(pressure_l2(s))
        interior.append(pressure_l2(s, inside=INTERIOR))
    orders = [np.log2(e[0] / e[2]) / 2 for e in (full, interior)]
    print(f"pressure L2 errors {full} (interior {interior}), observed orders {orders}")
    assert orders[0] > FULL_ORDER_MIN
    assert orders[1] > INTERIOR_ORDER_MIN


@pytest.mark.slow
def test_hertz_finite_size():
    """Finite-body error: width from the second pressure moment vs W = H."""

    def width(sf):
        s = solve(level=1, size_factor=sf).steps[-1]
        f = s.interface
        return 2 * np.sqrt(np.sum(f.w * f.p * f.x**2) / P)

    w25, w100 = width(25.0), width(100.0)
    print(f"moment widths / a: W=25: {w25 / A_HERTZ:.5f}, W=100: {w100 / A_HERTZ:.5f}")
    assert abs(w25 - w100) / A_HERTZ < 0.003
