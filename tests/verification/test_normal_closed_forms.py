"""Analytic normal solver against closed forms (plane strain, similar bodies, p >= 0).

Conventions: ``A = 4 (1 - nu^2) / E`` (so ``A = 2 / E*`` of Johnson 1985), ``M = int x p dx``.
Every closed form is a pure function below with its formula and source. Where a published
relation is stated in another normalisation, the docstring derives it in ours from the
single-zone / two-zone inversion (paper Eqs. 12-14, docs/conventions.md): for one zone
``[a, b]`` with nonsingular edges

    consistency   int_a^b h'(s) / sqrt((s-a)(b-s)) ds = 0,
    equilibrium   P = (1/A) int_a^b s h'(s) / sqrt((s-a)(b-s)) ds,
    pressure      p(x) = sqrt((x-a)(b-x)) / (pi A) PV int_a^b h'(s) / (sqrt((s-a)(b-s)) (s-x)) ds,

and for the symmetric pair ``[-b, -a] U [a, b]`` with an odd slope ``h'``, ``X = sqrt((s^2-a^2)
(b^2-s^2))`` and ``mu_j = 2 int_a^b s^j h'(s) / X(s) ds``: consistency ``mu_0 = 0`` and
``P = mu_2 / A``. The integrals are evaluated independently here with scipy.integrate.quad.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import analytic
from analytic import profiles

EDGE_RTOL = 1e-10
"""Edge positions relative to the zone width: the issue's accuracy target for the solver."""
LOAD_RTOL = 1e-10
"""Loads from a closed form evaluated at the solver's edges (same target)."""
PRESSURE_RTOL = 1e-10
"""Pressure relative to its peak (closed forms exact; solver quadrature near roundoff)."""
QUAD_RTOL = 1e-9
"""Comparisons against scipy.integrate.quad (its default epsabs/epsrel 1.5e-8, observed ~1e-11
on these smooth integrands with explicit endpoint weights)."""
QUAD_OPTS = {"epsabs": 1e-13, "epsrel": 1e-12, "limit": 200}

A = 0.9


# ---------------------------------------------------------------------------- closed forms
def hertz_half_width(P: float, A: float, R: float) -> float:
    """Hertz line contact: ``a^2 = 2 A P R / pi`` (Johnson 1985, Eq. 4.46 with A = 2 / E*)."""
    return float(np.sqrt(2 * A * P * R / np.pi))


def hertz_pressure(x: np.ndarray, a: float, A: float, R: float, center: float = 0.0):
    """``p = p0 sqrt(1 - ((x - center)/a)^2)``, ``p0 = a / (A R)`` (Johnson 1985, Eq. 4.45)."""
    return a / (A * R) * np.sqrt(np.clip(1 - ((x - center) / a) ** 2, 0, None))


def flat_punch_pressure(x: np.ndarray, P: float, b: float, M: float = 0.0) -> np.ndarray:
    """Sharp flat punch on ``[-b, b]``: ``p = (P + 2 M x / b^2) / (pi sqrt(b^2 - x^2))``.

    Johnson 1985, Sec. 2.8 (uniform part, ``M = 0``) and the tilted-punch term: the pressure
    ``C x / sqrt(b^2 - x^2)`` has zero resultant and moment ``C pi b^2 / 2``.
    """
    return (P + 2 * M * x / b**2) / (np.pi * np.sqrt(b**2 - x**2))


def flat_punch_rotation(M: float, A: float, b: float) -> float:
    """Rotation of a sharp flat punch under moment M: ``theta = 2 A M / (pi b^2)``.

    From ``h' = -theta = (A/pi) PV int p(s)/(x-s) ds`` with ``p = C s/sqrt(b^2-s^2)``:
    ``PV int s / (sqrt(b^2-s^2)(x-s)) ds = -pi`` gives ``C = theta / A``, and ``M = C pi b^2/2``.
    """
    return 2 * A * M / (np.pi * b**2)


