"""Edge estimators of fem.results on synthetic nodal data with known edges.

A nonsingular edge has p ~ sqrt(distance) inside and a gap ~ distance**1.5 outside; the
estimators must be exact for such profiles on uniform and graded grids, whatever the position
of the edge between two nodes, and must not be fooled by the two smeared outermost nodes.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import polynomial as P

from fem.results import (
    BAND_OF_RUN,
    EDGE_FIT,
    EDGE_FIT_MAX,
    EDGE_SKIP,
    GAP_FIT_MAX,
    GAP_OF_RUN,
    OPEN,
    SLIP,
    STICK,
    _polyfit,
    contact_and_stick,
    gap_edge,
    power_root,
    runs,
    smooth_prefix,
    sqrt_edge,
)

EXACT = 1e-9  # relative to the element size: the fits are exact up to rounding


def uniform(n: int = 81, lo: float = -1.0, hi: float = 1.0) -> np.ndarray:
    return np.linspace(lo, hi, n)


def graded(n: int = 81, ratio: float = 1.03) -> np.ndarray:
    """Nodes on [-1, 1] whose spacing grows geometrically from the left."""
    d = ratio ** np.arange(n - 1)
    return -1.0 + 2.0 * np.r_[0.0, np.cumsum(d)] / d.sum()


def run_of(f: np.ndarray) -> tuple[int, int]:
    (run,) = runs(f > 0)
    return run


@pytest.mark.parametrize("grid", [uniform, graded])
@pytest.mark.parametrize("b", [0.5013, 0.5219, 0.5377, 0.5488])
def test_sqrt_edge_exact_for_sqrt_profile(grid, b):
    x = grid()
    a = -0.6
    p = 3.0 * np.sqrt(np.clip((b - x) * (x - a), 0.0, None))  # p**2 quadratic: Hertz-like
    i0, i1 = run_of(p)
    h = x[i1 + 1] - x[i1]
    assert sqrt_edge(x, p, (i0, i1), +1) == pytest.approx(b, abs=EXACT * h)
    assert sqrt_edge(x, p, (i0, i1), -1) == pytest.approx(a, abs=EXACT * h)


def test_sqrt_edge_ignores_the_smeared_outer_nodes():
    x = uniform()
    b = 0.5219
    p = np.sqrt(np.clip(b - x, 0.0, None)) * (x > -0.5)
    i0, i1 = run_of(p)
    smeared = p.copy()
    smeared[i1] *= 0.7       # the node-wise contact smears the two outermost nodes
    smeared[i1 - 1] *= 0.95
    h = x[1] - x[0]
    assert sqrt_edge(x, smeared, (i0, i1), +1) == pytest.approx(b, abs=EXACT * h)


def test_sqrt_edge_stops_at_a_kink():
    """A kink (e.g. a former stick edge) a few nodes inside must not bend the fit."""
    x = uniform()
    b, kink = 0.5219, 0.42
    f2 = np.clip(b - x, 0.0, None) + 3.0 * np.clip(kink - x, 0.0, None)
    f = np.sqrt(f2) * (x > -0.5)
    i0, i1 = run_of(f)
    h = x[1] - x[0]
    assert sqrt_edge(x, f, (i0, i1), +1) == pytest.approx(b, abs=EXACT * h)
    assert smooth_prefix(np.array([1.0, 2.0, 3.0, 4.0, 4.5, 5.0])) == 4


@pytest.mark.parametrize("grid", [uniform, graded])
@pytest.mark.parametrize("b", [0.5013, 0.5219, 0.5488])
def test_gap_edge_exact_for_three_halves_gap(grid, b):
    x = grid()
    status = np.where(x < b, STICK, OPEN)
    gap = np.where(x < b, -1e-9, 0.7 * np.clip(x - b, 0.0, None) ** 1.5)
    end = int(np.flatnonzero(status > OPEN)[-1])
    h = x[end + 1] - x[end]
    assert gap_edge(x, gap, status, end, +1) == pytest.approx(b, abs=EXACT * h)


def test_gap_edge_needs_open_nodes_of_finite_gap():
    x = uniform()
    status = np.where(x < 0.5, STICK, OPEN)
    gap = np.where(x < 0.5, 0.0, np.inf)  # beyond a sharp corner
    end = int(np.flatnonzero(status > OPEN)[-1])
    assert gap_edge(x, gap, status, end, +1) is None


@pytest.mark.parametrize("grid", [uniform, graded])
@pytest.mark.parametrize("b", [0.5013, 0.5219, 0.5488])
def test_wide_band_exact_for_sqrt_profile_on_a_long_run(grid, b):
    """A run of > 84 nodes takes a wider band (BAND_OF_RUN, up to EDGE_FIT_MAX): still exact."""
    x = grid(4001, 1.0005) if grid is graded else grid(4001)
    a = -0.6
    p = 3.0 * np.sqrt(np.clip((b - x) * (x - a), 0.0, None))
    i0, i1 = run_of(p)
    assert (i1 - i0 + 1) // BAND_OF_RUN - EDGE_SKIP >= EDGE_FIT_MAX  # the widest band
    h = x[i1 + 1] - x[i1]
    assert sqrt_edge(x, p, (i0, i1), +1) == pytest.approx(b, abs=EXACT * h)
    assert sqrt_edge(x, p, (i0, i1), -1) == pytest.approx(a, abs=EXACT * h)


@pytest.mark.parametrize("b", [0.5013, 0.5219, 0.5488])
def test_gap_edge_wide_band_exact_for_three_halves_gap(b):
    """A contact run of >= GAP_OF_RUN * GAP_WIDE nodes: quadratic of g**(2/3) past the first
    GAP_SKIP_WIDE open nodes, exact for g ~ d**1.5 (1 + d), whose g**(2/3) is not a line."""
    x = uniform(2001)
    status = np.where(x < b, STICK, OPEN)
    d = np.clip(x - b, 0.0, None)
    gap = np.where(x < b, -1e-9, 0.7 * (d * (1.0 + 0.3 * d)) ** 1.5)
    end = int(np.flatnonzero(status > OPEN)[-1])
    h = x[end + 1] - x[end]
    long_run = GAP_OF_RUN * GAP_FIT_MAX
    assert gap_edge(x, gap, status, end, +1, long_run) == pytest.approx(b, abs=EXACT * h)
    assert abs(gap_edge(x, gap, status, end, +1) - b) > 1e3 * EXACT * h  # three nodes, a line


#: A smeared tail like our FE's (issue 28, cattaneo): f**2 at node k >= 3 from the end implies an
#: edge TAIL * 2**(2 - k) elements further out (measured +0.008 / +0.004 / +0.001 at nodes 3-5
#: above the smooth part); the quadratic through nodes 3-7 extrapolates it (0.024 element on
#: this model at every h, 0.017-0.036 measured), the wide band reads through it (0.004).
TAIL, OLD_FIT_ERROR, WIDE_BAND_ERROR = 0.016, 0.015, 0.006


def smeared_hertz(n: int, phase: float):
    """Hertz f**2 = 1 - x**2 on nodes of spacing 1/n shifted by ``phase`` elements, its right
    end's nodes k >= 3 shifted outwards by the decaying tail."""
    h = 1.0 / n
    x = (np.arange(-n - 8, n + 9) + phase) * h
    f2 = np.clip(1.0 - x * x, 0.0, None)
    (run,) = runs(f2 > 0)
    k = run[1] - np.arange(x.size) + 1
    shift = np.where((k >= 3) & (f2 > 0), TAIL * 0.5 ** (k - 2.0), 0.0) * h
    return x, np.sqrt(f2 + 2.0 * x * shift), run, h


