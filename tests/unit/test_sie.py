"""Unit tests of the pure functions of ``analytic._sie``, ``_rules`` and ``_layout`` (quadrature,
series, sign rules).

Known integrals (Gradshteyn & Ryzhik 3.196.3, 3.121; elementary with ``x = m - r cos t``):
- ``int_{-1}^{1} (1-t)^al (1+t)^be dt = 2^(al+be+1) B(al+1, be+1)``,
- ``int_a^b dx / sqrt((x-a)(b-x)) = pi``, ``int_a^b x dx / sqrt(...) = pi (a+b)/2``,
- ``int_a^b sqrt((x-a)(b-x)) dx = pi (b-a)^2 / 8``,
- ``int_a^b dx / ((c-x) sqrt((x-a)(b-x))) = pi / sqrt((c-a)(c-b))`` for ``c > b``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.special import beta as beta_fn
from scipy.special import binom

from analytic import profiles
from analytic._layout import sign_exponent, sign_from_d, w_abs
from analytic._rules import BASE_NODES, MAX_NODES, jacobi_rule, mapped_rule, nodes_for
from analytic._sie import Layout, System, series_coeffs
from analytic._zone_quadrature import squad_nodes, squad_plan

ROUNDOFF = 1e-13
"""Relative tolerance for exact quadrature / algebra in double precision (a few ulps x n)."""
SERIES_TAIL = 1e-9
"""Truncated-series check at |z| = 30 edges: remainder ~ 30^-(order+1) with order 6."""


@pytest.mark.parametrize(("al", "be"), [(0.5, 0.5), (-0.5, -0.5), (0.5, -0.5), (0.0, -0.5),
                                        (-0.5, 0.0), (0.0, 0.0)])
@pytest.mark.parametrize("k", [0, 1, 5, 2 * 16 - 1])
def test_jacobi_rule_is_exact_for_polynomials(al: float, be: float, k: int) -> None:
    """``sum w (1+t)^k = 2^(al+be+k+1) B(al+1, be+k+1)`` for ``k <= 2n - 1``."""
    t, w = jacobi_rule(16, al, be)
    exact = 2.0 ** (al + be + k + 1) * beta_fn(al + 1, be + k + 1)
    assert np.sum(w * (1 + t) ** k) == pytest.approx(exact, rel=ROUNDOFF)


def test_jacobi_rule_exactness_ends_at_degree_2n() -> None:
    """The rule must be Gaussian (exact to 2n-1) and no more: degree 2n is not integrated."""
    t, w = jacobi_rule(4, 0.5, -0.5)
    k = 8
    exact = 2.0 ** (k + 1) * beta_fn(1.5, 0.5 + k)
    assert abs(np.sum(w * (1 + t) ** k) / exact - 1) > 1e-6


A_, B_ = -0.7, 1.9


@pytest.mark.parametrize(
    ("al", "ah", "f", "exact"),
    [
        (-0.5, -0.5, lambda x: np.ones_like(x), np.pi),
        (-0.5, -0.5, lambda x: x, np.pi * (A_ + B_) / 2),
        (0.5, 0.5, lambda x: np.ones_like(x), np.pi * (B_ - A_) ** 2 / 8),
        (0.5, -0.5, lambda x: np.ones_like(x), np.pi * (B_ - A_) / 2),
        (-0.5, -0.5, lambda x: 1 / (3.0 - x), np.pi / np.sqrt((3.0 - A_) * (3.0 - B_))),
    ],
    ids=["chebyshev1", "first-moment", "semicircle", "sqrt-ratio", "cauchy-outside"],
)
def test_mapped_rule_known_integrals(al, ah, f, exact) -> None:
    x, w = mapped_rule(A_, B_, al, ah, 48)
    assert np.all((x > A_) & (x < B_))
    assert np.sum(w * f(x)) == pytest.approx(exact, rel=ROUNDOFF)


def test_nodes_for_grows_with_nearness_and_is_bounded() -> None:
    ratios = np.geomspace(1e-3, 1e12, 40)
    n = np.array([nodes_for(1.0, 1.0 / r) for r in ratios])
    assert np.all(np.diff(n) >= 0)
    assert n[0] >= BASE_NODES and n[-1] == MAX_NODES
    assert np.all(n % 8 == 0)
    assert nodes_for(1.0, np.inf) == BASE_NODES


@pytest.mark.parametrize("power", [1.0, -1.0, 2.0])
def test_series_coeffs_single_edge_is_the_binomial_series(power: float) -> None:
    e, eps = 0.8, 0.5
    c = series_coeffs(np.array([e]), np.array([eps]), power, 7)
    exact = [binom(power * eps, j) * (-e) ** j for j in range(8)]
    np.testing.assert_allclose(c, exact, rtol=ROUNDOFF, atol=1e-300)


def test_series_coeffs_integer_exponents_are_exact_polynomials() -> None:
    """power 2 with eps = +-1/2: ``(1 - e1 u)(1 - e2 u) / (1 - e3 u)`` (geometric series)."""
    edges = np.array([-1.0, 0.3, 2.0])
    eps = np.array([0.5, 0.5, -0.5])
    c = series_coeffs(edges, eps, 2.0, 6)
    num = np.array([1.0, -(edges[0] + edges[1]), edges[0] * edges[1]])
    geo = edges[2] ** np.arange(7)
    exact = np.convolve(num, geo)[:7]
    np.testing.assert_allclose(c, exact, rtol=ROUNDOFF, atol=ROUNDOFF)


def test_series_coeffs_of_W_times_one_over_W_is_one() -> None:
    """The solver's two uses (power 1: ``w1``; power -1: ``Poly``) are inverse series."""
    edges = np.array([-2.0, -1.1, 0.4, 1.7])
    eps = np.array([0.5, -0.5, 0.5, 0.5])
    prod = np.convolve(series_coeffs(edges, eps, 1.0, 8), series_coeffs(edges, eps, -1.0, 8))
    np.testing.assert_allclose(prod[:9], np.eye(9)[0], atol=1e-12)