def rounded_punch_load(a: float, b: float, A: float, rho: float) -> float:
    """Flat face ``|x| <= b`` with parabolic corners ``h0 = (|x| - b)^2 / (2 rho)``, contact
    ``[-a, a]``: ``P = a^2 / (2 A rho) (pi - 2 phi - sin 2 phi)``, ``sin phi = b / a``.

    Ciavarella, Hills & Monno 1998 (Proc. IMechE C 212, 319-328), here derived in our
    normalisation from the single-zone equilibrium with ``h' = (|s| - b) sign(s) / rho``:
    ``P = (2/(A rho)) int_b^a (s^2 - b s) / sqrt(a^2 - s^2) ds``; with ``s = a sin t``,
    ``int_b^a s^2/sqrt = a^2 (pi/4 - phi/2 + sin(2 phi)/4)`` and ``int_b^a s/sqrt = a cos phi``,
    so ``P = (2 a^2/(A rho)) (pi/4 - phi/2 - sin(2 phi)/4)``.
    """
    phi = np.arcsin(b / a)
    return float(a**2 / (2 * A * rho) * (np.pi - 2 * phi - np.sin(2 * phi)))


def gladwell_load_separate(a: float, b: float, c: float, A: float, R: float) -> float:
    """Bi-quadratic punch ``h0 = (x^2 - c^2)^2 / (8 R c^2)``, zones ``[-b,-a] U [a,b]``:
    ``P = pi (b^2 - a^2)^2 / (16 A R c^2)`` while ``a^2 + b^2 = 2 c^2`` (Gladwell 1980,
    Contact Problems in Classical Elasticity, Ch. 4; paper Sec. 6).

    Derived from ``P = mu_2 / A`` with ``h' = s (s^2 - c^2) / (2 R c^2)``: ``u = s^2`` and
    ``u = c^2 + r cos t``, ``r = (b^2 - a^2)/2``, give ``mu_2 = pi r^2 / (4 R c^2)``
    (and ``mu_0 = pi ((a^2 + b^2)/2 - c^2) / (2 R c^2)``, zero iff Gladwell's condition holds).
    Cross-checked against quadrature of :func:`gladwell_pressure` in this module.
    """
    return float(np.pi * (b**2 - a**2) ** 2 / (16 * A * R * c**2))


def gladwell_pressure(x: np.ndarray, a: float, b: float, c: float, A: float, R: float):
    """Separate zones: ``p = |x| sqrt((x^2 - a^2)(b^2 - x^2)) / (2 A R c^2)`` (Gladwell 1980).

    Derived: ``p = |X| Poly(h'/X) / A`` with the polynomial part ``x / (2 R c^2)`` of
    ``h'(z)/X(z)`` at infinity once ``a^2 + b^2 = 2 c^2``.
    """
    return np.abs(x) * np.sqrt(np.clip((x**2 - a**2) * (b**2 - x**2), 0, None)) / (
        2 * A * R * c**2)


def gladwell_load_merged(b: float, c: float, A: float, R: float) -> float:
    """Merged zone ``[-b, b]``: ``P = pi b^2 (3 b^2 - 4 c^2) / (16 A R c^2)``.

    Single-zone equilibrium with ``int s^4/sqrt(b^2-s^2) = 3 pi b^4/8`` and ``int s^2/sqrt =
    pi b^2/2``. The pressure ``sqrt(b^2-x^2)(x^2 - c^2 + b^2/2)/(2 A R c^2)`` is >= 0 at x = 0
    iff ``b^2 >= 2 c^2``, i.e. ``P >= pi c^2 / (4 A R)``: the merging load.
    """
    return float(np.pi * b**2 * (3 * b**2 - 4 * c**2) / (16 * A * R * c**2))


def gladwell_merging_load(c: float, A: float, R: float) -> float:
    """``P = pi c^2 / (4 A R)``: separate-zone load at ``a = 0`` = merged load at ``b^2 = 2c^2``."""
    return float(np.pi * c**2 / (4 * A * R))


def _pair_integral(f, lo: float, hi: float, a: float, b: float) -> float:
    """``int_lo^hi f(s) / sqrt((s^2 - a^2)(b^2 - s^2)) ds`` with a <= lo < hi <= b (quad with
    algebraic endpoint weights where lo = a or hi = b)."""
    wl = -0.5 if lo == a else 0.0
    wh = -0.5 if hi == b else 0.0

    def g(s):
        rest = (s + a) * (b + s)
        rest *= (s - a) if wl == 0.0 else 1.0
        rest *= (b - s) if wh == 0.0 else 1.0
        return f(s) / np.sqrt(rest)

    return quad(g, lo, hi, weight="alg", wvar=(wl, wh), **QUAD_OPTS)[0]


