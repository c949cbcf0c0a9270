"""Tabulated (C^2 spline) profiles solved to the accuracy of analytic ones (issue 29, item 3).

A cubic spline's third derivative jumps at every knot, so a Gauss rule across knots converges
only algebraically.  The solver's zone rule now cuts at the knots and its gap integrals continue
the edge interval's cubic (not the spline) beyond the edge.  Each case is judged by the audit's
independent quadratures of the returned pressure (``compare.audit.checks``), which cut at the
knots too.  Before the fix (same quadratures): int p off P by up to 6.5e-8, the rigid approach
spread by 7e-8 A P, gap(x) off by 4e-8 A P on audit seeds (seed 100467 was an open audit
regression); the two-cylinder spline of 301 samples was refused at P = 0.02 and 0.05
(approach 4e-5 and 0.05 A P) and its gap(x) was 3.6e-3 off at P = 1e-3.
"""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import profiles
from compare.audit import checks
from compare.audit.cases import make_case

LOAD_TOL = 1e-12
"""|int p - zone load| / P and |sum - P| / P, |int x p - M| / (P span) (measured <= 3.4e-13 on
110 tabulated audit seeds and the two-cylinder spline; analytic profiles reach ~1e-13)."""
RIGID_TOL = 3e-9
"""Spread of the rigid approach / (A P) (measured <= 3.0e-10 on the same cases)."""
GAP_TOL = 3e-9
"""|returned gap - recomputed gap| / (A P + |gap|) and -min gap / (A P) (measured <= 2.0e-10)."""
KINKED_LOAD_TOL = 2e-10
"""LOAD_TOL for a spline with a kink in or next to the zone (p log-singular there; measured
1.9e-11 with the edge 2.8e-3 past the kink, as on analytic wedges)."""

TOLERANCES = {"load_quadrature": LOAD_TOL, "moment_quadrature": LOAD_TOL,
              "rigid_approach": RIGID_TOL, "gap_negative": GAP_TOL, "gap_consistency": GAP_TOL,
              "pressure_negative": 0.0}


def two_cylinder_spline() -> profiles.Profile:
    """The issue's kind of table: two cylinders (R 0.7 at -0.8, R 1.2 at 0.9 lifted 0.01)
    sampled at 301 points on [-2, 2] and splined through their crossing."""
    x = np.linspace(-2.0, 2.0, 301)
    h = np.minimum((x + 0.8) ** 2 / (2 * 0.7), (x - 0.9) ** 2 / (2 * 1.2) + 0.01)
    return profiles.tabulated(x, h)


def _assert_precise(sol: analytic.NormalSolution, load_tol: float = LOAD_TOL) -> None:
    tol = {**TOLERANCES, "load_quadrature": load_tol, "moment_quadrature": load_tol}
    bad = [f.line() for f in checks.quadrature_findings(sol) if not f.value <= tol[f.check]]
    assert not bad, "\n".join(bad)


def test_spline_profiles_report_their_knots() -> None:
    prof = two_cylinder_spline()
    assert len(prof.knots) == 299
    pc = prof.pieces[0]
    x = np.linspace(-1.99, 1.99, 997)
    for f in ("h", "dh", "d2h"):
        local = np.array([getattr(pc.analytic_at(v), f)(np.array([v]))[0] for v in x])
        assert np.allclose(local, getattr(pc, f)(x), rtol=1e-13, atol=1e-13)
    assert profiles.cylinder(1.0).knots == ()


@pytest.mark.parametrize(("P", "M"), [(1e-3, None),
                                      pytest.param(0.02, 0.0, marks=pytest.mark.slow)],
                         ids=["one_zone", "two_zones_moment"])
def test_two_cylinder_spline_is_precise(P: float, M: float | None) -> None:
    sol = analytic.solve_normal(two_cylinder_spline(), P, 1.0, M)
    assert sol.n_zones == (1 if P < 0.01 else 2)
    _assert_precise(sol)


def kinked_spline() -> profiles.Profile:
    """``0.1 |x - 0.3| + 0.2 x^2`` at 81 points on [-2, 2] with its kink at the sample 0.3."""
    x = np.linspace(-2.0, 2.0, 81)
    return profiles.tabulated(x, 0.1 * np.abs(x - 0.3) + 0.2 * x * x, kinks=[0.3])


@pytest.mark.parametrize(("P", "M"), [(0.01, None), (0.05, 0.01)], ids=["edge_past_kink", "moment"])
def test_kinked_spline_is_precise(P: float, M: float | None) -> None:
    """A zone ending 2.8e-3 past the kink, and one spanning it in moment mode: refused before
    (int p off P by 1.2e-6 and 3.4e-6 > the spline tolerance 1e-6; at P = 0.2 it was returned
    1.6e-6 off, the issue's symptom).  The points near the kink get their graded rule on the
    pieces between the kink and its neighbouring knots (the zone rule's own cuts)."""
    sol = analytic.solve_normal(kinked_spline(), P, 1.0, M)
    assert sol.n_zones == 1
    _assert_precise(sol, KINKED_LOAD_TOL)


@pytest.mark.parametrize("seed", [100467, 360, 229, 28])
def test_tabulated_audit_seeds_are_precise(seed: int) -> None:
    """The worst tabulated seeds before the fix (int p off P by 3.7e-8, 6.5e-8, 4.8e-8 and
    3.6e-8; seed 100467 disagreed in the audit of seeds 100000-100999)."""
    case = make_case(seed)
    _assert_precise(analytic.solve_normal(case.profile, case.P, case.A, case.M))
