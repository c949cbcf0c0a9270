"""The end of a circular corner as a topology event (issue 18).

A flat punch with quarter-circle corners (face [-1, 1], radius 0.5) has ``h0 = +inf`` beyond
x = +-1.5, where the arcs end.  Under increasing load the contact edges run out along the arcs;
the arc's slope ``d^(-1/2)`` just beyond a free edge makes its load grow only like -ln d, so the
edges approach the ends logarithmically (checked against an independent quadrature of the
bounded solution's load) and pin there once d is below resolution; beyond, they stay there as
singular edges (complete contact, ``Profile.corners`` holds the arc ends).  Checks: the
approach, the pinned states obey the flat-punch closed form for load increments (exact for fixed
edges), tend to the sharp punch of half-width 1.5 as P grows, agree with the BEM, and an edge is
released again where the tilt unloads it.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

import analytic
from analytic import profiles
from compare.audit import checks
from compare.bem import solve_normal_bem

A = 1.0
B = 1.5  # x of the arcs' ends: half-width of the complete contact
X = np.linspace(-1.49, 1.49, 299)  # includes the kinks +-1 (face meets arc) to rounding
#: Load increments at fixed (singular) edges are the flat-punch closed form, up to rounding.
LINEAR_RTOL = 1e-10
#: The BEM on 600 panels (dx = 5.3e-3) differs from the analytic pressure by 0.41 % of its
#: maximum on |x| < 1.3 (0.29 % on 1200 panels): first order in dx near singular edges.
BEM_PRESSURE_REL = 0.01
#: The free edges' loads against an adaptive quadrature of the bounded-solution load (quad's own
#: accuracy ~1e-9; the Gauss-Jacobi rule unresolved at the arc's end was 6 % off).
BOUNDED_LOAD_RTOL = 1e-7


@pytest.fixture(scope="module")
def punch() -> profiles.Profile:
    return profiles.flat_punch(-1.0, 1.0, corner_radius=0.5)


def sharp(P: float, x: np.ndarray) -> np.ndarray:
    """Flat punch of half-width B: ``p = P / (pi sqrt(B^2 - x^2))`` (Johnson, Contact Mechanics,
    Eq. 2.64)."""
    return P / (np.pi * np.sqrt(B * B - x * x))


def test_arc_ends_are_corners(punch) -> None:
    assert punch.corners == (-B, B) and punch.kinks == (-1.0, 1.0)
    assert profiles.flat_punch(-1.0, 1.0, corner_radius=0.5, corner_shape="parabolic").corners \
        == ()


def test_complete_contact_at_P20_and_beyond(punch) -> None:
    for P in (20.0, 1e3):
        sol = analytic.solve_normal(punch, P, A)
        assert sol.zones == [(-B, B)] and sol.singular == [(True, True)]
        assert sol.residuals["equilibrium"] < 1e-12 and sol.residuals["min_pressure"] > 0
        p = sol.pressure(X)
        assert np.all(np.isfinite(p)) and np.all(p > 0)


def test_load_increment_is_the_flat_punch_closed_form(punch) -> None:
    p20, p30 = (analytic.solve_normal(punch, P, A).pressure(X) for P in (20.0, 30.0))
    ref = sharp(10.0, X)
    assert np.max(np.abs(p30 - p20 - ref)) <= LINEAR_RTOL * ref.max()


def test_sharp_punch_limit(punch) -> None:
    """p / P -> the sharp punch of half-width B; the rest (the arcs' share) does not grow with P,
    so the relative difference falls as 1/P."""
    dev = {P: np.max(np.abs(analytic.solve_normal(punch, P, A).pressure(X) / P
                            - sharp(1.0, X))) * np.pi * B for P in (1e3, 1e6)}
    assert dev[1e6] < 1e-4
    assert dev[1e3] / dev[1e6] == pytest.approx(1e3, rel=1e-6)


def bounded_load(a: float) -> float:
    """P of the symmetric solution bounded at both edges +-a (independent of the solver):
    ``P = (2/A) int_0^(pi/2) a sin(phi) h0'(a sin(phi)) dphi`` (from ``p(+-a) = 0`` in the
    inversion of Johnson, Contact Mechanics, Eq. 2.41; Hertz: ``P = pi a^2 / (2 A R)``), in
    ``psi = pi/2 - phi`` with breakpoints towards the edge (h0' ~ (d + a psi^2/2)^(-1/2))."""
    def f(psi: float) -> float:  # B - x written without cancellation near the edge
        x = a * np.cos(psi)
        short = (B - a) + 2.0 * a * np.sin(0.5 * psi) ** 2
        return x * (x - 1.0) / np.sqrt(short * (x - 0.5)) if x > 1.0 else 0.0

    top = 0.5 * np.pi - np.arcsin(1.0 / a)
    br = [0.0, *np.geomspace(1e-7, 0.3 * top, 12), top]
    return 2.0 / A * sum(quad(f, lo, hi, epsabs=0.0, epsrel=1e-11, limit=200)[0]
                         for lo, hi in zip(br[:-1], br[1:], strict=True))


def test_edges_approach_the_arc_ends_logarithmically(punch) -> None:
    """A free edge a distance d short of the arc's end carries ``P ~ C0 - C1 ln d`` (the arc's
    slope ``d^(-1/2)`` just beyond it): it reaches the end only in the limit (d = 7e-5 at
    P = 8, 7e-8 at P = 15), and pins there once d is below 3e-9 of the span (P ~ 16.5), where
    its load is rounding-limited (``analytic._topology.VERTICAL_LANDING``)."""
    loads = [8.0, 9.0, 12.0, 15.0, 20.0, 25.0]
    curve = analytic.load_curve(punch, loads, A)
    free = [s for s in curve if s.singular == [(False, False)]]
    pinned = [s for s in curve if s.singular == [(True, True)]]
    assert len(free) + len(pinned) == len(loads) and free and pinned
    assert max(s.P for s in free) < min(s.P for s in pinned)  # one event, in between
    gaps = [B - s.zones[0][1] for s in free]
    assert np.all(np.diff(gaps) < 0) and gaps[-1] < 1e-7
    for s in free[:3]:
        assert bounded_load(s.zones[0][1]) == pytest.approx(s.P, rel=BOUNDED_LOAD_RTOL)
    # across the event the pressure away from the edges changes with the load step only
    inner = np.r_[np.linspace(-0.8, 0.8, 17), -1.3, -1.2, -0.99, 0.99, 1.2, 1.3]
    p_below, p_above = free[-1].pressure(inner), pinned[0].pressure(inner)
    dP = pinned[0].P - free[-1].P
    assert np.max(np.abs(p_above - p_below)) < 10 * sharp(dP, inner).max() + 1e-6


def test_every_load_and_moment_across_the_pinning_solves(punch) -> None:
    """Across the event the free edge is 1e-8 .. 1e-10 of the span short of the end, where its
    load is rounding-limited (the self-check refused P = 18.3 and M = 5 before the landing
    rule): every load solves, free below and pinned above one load, and moments too."""
    loads = np.geomspace(8.0, 60.0, 20)
    pinned = [analytic.solve_normal(punch, P, A).singular == [(True, True)] for P in loads]
    assert pinned == sorted(pinned) and pinned[-1] and not pinned[0]
    for M in (2.0, 5.0, 10.0):
        sol = analytic.solve_normal(punch, 25.0, A, M=M)
        assert sol.zones[0][1] == B and sol.singular[0][1]


def test_tilt_releases_one_arc_end(punch) -> None:
    """Tilted far enough, the face lifts on the left: that edge leaves the arc end (at
    theta = 0.5 already, by 1e-9: the free edge's load grows only like -ln d)."""
    level = analytic.solve_normal_fixed_rotation(punch, 20.0, A, 0.1)
    tilted = analytic.solve_normal_fixed_rotation(punch, 20.0, A, 3.0)
    assert level.singular == [(True, True)]
    assert tilted.singular == [(False, True)] and -B < tilted.zones[0][0] < -1.0
    moment = analytic.solve_normal(punch, 20.0, A, M=0.0)
    assert moment.singular == [(True, True)] and abs(moment.theta) < 1e-12


def test_bem_agrees_in_complete_contact(punch) -> None:
    sol = analytic.solve_normal(punch, 20.0, A)
    bem = solve_normal_bem(punch.h0, (-1.6, 1.6), 600, 20.0, A)
    inner = np.abs(bem.x) < 1.3
    p = sol.pressure(bem.x[inner])
    assert np.max(np.abs(bem.p[inner] - p)) <= BEM_PRESSURE_REL * p.max()


@pytest.mark.parametrize(("theta", "P"), [(8.0, 5.0), (16.0, 10.0)])
def test_tilted_zone_on_the_arc_alone_pinned_at_its_end(punch, theta, P) -> None:
    """Tilted steeply, the zone lies on the right arc alone (no kink inside) and is pinned at
    its end: the local rule near that end takes its far half up to the zone's free edge, whose
    edge weight it carried at the wrong end of that half (the self-check refused these with
    int p 9 % and 4.5 % off).  The audit's independent quadratures and the BEM agree."""
    sol = analytic.solve_normal_fixed_rotation(punch, P, A, theta)
    (a, b), = sol.zones
    assert 1.0 < a < B and b == B and sol.singular == [(False, True)]
    assert sol.residuals["selfcheck_load"] < 1e-9
    assert not [f.line() for f in checks.quadrature_findings(sol) if f.failed]
    bem = solve_normal_bem(lambda x: punch.h0(x) - theta * x, (0.9, 1.6), 600, P, A)
    (lo, hi), = bem.zones
    assert abs(lo - a) < 2 * (0.7 / 600) and abs(hi - b) < 2 * (0.7 / 600)