def double_wedge_E(a: float, b: float, c: float, phi1: float, phi2: float) -> float:
    """Paper Eq. (21): ``E = tan(phi1) int_a^c dx/X - tan(phi2) int_c^b dx/X`` (= -mu_0/2)."""
    one = np.ones_like
    return (np.tan(phi1) * _pair_integral(one, a, c, a, b)
            - np.tan(phi2) * _pair_integral(one, c, b, a, b))


def double_wedge_load(a: float, b: float, c: float, phi1: float, phi2: float, A: float,
                      consistent: bool = True) -> float:
    """Load of the symmetric double wedge (paper Fig. 4): ``P = mu_2/A`` with ``h' = -tan phi1``
    on ``(a, c)`` and ``tan phi2`` on ``(c, b)``.

    ``consistent=False``: the load of the Eq. 13 pressure when ``mu_0 != 0`` (paper Sec. 6,
    overlapped extent): the residue at infinity of ``Phi = W Psi`` with
    ``W = z^2 (1 - (a^2+b^2)/(2 z^2) + ...)`` gives ``P = (mu_2 - (a^2 + b^2) mu_0 / 2) / A``.
    """
    shift = 0.0 if consistent else 0.5 * (a**2 + b**2)

    def moment(f):
        return 2 * (-np.tan(phi1) * _pair_integral(f, a, c, a, b)
                    + np.tan(phi2) * _pair_integral(f, c, b, a, b))

    return (moment(lambda s: s**2 - shift)) / A


def wedge_zone(P: float, A: float, phi_l: float, phi_r: float) -> tuple[float, float]:
    """Asymmetric wedge (apex 0, slopes ``-tan phi_l``, ``tan phi_r``): with ``s = m - r cos t``
    consistency gives ``t0 = pi tr / (tl + tr)`` (apex at ``cos t0 = m / r``), equilibrium
    ``P = r sin(t0) (tl + tr) / A``. Symmetric case: ``a = A P / (2 tan phi)``, i.e.
    ``P = E* a cot(alpha)`` (Johnson 1985, Sec. 5.8, wedge of semi-angle alpha).
    """
    tl, tr = np.tan(phi_l), np.tan(phi_r)
    t0 = np.pi * tr / (tl + tr)
    r = A * P / ((tl + tr) * np.sin(t0))
    m = r * np.cos(t0)
    return float(m - r), float(m + r)


def single_zone_pressure_quad(dh, a: float, b: float, x: float, A: float,
                              kinks: tuple[float, ...] = ()) -> float:
    """The single-zone inversion formula evaluated by quad: ``s = m - r cos t`` removes the
    endpoint weights, the Cauchy kernel is handled by quad's ``weight='cauchy'``."""
    m, r = 0.5 * (a + b), 0.5 * (b - a)
    t0 = np.arccos((m - x) / r)
    s = lambda t: m - r * np.cos(t)  # noqa: E731
    cuts = sorted({0.0, np.pi, *[float(np.arccos((m - k) / r)) for k in kinks if a < k < b]})
    total = 0.0
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        if lo < t0 < hi:
            g = lambda t: dh(s(t)) * (t - t0) / (s(t) - x) if t != t0 else dh(x) / (  # noqa: E731
                r * np.sin(t0))
            total += quad(g, lo, hi, weight="cauchy", wvar=t0, **QUAD_OPTS)[0]
        else:
            total += quad(lambda t: dh(s(t)) / (s(t) - x), lo, hi, **QUAD_OPTS)[0]
    return float(np.sqrt((x - a) * (b - x)) * total / (np.pi * A))


def check_admissible(sol, zone_integral) -> None:
    """Equilibrium (independently by zone quadrature of the pressure where no kink of h0 lies
    inside a zone: see :func:`test_pressure_integrates_to_P_across_kinks`) and self-checks."""
    kinked = any(a < k < b for a, b in sol.zones for k in sol.profile.kinks)
    loads = sol.zone_loads if kinked else zone_integral(sol)
    assert sum(loads) == pytest.approx(sol.P, rel=LOAD_RTOL)
    assert sol.residuals["min_pressure"] >= 0
    assert sol.residuals["min_gap"] >= 0