@pytest.mark.parametrize("phase", [0.1, 0.37, 0.64, 0.9])
def test_wide_band_reads_through_a_smeared_tail(phase):
    for n in (400, 800):
        x, f, run, h = smeared_hertz(n, phase)
        inward = np.arange(run[1], run[0] - 1, -1)
        nodes = inward[EDGE_SKIP:EDGE_SKIP + EDGE_FIT]
        old = power_root(x[nodes], f[nodes] ** 2, x[run[1]], -1)
        assert abs(old - 1.0) / h > OLD_FIT_ERROR
        assert abs(sqrt_edge(x, f, run, +1) - 1.0) / h < WIDE_BAND_ERROR


def cattaneo_nodes(x, a, c, mu=0.5, reverse=False):
    """Hertz pressure on [-a, a], stick zone [-c, c] (Cattaneo), optionally reversed shear."""
    p = np.sqrt(np.clip(a * a - x * x, 0.0, None))
    q = mu * (p - np.sqrt(np.clip(c * c - x * x, 0.0, None)))
    if reverse:
        q = -q
    status = np.where(p > 0, np.where(np.abs(x) < c, STICK, SLIP), OPEN).astype(np.int8)
    gap = np.where(p > 0, 0.0, np.clip(np.abs(x) - a, 0.0, None) ** 1.5)
    return p, q, status, gap


@pytest.mark.parametrize("reverse", [False, True])
@pytest.mark.parametrize("grid", [uniform, graded])
def test_contact_and_stick_exact_for_cattaneo(grid, reverse):
    x = grid(161)
    a, c, mu = 0.6071, 0.4133, 0.5
    p, q, status, gap = cattaneo_nodes(x, a, c, mu, reverse)
    zones, sticks = contact_and_stick(x, p, q, status, np.ones(x.size, bool), mu, gap)
    h = np.max(np.diff(x))
    assert np.allclose(zones, [(-a, a)], atol=1e-6 * h)
    assert np.allclose(sticks, [(-c, c)], atol=EXACT * h)