def test_series_coeffs_square_of_power_one_is_power_two() -> None:
    edges = np.array([-2.0, -1.1, 0.4, 1.7])
    eps = np.full(4, 0.5)
    c1 = series_coeffs(edges, eps, 1.0, 8)
    c2 = series_coeffs(edges, eps, 2.0, 8)
    np.testing.assert_allclose(np.convolve(c1, c1)[:9], c2, rtol=1e-12, atol=1e-12)


def principal_W(z: np.ndarray, edges: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """``W(z) = prod sqrt(z - e)^(2 eps)`` with principal square roots (~ z^(e-n) at infinity)."""
    return np.prod(np.sqrt(z[:, None] - edges[None, :]) ** (2 * eps[None, :]), axis=1)


def test_series_coeffs_expand_W_at_infinity() -> None:
    """``W(z) / z^(e-n) = sum c_j z^-j`` with ``c = series_coeffs(edges, eps, 1, order)``."""
    edges = np.array([-1.0, -0.4, 0.2, 1.0])
    eps = np.array([0.5, 0.5, -0.5, 0.5])
    c = series_coeffs(edges, eps, 1.0, 6)
    z = 30.0 * np.exp(1j * np.array([0.3, 1.2, 2.5, -2.0]))
    e_minus_n = int(np.sum(eps))
    series = np.polyval(c[::-1], 1 / z)
    np.testing.assert_allclose(principal_W(z, edges, eps) / z**e_minus_n, series,
                               rtol=SERIES_TAIL)


LAYOUTS = [
    ([-1.0, 1.0], [False, False]),
    ([-2.0, -1.0, 0.5, 1.5], [False, False, False, False]),
    ([-2.0, -1.0, 0.5, 1.5, 2.0, 3.0], [False, True, False, False, True, False]),
    ([-1.0, 1.0, 2.0, 2.5], [True, True, False, True]),
]


@pytest.mark.parametrize(("edges", "pinned"), LAYOUTS)
def test_sign_rules_match_the_principal_branch(edges, pinned) -> None:
    """Inside L: ``W(x + i0) = i W_s``; in a gap or outside: ``W`` real; both = sign * |W|."""
    edges, pinned = np.asarray(edges), np.asarray(pinned)
    eps = np.where(pinned, -0.5, 0.5)
    mids = 0.5 * (edges[:-1] + edges[1:])
    x = np.concatenate([[edges[0] - 0.7], mids, [edges[-1] + 0.3]])
    inside = np.zeros(x.size, bool)
    inside[1:-1] = np.arange(mids.size) % 2 == 0
    W = principal_W(x + 1e-300j, edges, eps)
    W = np.where(inside, W / 1j, W)
    assert np.all(np.abs(W.imag) <= 1e-12 * np.abs(W.real))
    signed = sign_from_d(sign_exponent(x, edges, pinned)) * w_abs(x, edges, eps)
    np.testing.assert_allclose(signed, W.real, rtol=1e-13)


def test_sign_rule_for_all_nonsingular_edges_is_the_papers() -> None:
    """Paper Eq. 2: ``W_s = (-1)^(n-k) |X|`` in zone k = 1..n (all edges nonsingular)."""
    n = 4
    edges = np.arange(2 * n, dtype=float)
    pinned = np.zeros(2 * n, bool)
    mids = edges[0::2] + 0.5
    signs = sign_from_d(sign_exponent(mids, edges, pinned))
    np.testing.assert_array_equal(signs, [(-1.0) ** (n - k) for k in range(1, n + 1)])


def test_w_abs_skips_selected_edges() -> None:
    edges = np.array([-1.0, 2.0])
    eps = np.array([0.5, -0.5])
    x = np.array([0.5])
    assert w_abs(x, edges, eps)[0] == pytest.approx(np.sqrt(1.5 / 1.5), rel=ROUNDOFF)
    skip = np.array([True, False])
    assert w_abs(x, edges, eps, skip)[0] == pytest.approx(1 / np.sqrt(1.5), rel=ROUNDOFF)


def test_w_abs_on_an_edge_is_its_limit_without_a_warning() -> None:
    """A point on an edge (a graded quadrature node there, audit seed 69): |x - e|^eps is 0
    for eps > 0 and inf for eps < 0, not a divide-by-zero warning."""
    edges = np.array([-1.0, 2.0])
    x = np.array([-1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        zero = w_abs(x, edges, np.array([0.5, -0.5]))[0]
        inf = w_abs(x, edges, np.array([-0.5, 0.5]))[0]
    assert zero == 0.0 and inf == np.inf


def test_layout_counts() -> None:
    lay = Layout(np.array([-1.0, 0.0, 1.0, 2.0]), np.array([True, False, False, False]))
    assert (lay.n, lay.e) == (2, 3)
    np.testing.assert_array_equal(lay.eps, [-0.5, 0.5, 0.5, 0.5])
    assert lay.zones() == [(-1.0, 0.0), (1.0, 2.0)]


@pytest.mark.parametrize("center", [0.0, 0.37])
def test_system_hertz_load_moment_and_pressure(center: float) -> None:
    """n = 1, e = 2: ``P = mu_1 / A = pi a^2 / (2 A R)``, ``M = center P``, Hertz pressure."""
    A, R, a = 0.8, 1.3, 0.4
    lay = Layout(np.array([center - a, center + a]), np.array([False, False]))
    sys_ = System.build(lay, profiles.cylinder(R, center=center), A, 0.0, center, [])
    P, M = sys_.load_and_moment()
    assert P == pytest.approx(np.pi * a**2 / (2 * A * R), rel=ROUNDOFF)
    assert M == pytest.approx(center * P, rel=ROUNDOFF, abs=ROUNDOFF * P)
    assert sys_.moments(0)[0] == pytest.approx(0.0, abs=ROUNDOFF)  # consistency (symmetric)
    x = center + a * np.array([-0.99, -0.5, 0.0, 0.3, 0.9])
    exact = a / (A * R) * np.sqrt(1 - ((x - center) / a) ** 2)
    np.testing.assert_allclose(sys_.pressure_inside(x), exact, rtol=1e-12)


def test_system_flat_punch_load_from_beta() -> None:
    """n = 1, e = 0: ``T = beta_0 = -A P`` and ``p = P / (pi sqrt(b^2 - x^2))``."""
    A, P, b = 1.1, 0.6, 0.5
    lay = Layout(np.array([-b, b]), np.array([True, True]))
    sys_ = System.build(lay, profiles.flat_punch(-b, b), A, 0.0, 0.0, [-A * P])
    assert sys_.load_and_moment()[0] == pytest.approx(P, rel=ROUNDOFF)
    x = np.array([-0.49, 0.0, 0.2])
    np.testing.assert_allclose(sys_.pressure_inside(x), P / (np.pi * np.sqrt(b**2 - x**2)),
                               rtol=1e-12)


def test_residual_growth_is_the_polynomial_part_of_W_B() -> None:
    """Off consistency (two cylinders' zones at arbitrary edges: mu_0, mu_1 not 0) ``W B/pi``
    with H = 0 grows like x (e - n = 2); less the derivative of ``residual_growth`` it decays
    like ``-(mu_2 + c_1 mu_1 + c_2 mu_0)/(pi x)`` (``W = x^2 sum c_k x^-k``), as the
    displacement slope of a pressure must."""
    prof = profiles.union(profiles.cylinder(1.0, center=-1.0), profiles.cylinder(1.3, center=1.2))
    lay = Layout(np.array([-1.3, -0.6, 0.9, 1.6]), np.zeros(4, bool))
    sys_ = System.build(lay, prof, 1.0, 0.0, 0.1, [])
    mu = sys_.moments(2)
    assert np.min(np.abs(mu[:2])) > 1e-3  # far from consistent: the growth is large
    x = np.array([1e4, -1e4, 1e5])
    F = sys_.W_real(x + sys_.xc) * sys_.B(x, np.zeros(3)) / np.pi
    h = 1e-3 * np.abs(x)
    grow = sys_.batch.residual_growth(np.concatenate([x + h, x - h])[None, :])[0]
    slope = (grow[:3] - grow[3:]) / (2 * h)
    assert np.max(np.abs(F)) > 10.0
    c = series_coeffs(lay.edges - sys_.xc, lay.eps, 1.0, 2)
    lead = -(mu[2] + c[1] * mu[1] + c[2] * mu[0]) / np.pi
    assert (F - slope) * x == pytest.approx(np.full(3, lead), rel=1e-3)
    flat = System.build(Layout(np.array([-1.0, 1.0]), np.array([True, True])),
                        profiles.flat_punch(-1.0, 1.0), 1.0, 0.0, 0.0, [-1.0])
    assert np.all(flat.batch.residual_growth(x[None, :]) == 0.0)  # e <= n: no growth


@pytest.mark.parametrize("gap", [1e-4, 1.4e-5, 1e-7, 1e-10])
def test_zone_rule_resolves_omega_next_to_a_close_zone(gap: float) -> None:
    """Two free-edged zones 0.9 and 0.8 wide, ``gap`` apart: ``W ~ z^2 (1 + w1/z + ...)``, so
    ``int_L s^j omega ds = pi (0, 1, -w1)`` for j = 0, 1, 2 (the coefficients of 1/W at
    infinity).  The facing edge's factor varies on the scale of the gap; the zone rule is
    graded towards it beyond MAX_NODES (one capped rule per zone: 1.2e-6 of int |omega| off at
    gap 1.4e-5, 3e-3 at 1e-7)."""
    edges = np.array([-0.9, -0.5 * gap, 0.5 * gap, 0.8])
    lay = Layout(edges, np.zeros(4, bool))
    prof = profiles.cylinder(R=1.0)
    plan = squad_plan(lay, prof)
    assert max(plan.counts) < MAX_NODES
    q = squad_nodes(plan, prof, edges[None, :], 0.0, np.zeros(1))
    s, om, scale = q.s[0], q.Omega[0], q.absOmega[0].sum()
    w1 = -float(edges @ lay.eps)
    moments = np.array([np.sum(om), np.sum(s * om), np.sum(s * s * om)])
    assert np.all(np.abs(moments - np.pi * np.array([0.0, 1.0, -w1])) < 1e-12 * scale)


@pytest.mark.parametrize("gap", [0.0, -1e-3])
def test_zone_rule_of_touching_or_crossed_zones_stays_one_rule(gap: float) -> None:
    """A trial step can leave two zones touching or crossed: no grading (it would never reach
    the edge), one capped rule per zone, as before."""
    edges = np.array([-0.9, -0.5 * gap, 0.5 * gap, 0.8])
    plan = squad_plan(Layout(edges, np.zeros(4, bool)), profiles.cylinder(R=1.0))
    assert plan.counts == (MAX_NODES, MAX_NODES)