# ---------------------------------------------------------------------------- Hertz
@pytest.mark.parametrize(("P", "R", "center"), [(0.5, 1.0, 0.0), (3.0, 0.2, 0.7),
                                                (1e-4, 50.0, -2.0)])
def test_hertz_half_width_peak_and_profile(P, R, center, zone_integral) -> None:
    sol = analytic.solve_normal(profiles.cylinder(R, center=center), P, A)
    a = hertz_half_width(P, A, R)
    assert len(sol.zones) == 1 and sol.singular == [(False, False)]
    lo, hi = sol.zones[0]
    assert abs(lo - (center - a)) <= EDGE_RTOL * 2 * a
    assert abs(hi - (center + a)) <= EDGE_RTOL * 2 * a
    p0 = a / (A * R)
    assert sol.pressure(center) == pytest.approx(p0, rel=PRESSURE_RTOL)
    x = center + a * np.linspace(-1.2, 1.2, 96)  # no point exactly at an edge (sqrt)
    err = np.abs(sol.pressure(x) - hertz_pressure(x, a, A, R, center))
    assert err.max() <= PRESSURE_RTOL * p0
    assert sol.M == pytest.approx(center * P, rel=LOAD_RTOL, abs=LOAD_RTOL * P * a)
    check_admissible(sol, zone_integral)


def test_hertz_deformed_gap_is_the_closed_form() -> None:
    """Outside ``[-a, a]`` the deformed-gap slope is ``g' = W B / pi = sign(x) sqrt(x^2 - a^2) / R``
    (docs/conventions.md, with ``B = pi / R``), so
    ``g = (|x| sqrt(x^2 - a^2) - a^2 acosh(|x|/a)) / (2 R)``
    (equivalently Johnson 1985, Sec. 4.2, surface displacement outside a Hertz contact)."""
    R, P = 1.3, 0.4
    sol = analytic.solve_normal(profiles.cylinder(R), P, A)
    a = hertz_half_width(P, A, R)
    x = a * np.array([1.01, 1.3, 2.0, 5.0, -1.5, -3.0])
    ax = np.abs(x)
    exact = (ax * np.sqrt(ax**2 - a**2) - a**2 * np.arccosh(ax / a)) / (2 * R)
    np.testing.assert_allclose(sol.gap(x), exact, rtol=1e-9, atol=1e-12 * a**2 / R)


# ---------------------------------------------------------------------------- flat punches
@pytest.mark.parametrize(("left", "right"), [(-0.5, 0.5), (0.2, 1.7)])
def test_sharp_flat_punch_pressure(left, right, zone_integral) -> None:
    P = 0.7
    sol = analytic.solve_normal(profiles.flat_punch(left, right), P, A)
    assert sol.zones == [(left, right)] and sol.singular == [(True, True)]
    b, mid = 0.5 * (right - left), 0.5 * (left + right)
    x = mid + b * np.array([-0.9999, -0.9, -0.3, 0.0, 0.5, 0.999])
    np.testing.assert_allclose(sol.pressure(x), flat_punch_pressure(x - mid, P, b),
                               rtol=PRESSURE_RTOL)
    check_admissible(sol, zone_integral)


@pytest.mark.parametrize("M", [0.1, -0.05])
def test_sharp_flat_punch_with_moment(M) -> None:
    P, b = 0.5, 0.5
    sol = analytic.solve_normal(profiles.flat_punch(-b, b), P, A, M=M)
    assert sol.zones == [(-b, b)]
    assert sol.theta == pytest.approx(flat_punch_rotation(M, A, b), rel=1e-9)
    x = b * np.array([-0.9, 0.0, 0.7])
    np.testing.assert_allclose(sol.pressure(x), flat_punch_pressure(x, P, b, M),
                               rtol=PRESSURE_RTOL)


def test_rounded_punch_load_formula_matches_quadrature() -> None:
    """Check the derivation of :func:`rounded_punch_load` by direct quadrature of equilibrium."""
    a, b, rho = 1.3, 0.8, 2.0
    direct = 2 / (A * rho) * quad(lambda s: s * (s - b) / np.sqrt(a**2 - s**2), b, a,
                                  **QUAD_OPTS)[0]
    assert rounded_punch_load(a, b, A, rho) == pytest.approx(direct, rel=QUAD_RTOL)