def test_stick_edge_where_the_shear_changes_sign_in_the_stick_zone():
    """Stage 3: q < 0 in the slip zones, q > 0 in the middle of the stick zone; mu p + q
    (not mu p - |q|, which has a kink where q = 0) is the sqrt-shaped function."""
    x = uniform(161)
    a, c, mu = 0.6071, 0.4133, 0.5
    p = np.sqrt(np.clip(a * a - x * x, 0.0, None))
    q = -mu * p + 2 * mu * np.sqrt(np.clip(c * c - x * x, 0.0, None))
    status = np.where(p > 0, np.where(np.abs(x) < c, STICK, SLIP), OPEN).astype(np.int8)
    assert np.any(q[np.abs(x) < c] > 0) and np.all(q[status == SLIP] < 0)
    _, sticks = contact_and_stick(x, p, q, status, np.ones(x.size, bool), mu)
    assert np.allclose(sticks, [(-c, c)], atol=EXACT * (x[1] - x[0]))


def test_singular_edge_at_the_corner_node():
    """A flat punch: p ~ 1/sqrt rising to the corner nodes, which are the edges."""
    x = uniform()
    inside = np.abs(x) <= 0.5 + 1e-12
    p = np.where(inside, 1.0 / np.sqrt(np.clip(0.25 - x * x, 0.0, None) + 0.01), 0.0)
    status = np.where(inside, STICK, OPEN).astype(np.int8)
    zones, _ = contact_and_stick(x, p, 0 * p, status, np.ones(x.size, bool), 0.5)
    assert zones == ((-0.5, 0.5),)


def test_a_kink_next_to_the_edge_falls_back_to_the_outermost_nodes():
    """A stage-3 stick zone can hold the frozen stage-2 stick edge within two elements of its
    own edge: further in, f**2 is not the edge's sqrt, the skipped nodes are off the fit, and
    the line through the two outermost nodes (on the sqrt part here) is used."""
    x = uniform()
    b, kink = 0.5219, 0.4719
    f2 = np.where(x < kink, (b - kink) + 3.0 * (kink - x), b - x)  # fit root in bounds
    f = np.sqrt(np.clip(f2, 0.0, None)) * (x > -0.5)
    i0, i1 = run_of(f)
    assert x[i1 - 1] > kink > x[i1 - 2]
    assert sqrt_edge(x, f, (i0, i1), +1) == pytest.approx(b, abs=EXACT * (x[1] - x[0]))


@pytest.mark.parametrize("deg, n", [(1, 2), (1, 3), (1, 7), (2, 3), (2, 7), (2, 40)])
def test_polyfit_is_numpys_to_the_bit(deg, n):
    """power_root's fit takes polyfit's own steps without its checks: the same coefficients."""
    rng = np.random.default_rng(n + deg)
    t = np.sort(rng.uniform(-1.0, 0.0, n))
    y = rng.uniform(0.0, 2.0, n)
    assert np.array_equal(_polyfit(t, y, deg), P.polyfit(t, y, deg))


def test_stick_flags_at_the_cone_are_slip():
    """At Q = mu P every node is at the cone (sum q = mu sum p); stick flags there are the
    return mapping's tie (AT_CONE_RTOL): no stick zone.  Just inside the cone they count."""
    x = uniform(161)
    a, mu = 0.6071, 0.5
    p = np.sqrt(np.clip(a * a - x * x, 0.0, None))
    q = mu * p
    status = np.where(p > 0, SLIP, OPEN).astype(np.int8)
    status[np.argsort(np.abs(x))[:3]] = STICK
    _, sticks = contact_and_stick(x, p, q * (1 - 1e-14), status, np.ones(x.size, bool), mu)
    assert sticks == (None,)
    _, sticks = contact_and_stick(x, p, q * (1 - 1e-6), status, np.ones(x.size, bool), mu)
    assert sticks != (None,)


def test_two_node_stick_zone_is_symmetric_with_an_element_of_uncertainty():
    """At Q = 0.999 mu P our FE left two stick nodes; the fit of two equal values put one edge on
    the slip node and the other half-way (by the sign of round-off), uncertainty 3e9 lengths. A
    stick run too short to fit (MIN_STICK_FIT) has its edge between its end node and the next."""
    from fem.results import zones_with_uncertainty

    x = uniform(160)  # nodes at +-h/2, none at 0: the two stick nodes sit symmetrically
    h, mu = x[1] - x[0], 0.3
    p = np.sqrt(np.clip(0.6 ** 2 - x * x, 0.0, None))
    status = np.where(p > 0, SLIP, OPEN).astype(np.int8)
    mid = np.argsort(np.abs(x))[:2]
    status[mid] = STICK
    q = mu * p
    q[mid] *= 0.9
    q[mid.min() - 1] *= 1 + 2e-16  # round-off of opposite signs either side
    q[mid.max() + 1] *= 1 - 2e-16
    _, sticks, _, unc = zones_with_uncertainty(x, p, q, status, np.ones(x.size, bool), mu)
    (c, d), (uc, ud) = sticks[0], unc[0]
    assert c == pytest.approx(-d, abs=1e-12 * h)
    assert uc == pytest.approx(0.5 * h) and ud == pytest.approx(0.5 * h)
    assert x[mid.min() - 1] < c < x[mid.min()] and x[mid.max()] < d < x[mid.max() + 1]
