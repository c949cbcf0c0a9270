"""Two contact zones either side of a notch of the surface (a ridge of h0: a concave kink of a
union, here where a rounded flat punch's profile meets a cylinder's).

A zone cannot span the ridge: its pressure would be -log-singular there.  Two zones either side
of it are separated by a gap that closes only where that log term would cross zero, i.e.
exponentially in the load (audit seed 103644: 1.7e-4 at P = 0.3, 2.7e-5 at P = 0.4629).  The
solver of 43cdcfa pinned one edge at the ridge with a negative stress intensity (p < 0 only
within 1e-6 of it, between the admissibility check's Chebyshev points), and the vertical solve
at P = 0.4629 was refused by the self-check (min p = -46 times the mean).

These checks use the solver's equations only through Newton's converged states; what they assert
is read off the pressure and the profile (the sign of p next to the edge, the ridge between the
edges, p >= 0 and the loads by the audit's own quadrature).
"""

from __future__ import annotations

import numpy as np
import pytest

from analytic import _admissibility, _continuation, _newton, _topology
from analytic._sie import Layout, System
from analytic.normal import _finish
from compare.audit import cases, checks
from compare.audit import quadrature as qd

P_CASE = 0.4628637282003999
RIDGE = 2.2304209731041116
PINNED_EDGES = (-0.9826836582909562, 0.9660741113822995, 1.9434477262098586, 2.0044388692387587,
                2.005300210668267, RIDGE, 2.230430969654612, 2.6562862417661126)
"""The state the solver of 43cdcfa returned at P_CASE (edge 5 pinned at the ridge)."""
P_LOWER = 0.395209
LOWER = (-0.977416824, 0.962720466, 1.968005950, 2.003521880, 2.006079139, 2.230393284,
         2.230448725, 2.618740484)
"""Edges near the state the continuation reaches at P_LOWER (gap 5.5e-5 at the ridge)."""
FREE_EDGES = (-0.9826836580837769, 0.9660741107577184, 1.9434477212711379, 2.004438869321713,
              2.0053002105921247, 2.230407402646958, 2.2304345597663646, 2.656286244816182)
"""The solution at P_CASE: four free-edged zones, 2.7e-5 apart at the ridge."""


@pytest.fixture(scope="module")
def case():
    return cases.make_case(103644)


def _solved(profile, edges, pinned, P):
    st = _newton.fresh_state(Layout(np.array(edges), np.array(pinned)), 0.0, P)
    st.beta = _newton.beta_for(st, 1.0, P)
    st, F = _newton.newton(_continuation._recentre(st), _newton.Mode(P, None), profile, 1.0)
    return st, F, System.build(st.layout, profile, 1.0, st.theta, st.xc, st.beta)


def test_edge_pinned_with_negative_intensity_is_released(case) -> None:
    """The equations hold on the old state, but p < 0 just inside its pinned edge, growing like
    d^(-1/2) (a negative stress intensity): admissibility now asks that edge to release."""
    pinned = [e == RIDGE for e in PINNED_EDGES]
    st, F, sys_ = _solved(case.profile, PINNED_EDGES, pinned, P_CASE)
    assert np.max(np.abs(F)) < 1e-9
    d = np.array([1e-12, 1e-10, 1e-8])
    k = sys_.pressure_inside(RIDGE - d) * np.sqrt(d)
    assert np.all(k < 0) and np.ptp(k) < 0.01 * abs(k[0])
    ev = _admissibility.find_event(st, sys_, case.profile, 1.0)
    assert ev is not None and ev.kind == "release" and ev.where == RIDGE


def test_released_notch_edge_converges_beside_the_ridge(case) -> None:
    """Released, the edge starts as far from the ridge as the facing edge across it (not 2 % of
    its zone away), and Newton converges from there to an admissible state, every edge free,
    the ridge in a gap below 1e-4."""
    pinned = [e == RIDGE for e in PINNED_EDGES]
    st, _, sys_ = _solved(case.profile, PINNED_EDGES, pinned, P_CASE)
    ev = _admissibility.find_event(st, sys_, case.profile, 1.0)
    new = _topology.apply_event(st, ev, sys_, case.profile)
    e = new.layout.edges
    assert not new.layout.pinned.any()
    assert RIDGE - e[5] == pytest.approx(e[6] - RIDGE, rel=1e-6)
    st, F, sys_ = _solved(case.profile, e, [False] * 8, P_CASE)
    assert np.max(np.abs(F)) < 1e-9
    e = st.layout.edges
    assert e[5] < RIDGE < e[6] and e[6] - e[5] < 1e-4
    assert _admissibility.find_event(st, sys_, case.profile, 1.0) is None