@pytest.mark.parametrize("P", [1e-3, 0.05, 0.4, 3.0])
def test_rounded_flat_punch_ciavarella_hills_monno(P, zone_integral) -> None:
    b, rho = 0.5, 2.0
    prof = profiles.flat_punch(-b, b, corner_radius=rho, corner_shape="parabolic")
    sol = analytic.solve_normal(prof, P, A)
    a = brentq(lambda t: rounded_punch_load(t, b, A, rho) - P, b * (1 + 1e-15), 100 * b,
               xtol=1e-15, rtol=1e-15)
    assert len(sol.zones) == 1 and sol.singular == [(False, False)]
    lo, hi = sol.zones[0]
    assert abs(lo + a) <= EDGE_RTOL * 2 * a and abs(hi - a) <= EDGE_RTOL * 2 * a
    assert rounded_punch_load(hi, b, A, rho) == pytest.approx(P, rel=LOAD_RTOL * 10)
    dh = lambda s: np.sign(s) * max(abs(s) - b, 0.0) / rho  # noqa: E731
    for x in (0.0, 0.3 * a, 0.6 * a, 0.95 * a):
        ref = single_zone_pressure_quad(dh, -a, a, x, A, kinks=(-b, b))
        assert sol.pressure(x) == pytest.approx(ref, rel=QUAD_RTOL)
    check_admissible(sol, zone_integral)


# ---------------------------------------------------------------------------- Gladwell
def test_gladwell_load_formula_matches_quadrature_of_the_pressure() -> None:
    c, R, a = 1.0, 0.7, 0.6
    b = np.sqrt(2 * c**2 - a**2)
    one = quad(lambda x: gladwell_pressure(np.array(x), a, b, c, A, R), a, b, **QUAD_OPTS)[0]
    assert 2 * one == pytest.approx(gladwell_load_separate(a, b, c, A, R), rel=QUAD_RTOL)
    merged = quad(lambda x: np.sqrt(b**2 - x**2) * (x**2 - c**2 + b**2 / 2) / (2 * A * R * c**2),
                  -b, b, **QUAD_OPTS)[0]
    assert merged == pytest.approx(gladwell_load_merged(b, c, A, R), rel=QUAD_RTOL)


@pytest.mark.parametrize("fraction", [1e-3, 0.1, 0.5, 0.9])
def test_gladwell_biquadratic_separate_zones(fraction, zone_integral) -> None:
    c, R = 1.2, 0.8
    P = fraction * gladwell_merging_load(c, A, R)
    sol = analytic.solve_normal(profiles.biquadratic(c, R), P, A)
    assert len(sol.zones) == 2
    (a1, b1), (a2, b2) = sol.zones
    width = b2 - a2
    assert abs(a1 + b2) <= EDGE_RTOL * width and abs(b1 + a2) <= EDGE_RTOL * width
    assert abs(a2**2 + b2**2 - 2 * c**2) <= EDGE_RTOL * 2 * c * width
    assert gladwell_load_separate(a2, b2, c, A, R) == pytest.approx(P, rel=LOAD_RTOL)
    t = np.linspace(0, 1, 43)[1:-1]  # interior points: at an edge p is sqrt-sensitive
    x = np.concatenate([a1 + (b1 - a1) * t, a2 + (b2 - a2) * t])
    pmax = np.max(gladwell_pressure(x, a2, b2, c, A, R))
    err = np.abs(sol.pressure(x) - gladwell_pressure(x, a2, b2, c, A, R))
    assert err.max() <= PRESSURE_RTOL * pmax
    np.testing.assert_allclose(sol.zone_loads, [P / 2, P / 2], rtol=LOAD_RTOL)
    check_admissible(sol, zone_integral)


NEAR_MERGE_RTOL = 1e-6
"""Edge symmetry just below merging: the gap between the zones is ~1e-3 of their width and
the Newton system is ill-conditioned there (observed 3.6e-8 / width at eps = 1e-6)."""


NEAR_MERGE_EQUILIBRIUM = 1e-13
"""Sum of the zone loads (contour integrals) against P just below merging: a fixed 160-node
rule gave 2.6e-11 at eps = 1e-6, the adaptive one gives ~2e-15."""


@pytest.mark.parametrize("eps", [1e-3, 1e-6])
def test_gladwell_zones_merge_at_pi_c2_over_4AR(eps) -> None:
    c, R = 1.0, 1.0
    P_merge = gladwell_merging_load(c, A, R)
    below = analytic.solve_normal(profiles.biquadratic(c, R), P_merge * (1 - eps), A)
    above = analytic.solve_normal(profiles.biquadratic(c, R), P_merge * (1 + eps), A)
    assert len(below.zones) == 2
    a = below.zones[1][0]
    assert 0 < a < 2 * np.sqrt(eps) * c  # a^2 = c^2 (1 - sqrt(1 - eps)) ~ c^2 eps / 2
    assert abs(below.zones[0][1] + a) <= NEAR_MERGE_RTOL * below.extent
    # the zone-load contours are squeezed between the close zones: their rule must adapt
    np.testing.assert_allclose(below.zone_loads, [below.P / 2] * 2, rtol=NEAR_MERGE_RTOL)
    assert below.residuals["equilibrium"] <= NEAR_MERGE_EQUILIBRIUM
    assert len(above.zones) == 1
    lo, hi = above.zones[0]
    assert lo == pytest.approx(-hi, rel=EDGE_RTOL)
    assert gladwell_load_merged(hi, c, A, R) == pytest.approx(P_merge * (1 + eps), rel=LOAD_RTOL)
    assert above.pressure(0.0) > 0


@pytest.mark.parametrize("eps", [1e-3, 1e-4, 1e-5, 1e-6])
def test_gladwell_edges_exact_close_to_merging(eps) -> None:
    """``a^2 = c^2 (1 - sqrt(1 - eps))`` at ``P = (1 - eps) pi c^2/(4 A R)`` (from P(a, b) with
    ``a^2 + b^2 = 2 c^2``), both inner edges to 1e-10 of the zone width.  Near the merge the
    system is ill-conditioned (shifting the narrow gap sideways barely changes the residual):
    a scaled residual of 1e-14 alone left the pair 1.6e-8 off at eps = 1e-6; Newton now also
    requires its next step to be below STEP_TOL."""
    c, R = 1.0, 1.0
    sol = analytic.solve_normal(profiles.biquadratic(c, R),
                                gladwell_merging_load(c, A, R) * (1 - eps), A)
    a = c * np.sqrt(1 - np.sqrt(1 - eps))
    (_, b1), (a2, b2) = sol.zones
    assert abs(a2 - a) <= EDGE_RTOL * (b2 - a2)
    assert abs(b1 + a) <= EDGE_RTOL * (b2 - a2)


def test_gladwell_merged_well_above() -> None:
    c, R = 1.0, 2.0
    P = 3 * gladwell_merging_load(c, A, R)
    sol = analytic.solve_normal(profiles.biquadratic(c, R), P, A)
    assert len(sol.zones) == 1
    assert gladwell_load_merged(sol.zones[0][1], c, A, R) == pytest.approx(P, rel=LOAD_RTOL)


# ---------------------------------------------------------------------------- double wedge
PAPER_ANGLES = [(0.11, 0.07), (0.18, 0.18), (0.07, 0.11)]


@pytest.mark.parametrize(("phi1", "phi2"), PAPER_ANGLES)
@pytest.mark.parametrize("load", [0.02, 0.3])
def test_double_wedge_eq21_residual_and_load(phi1, phi2, load, zone_integral) -> None:
    c = 1.0
    P = load * c * np.tan(min(phi1, phi2)) / A
    sol = analytic.solve_normal(profiles.double_wedge(c, phi1, phi2), P, A)
    assert len(sol.zones) == 2 and sol.singular == [(False, False), (False, False)]
    (a1, b1), (a, b) = sol.zones
    assert a < c < b
    assert abs(a1 + b) <= EDGE_RTOL * (b - a) and abs(b1 + a) <= EDGE_RTOL * (b - a)
    scale = np.tan(phi1) * _pair_integral(np.ones_like, a, c, a, b)
    assert abs(double_wedge_E(a, b, c, phi1, phi2)) <= QUAD_RTOL * scale
    assert double_wedge_load(a, b, c, phi1, phi2, A) == pytest.approx(P, rel=QUAD_RTOL)
    if phi1 == phi2:
        assert a * b == pytest.approx(c**2, rel=EDGE_RTOL)
    check_admissible(sol, zone_integral)