def test_notch_edges_are_solved_in_log_distance(case) -> None:
    """Both edges of each narrow gap at a ridge (5.5e-5 at 2.2304 between zones ~0.2 wide;
    2.6e-3 at 2.0049 beside a zone 0.036 wide: 0.07 of it) are unknowns ``ln(d / ell)``, packed
    and unpacked to the same x; the wide gap between the punch and the cylinders is not."""
    st = _newton.fresh_state(Layout(np.array(LOWER), np.zeros(8, bool)), 0.0, P_LOWER)
    mode = _newton.Mode(P_LOWER, None)
    notches = _newton.notch_edges(st, mode, case.profile)
    ridge = case.profile.ridges[2]
    assert notches == ((3, ridge, -1.0), (4, ridge, 1.0), (5, RIDGE, -1.0), (6, RIDGE, 1.0))
    mode = _newton.Mode(P_LOWER, None, notches=notches)
    z = _newton._pack(st, mode)
    assert z[5] == pytest.approx(np.log((RIDGE - LOWER[5]) / st.ell), rel=1e-12)
    back = _newton._unpack(z, st, mode, 1.0).layout.edges
    assert np.all(np.abs(back - np.array(LOWER)) <= 4 * np.spacing(np.abs(back)))


def test_continuation_reaches_the_load_beyond_the_notch(case) -> None:
    """From the state at P_LOWER the continuation reaches P_CASE with four zones, every edge
    free, the ridge between the two middle-right zones (their gap 2.7e-5); the pressure passes
    the audit's independent quadratures (loads, moment, rigid approach, p >= 0, g >= 0)."""
    st = _newton.fresh_state(Layout(np.array(LOWER), np.zeros(8, bool)), 0.0, P_LOWER)
    st.beta = _newton.beta_for(st, 1.0, P_LOWER)
    st, _ = _continuation.converge(st, case.profile, 1.0, None)
    st, sys_, _ = _continuation.continue_to(st, P_CASE, case.profile, 1.0)
    e = st.layout.edges
    assert st.layout.n == 4 and not st.layout.pinned.any()
    assert e[5] < RIDGE < e[6] and e[6] - e[5] < 1e-4
    assert e[3] < case.profile.ridges[2] < e[4]
    sol = _finish(st, sys_, case.profile, 1.0, "vertical")
    found = checks.quadrature_findings(sol)
    assert found and not [f.line() for f in found if f.failed]


def test_gap_far_from_the_contact_matches_the_log_kernel(case) -> None:
    """``gap(x)`` out to two spans beyond the contact against ``h0 + u - delta`` with u the
    log-kernel integral of the returned pressure (the audit's quadrature): within 1e-8 A P plus
    1e-9 of g.  Before the fix g(-8.26) = 41.89481 against 41.89430 (1.1e-3 A P): the gap
    integral subtracted h' in B out to the target, and ``H int omega/(s - x)`` carried the
    zone rule's error in the moments of omega (zones 2.7e-5 apart) times ``|W| ~ x^4``."""
    st, F, sys_ = _solved(case.profile, FREE_EDGES, [False] * 8, P_CASE)
    assert np.max(np.abs(F)) < 1e-9
    sol = _finish(st, sys_, case.profile, 1.0, "vertical")
    span = FREE_EDGES[-1] - FREE_EDGES[0]
    x = np.concatenate([FREE_EDGES[0] - span * np.array([0.3, 1.0, 2.0]),
                        FREE_EDGES[-1] + span * np.array([0.3, 1.0, 2.0])])
    _, _, delta, _, rule_p = checks._quadrature_run(sol, 0.5 * qd.STEP)
    ref = checks._recomputed_gap(sol, rule_p, delta, x)
    AP = sol.A * sol.P
    assert np.all(np.abs(sol.gap(x) - ref) < 1e-8 * AP + 1e-9 * np.abs(ref))
    assert min(ref) > 0.5  # far from the contact: g from 0.7 to 42