# ---------------------------------------------------------------------------- wedge, moment
@pytest.mark.parametrize(("phi_l", "phi_r", "apex"), [(0.1, 0.1, 0.0), (0.1, 0.2, 0.3),
                                                      (0.3, 0.05, -1.0)])
def test_wedge_edges_and_pressure(phi_l, phi_r, apex, zone_integral) -> None:
    P = 0.5
    sol = analytic.solve_normal(profiles.wedge(phi_l, phi_r, apex=apex), P, A)
    lo, hi = wedge_zone(P, A, phi_l, phi_r)
    a, b = sol.zones[0]
    assert len(sol.zones) == 1
    assert abs(a - apex - lo) <= EDGE_RTOL * (hi - lo)
    assert abs(b - apex - hi) <= EDGE_RTOL * (hi - lo)
    dh = lambda s: -np.tan(phi_l) if s < apex else np.tan(phi_r)  # noqa: E731
    for x in (a + 0.1 * (b - a), apex + 0.3 * (b - apex), b - 0.05 * (b - a)):
        ref = single_zone_pressure_quad(dh, a, b, x, A, kinks=(apex,))
        assert sol.pressure(x) == pytest.approx(ref, rel=QUAD_RTOL)
    check_admissible(sol, zone_integral)


@pytest.mark.parametrize(("P", "M", "R"), [(0.5, 0.05, 1.0), (0.5, -0.2, 1.0), (2.0, 0.3, 0.4)])
def test_applied_moment_on_cylinder(P, M, R, zone_integral) -> None:
    """``h0 - theta x`` is the cylinder shifted by ``theta R``; the load centre is ``M/P``, so
    ``theta = M / (P R)`` and the zone is the Hertz zone centred at ``M / P``."""
    sol = analytic.solve_normal(profiles.cylinder(R), P, A, M=M)
    assert sol.mode == "moment"
    assert sol.theta == pytest.approx(M / (P * R), rel=EDGE_RTOL)
    assert sol.M == pytest.approx(M, rel=LOAD_RTOL)
    a, xc = hertz_half_width(P, A, R), M / P
    lo, hi = sol.zones[0]
    assert abs(lo - (xc - a)) <= EDGE_RTOL * 2 * a and abs(hi - (xc + a)) <= EDGE_RTOL * 2 * a
    m = zone_integral(sol, lambda x: x)[0]
    assert m == pytest.approx(M, rel=LOAD_RTOL)
    check_admissible(sol, zone_integral)


def test_symmetric_wedge_pressure_near_the_apex() -> None:
    """``p = (2 tan(phi) / (pi A)) acosh(a / |x|)``, ``a = A P / (2 tan phi)`` (Johnson 1985,
    Sec. 5.8: ``p = (E* cot(alpha)/pi) acosh(a/x)`` with ``E* = 2/A``, ``cot(alpha) = tan phi``)."""
    P, phi = 0.5, 0.1
    sol = analytic.solve_normal(profiles.wedge(phi, phi), P, A)
    a = A * P / (2 * np.tan(phi))
    x = a * np.array([-0.9, -0.1, -1e-3, 1e-6, 1e-2, 0.5])
    exact = 2 * np.tan(phi) / (np.pi * A) * np.arccosh(a / np.abs(x))
    np.testing.assert_allclose(sol.pressure(x), exact, rtol=PRESSURE_RTOL)


@pytest.mark.parametrize("prof", [
    profiles.wedge(0.1, 0.2, apex=0.3),
    profiles.double_wedge(1.0, 0.11, 0.07),
    profiles.flat_punch(-0.5, 0.5, corner_radius=2.0, corner_shape="parabolic"),
], ids=["wedge", "double_wedge", "rounded_punch"])
def test_pressure_integrates_to_P_across_kinks(prof, zone_integral) -> None:
    P = 0.01
    sol = analytic.solve_normal(prof, P, A)
    assert sum(zone_integral(sol)) == pytest.approx(P, rel=LOAD_RTOL)


# ---------------------------------------------------------------------------- Section 6
def test_overlapped_equals_actual_for_symmetric_single_and_biquadratic() -> None:
    """Paper Sec. 6: the overlapped extent is exact for a symmetric single contact (Fig. 3b)
    and for Gladwell's bi-quadratic punch (its consistency condition is the roots' relation)."""
    for prof, P in ((profiles.cylinder(1.3), 0.4), (profiles.biquadratic(1.0, 1.0), 0.3)):
        actual = analytic.solve_normal(prof, P, A).zones
        ovl = analytic.overlapped(prof, P, A)
        np.testing.assert_allclose(np.ravel(ovl.zones), np.ravel(actual), atol=1e-9)
        assert sum(ovl.zone_loads) == pytest.approx(P, rel=1e-10)


@pytest.mark.parametrize(("phi1", "phi2"), PAPER_ANGLES)
def test_overlapped_double_wedge_edges_on_a_horizontal_line(phi1, phi2) -> None:
    """``H_L(a, b) = tan(phi2) b + tan(phi1) a - (tan phi1 + tan phi2) c = 0`` and the load of the
    unconstrained Eq. 13 pressure (:func:`double_wedge_load`, consistent=False) equals P."""
    c = 1.0
    P = 0.2 * np.tan(min(phi1, phi2)) / A
    ovl = analytic.overlapped(profiles.double_wedge(c, phi1, phi2), P, A)
    (a1, b1), (a, b) = ovl.zones
    assert a1 == pytest.approx(-b, rel=1e-12) and b1 == pytest.approx(-a, rel=1e-12)
    H_L = np.tan(phi2) * b + np.tan(phi1) * a - (np.tan(phi1) + np.tan(phi2)) * c
    assert abs(H_L) <= 1e-12 * c
    ref = double_wedge_load(a, b, c, phi1, phi2, A, consistent=False)
    assert ref == pytest.approx(P, rel=QUAD_RTOL)


def weak_load_Pe(phi_inner: float, phi_outer: float) -> float:
    """Limit of Pe as kappa -> 0: each zone becomes a single asymmetric wedge (slopes
    ``tl = tan phi_inner`` towards the centre, ``tr = tan phi_outer``). With ``s = m - r cos t``
    and the apex at ``cos t0 = m / r`` the load is ``P = r sin(t0) (tl + tr) / A`` for both
    estimates (:func:`wedge_zone`; the overlapped load adds ``w1 mu_0`` with ``w1 = -m``, which
    gives the same expression). Actual: ``t0 = pi tr / (tl + tr)`` (consistency); overlapped:
    equal edge heights give ``cos t0 = (tl - tr) / (tl + tr)``. Equal load:
    ``Pe = 100 (1 - sin t0_actual / sin t0_overlapped)`` (0 for equal angles)."""
    tl, tr = np.tan(phi_inner), np.tan(phi_outer)
    t_act = np.pi * tr / (tl + tr)
    t_ovl = np.arccos((tl - tr) / (tl + tr))
    return float(100 * (1 - np.sin(t_act) / np.sin(t_ovl)))


WEAK_LOAD_PE_ATOL = 0.05
"""Pe (percent) at kappa ~ 1e-3 vs its kappa -> 0 limit: the correction is O(kappa)."""


@pytest.mark.parametrize(("phi1", "phi2"), PAPER_ANGLES)
def test_fig5_data_definitions_and_weak_load_limit(phi1, phi2) -> None:
    """``Pe = (actual - overlapped)/actual * 100``, ``kappa = actual / c`` (paper Sec. 6); the
    actual widths are the solver's; at weak load Pe tends to :func:`weak_load_Pe` (Fig. 5d)."""
    c = 1.0
    loads = np.array([2e-4, 2e-3, 0.2]) * c * np.tan(min(phi1, phi2)) / A
    data = analytic.fig5_data(phi1, phi2, loads=loads, c=c, A=A)
    np.testing.assert_allclose(data.Pe, (data.actual - data.overlapped) / data.actual * 100,
                               rtol=1e-12)
    np.testing.assert_allclose(data.kappa, data.actual / c, rtol=1e-12)
    ref = analytic.solve_normal(profiles.double_wedge(c, phi1, phi2), loads[-1], A).zones[-1]
    assert data.actual[-1] == pytest.approx(ref[1] - ref[0], rel=1e-10)
    limit = weak_load_Pe(phi1, phi2)
    dev = np.abs(data.Pe - limit)
    assert dev[0] < WEAK_LOAD_PE_ATOL
    assert dev[0] < dev[1] < dev[2]
