"""Edge estimators on noisy nodal data (another code's mortar pressure ripples from node to node)
and the stick-zone rule against stray stick flags.

The data are exact closed forms sampled at nodes (Hertz p = sqrt(a^2 - x^2); Cattaneo q = mu (p -
sqrt(c^2 - x^2))), so the true edges are known; the noise is multiplicative (a fraction of the
local value), at several node spacings h and edge phases (where the edge falls between nodes).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import fem.results as R
from fem.results import (
    OPEN,
    SLIP,
    STICK,
    _band,
    _wls_roots,
    band_edge,
    contact_and_stick,
    edge_estimate,
    is_noisy,
    runs,
    sqrt_edge,
    stick_edge_estimate,
    zones_with_uncertainty,
)

#: Edge error (elements) of edge_estimate on Hertz with a +-2 % node-to-node ripple (period 2 or
#: 3), h = a/20, a/40, a/80, 20 phases each: measured 0.046.
RIPPLE_EDGE_ACCURACY = 0.05
#: The same with +-1 % uniform random noise: 95th percentile measured 0.019 (max 0.060 at
#: h = a/20); the estimator's uncertainty covers the true error in >= 99 % of the samples.
RANDOM_EDGE_P95, RANDOM_COVERED = 0.05, 0.97
#: sqrt_edge (fit of nodes 3-7 from the end) on the alternating ripple: measured up to 0.15
#: element at h = a/40 (the issue saw 0.12 and 0.21 on Kratos T3 results).
OLD_RIPPLE_ERROR = 0.1
#: Stick edges on Cattaneo (c/a = 0.4, 0.63, 0.8) with a +-2 % ripple common to p and the
#: reduced-problem pressure (q = mu (p - p*) sampled with the same ripple), h = a/40 and a/80,
#: 10 phases: measured 0.042 element, always within the uncertainty.
STICK_RIPPLE_ACCURACY = 0.05
SPACINGS = (20, 40, 80)
PHASES = np.linspace(0.0, 1.0, 21)[:-1]


def ripple(k: np.ndarray, kind: str, rng: np.random.Generator) -> np.ndarray:
    if kind == "alternating":
        return 0.02 * (-1.0) ** k
    if kind == "period3":
        return 0.02 * np.cos(2 * np.pi * k / 3)
    return rng.uniform(-0.01, 0.01, k.size)


def hertz(n: int, phase: float, kind: str | None, rng=None):
    """Nodes of spacing h = 1/n around the zone [-1, 1], shifted by ``phase`` elements."""
    h = 1.0 / n
    x = (np.arange(-n - 5, n + 6) + phase) * h
    p = np.sqrt(np.clip(1.0 - x * x, 0.0, None))
    if kind:
        p = p * (1.0 + ripple(np.arange(x.size), kind, rng))
    return x, p, h


def edge_errors(kind: str, rng=None) -> tuple[np.ndarray, np.ndarray]:
    """(|error| / h, covered by the uncertainty) over spacings, phases and both edges."""
    err, cov = [], []
    for n in SPACINGS:
        for phase in PHASES:
            x, p, h = hertz(n, phase, kind, rng)
            (run,) = runs(p > 0)
            for step in (-1, 1):
                e, u = edge_estimate(x, p, run, step)
                err.append(abs(e - step) / h)
                cov.append(abs(e - step) <= u)
    return np.array(err), np.array(cov)


@pytest.mark.parametrize("kind", ["alternating", "period3"])
def test_edge_with_ripple_within_a_twentieth_element_and_covered(kind):
    err, cov = edge_errors(kind)
    assert err.max() <= RIPPLE_EDGE_ACCURACY, err.max()
    assert cov.all()


def test_edge_with_random_noise():
    err, cov = edge_errors("random", np.random.default_rng(7))
    assert np.percentile(err, 95) <= RANDOM_EDGE_P95
    assert cov.mean() >= RANDOM_COVERED, cov.mean()


def test_the_old_fit_extrapolates_the_ripple():
    """What the band estimator fixes: the fit of five inner nodes puts edges 0.2+ element off."""
    worst = 0.0
    for phase in PHASES:
        x, p, h = hertz(40, phase, "alternating")
        (run,) = runs(p > 0)
        worst = max(worst, abs(sqrt_edge(x, p, run, 1) - 1.0) / h)
    assert worst > OLD_RIPPLE_ERROR


@pytest.mark.parametrize("phase", [0.0, 0.37, 0.81])
def test_smooth_data_keep_sqrt_edge_exactly(phase):
    """One rule for both codes: smooth nodal data (our own FE) are not noisy, and the estimate
    is sqrt_edge's to the last bit; only the uncertainty is added."""
    x, p, h = hertz(40, phase, None)
    (run,) = runs(p > 0)
    for step in (-1, 1):
        assert not is_noisy(x, p, run, step)
        e, u = edge_estimate(x, p, run, step)
        assert e == sqrt_edge(x, p, run, step)
        assert 0 <= u < 0.01 * h


@pytest.mark.parametrize("n", [12, 5])
def test_band_fits_skipping_end_nodes_are_the_fits_of_the_shorter_data(n):
    """_wls_roots fits y(t) once per number k of skipped end points, all k from one stacked QR:
    each fit equals, to the last bit, the fit of the data without those points (n = 5:
    quadratics and a line through the last 3 points); an exact quadratic gives its root next to
    the end and a zero standard deviation."""
    t0 = 0.37
    t = -np.arange(float(n))
    y = (t0 - t) * (1.0 - 0.03 * t)  # falls towards +t through t0; its other root is far
    sig = np.random.default_rng(3).uniform(0.5, 2.0, n)
    for k, fit in enumerate(_wls_roots(t, y, sig, 3)):
        if n - k >= 4:  # a quadratic: exact
            assert fit[0] == pytest.approx(t0, abs=1e-12)
            assert fit[1] < 1e-9
    noisy = y * (1.0 + 0.01 * np.random.default_rng(4).uniform(-1, 1, n))
    fits = _wls_roots(t, noisy, sig, 3)
    for k in range(3):
        assert fits[k] == _wls_roots(t[k:], noisy[k:], sig[k:], 1)[0]
        assert fits[k][1] > 0


def band_edge_one_band_at_a_time(x, f, run, step, scale=None) -> tuple[tuple, int]:
    """band_edge as first written (each band's fits its own _wls_roots, the half band's only
    when needed), and how many times the band was halved."""
    nodes = _band(run, step, np.maximum(f, 0.0))
    fit, halved = one_band(x, f, nodes, step, scale), 0
    while nodes.size // 2 >= R.BAND_MIN:
        nodes = nodes[:nodes.size // 2]
        half = one_band(x, f, nodes, step, scale)
        if math.isfinite(fit[0]) and math.isfinite(half[0]) and abs(fit[0] - half[0]) <= \
                math.hypot(fit[1], half[1]) * R.BAND_HALVE:
            return fit, halved
        fit, halved = half, halved + 1
    return fit, halved


def one_band(x, f, nodes, step, scale):
    end = nodes[0]
    if nodes.size < 2 or not 0 <= end + step < x.size:
        return math.nan, math.nan
    h = abs(float(x[end + step] - x[end]))
    t = (x[nodes] - x[end]) * step / h
    fn = np.maximum(f[nodes], 0.0)
    sc = np.abs(fn if scale is None else scale[nodes])
    floor = R.BAND_NOISE_FLOOR * float(np.max(sc)) or 1.0
    sig = np.maximum(fn, floor) * np.maximum(sc, floor)
    fits = _wls_roots(t, fn ** 2, sig, R.BAND_SKIPS)
    k = next((k for k in range(R.BAND_SKIPS - 1) if fits[k] and fits[k + 1] and
              abs(fits[k][0] - fits[k + 1][0]) <= R.BAND_COVER * math.hypot(
                  fits[k][1], fits[k + 1][1]) + R.BAND_AGREE), None)
    if k is None:
        k = next((j for j in range(R.BAND_SKIPS - 1, -1, -1) if fits[j]), None)
        if k is None:
            return math.nan, math.nan
    t0, sd = fits[k]
    nxt = fits[k + 1][0] if k + 1 < R.BAND_SKIPS and fits[k + 1] else t0
    return float(x[end]) + step * h * t0, h * math.hypot(R.BAND_COVER * sd, nxt - t0)


def test_band_edge_solves_the_halved_bands_together_as_one_at_a_time():
    """band_edge fits a band and its halves from one stacked QR: the same edges and
    uncertainties to the last bit as fitting one band after the other, on noisy Hertz
    pressures, the same with a kink 6 elements in (where the band is halved) or with the noise
    carried by a larger magnitude (the weights' floor then differs between a band and its half),
    and on stage-3 stick data."""
    halved = 0
    for phase in PHASES[::4]:
        x, p, _ = hertz(40, phase, "period3")
        (run,) = runs(p > 0)
        kinked = p * (1.0 + 2.0 * np.maximum(0.0, 0.85 - np.abs(x)))
        xs, ps, qs, status, _ = unloaded(40, phase, 0.63, 0.8)
        (stick,) = runs(status == STICK)
        f = np.maximum(0.3 * ps + qs, 0.0)  # mu p - s q, s = -1: reverse slip
        for step in (-1, 1):
            for args in ((x, p, run, step), (x, kinked, run, step), (x, p, run, step, 5 * p),
                         (xs, f, stick, step, 0.3 * ps)):
                ref, times = band_edge_one_band_at_a_time(*args)
                assert np.array_equal(band_edge(*args), ref, equal_nan=True)
                halved += times
                x_, f_, run_, _, scale = (*args, None)[:5]
                bands = [_band(run_, step, np.maximum(f_, 0.0))]
                while bands[-1].size // 2 >= R.BAND_MIN:
                    bands.append(bands[-1][:bands[-1].size // 2])
                got = list(R._band_fits(x_, f_, bands, step, scale))
                want = [one_band(x_, f_, b, step, scale) for b in bands]
                assert np.array_equal(got, want, equal_nan=True)
    assert halved >= 5


def cattaneo(n: int, phase: float, c: float, mu: float = 0.3, noisy: bool = True):
    h = 1.0 / n
    x = (np.arange(-n - 5, n + 6) + phase) * h
    r = 0.02 * (-1.0) ** np.arange(x.size) if noisy else 0.0
    p = np.sqrt(np.clip(1.0 - x * x, 0.0, None)) * (1.0 + r)
    p_star = np.sqrt(np.clip(c * c - x * x, 0.0, None)) * (1.0 + r)
    q = mu * (p - p_star)
    status = np.where(p > 0, np.where(np.abs(x) < c, STICK, SLIP), OPEN).astype(np.int8)
    return x, p, q, status, h


@pytest.mark.parametrize("n", [40, 80])
def test_stick_edge_with_ripple(n):
    mu = 0.3
    for c in (0.4, 0.63, 0.8):
        for phase in PHASES[::2]:
            x, p, q, status, h = cattaneo(n, phase, c, mu)
            (run,) = runs(status == STICK)
            for step in (-1, 1):
                e, u = stick_edge_estimate(x, p, q, mu, run, step)
                assert abs(e - step * c) / h <= STICK_RIPPLE_ACCURACY
                assert abs(e - step * c) <= u


#: Stage-3 stick edges (Cattaneo unloaded: stick zone |x| < c3 around the frozen stage-2 one
#: |x| < c) with the +-2 % ripple inside the stage-2 stick zone only (Kratos' stage 3: smooth
#: between the two edges, noisy inside): mu p - s q = 2 mu sqrt(c3^2 - x^2) is one smooth branch
#: up to its peak at c; the band fit across that kink put the edge 0.74 element off (h = a/40),
#: on the smooth branch it is exact to round-off (measured 0.000, c3 - c = 7-11 elements).
STAGE3_STICK_ACCURACY = 0.05


def unloaded(n: int, phase: float, c: float, c3: float, mu: float = 0.3):
    """Cattaneo unloaded from Q0 (stick |x| < c) by dQ: reverse slip beyond c3 (a = p0 = 1)."""
    h = 1.0 / n
    x = (np.arange(-n - 5, n + 6) + phase) * h
    r = np.where(np.abs(x) < c, 0.02 * (-1.0) ** np.arange(x.size), 0.0)
    p = np.sqrt(np.clip(1.0 - x * x, 0.0, None)) * (1.0 + r)
    q = mu * (-p + 2.0 * np.sqrt(np.clip(c3 * c3 - x * x, 0.0, None))
              - np.sqrt(np.clip(c * c - x * x, 0.0, None)) * (1.0 + r))
    status = np.where(p > 0, np.where(np.abs(x) < c3, STICK, SLIP), OPEN).astype(np.int8)
    return x, p, q, status, h


@pytest.mark.parametrize("n", [40, 80])
@pytest.mark.parametrize("c3", [0.8, 0.9])
def test_stage3_stick_edge_with_the_frozen_stick_edge_inside(n, c3):
    mu, c = 0.3, 0.63
    for phase in PHASES[::2]:
        x, p, q, status, h = unloaded(n, phase, c, c3, mu)
        (run,) = runs(status == STICK)
        assert is_noisy(x, np.maximum(mu * p + q, 0.0), run, 1)
        for step in (-1, 1):
            e, u = stick_edge_estimate(x, p, q, mu, run, step)
            assert abs(e - step * c3) / h <= STAGE3_STICK_ACCURACY
            assert abs(e - step * c3) <= u + 1e-9 * h


def test_every_edge_carries_its_uncertainty():
    x, p, q, status, h = cattaneo(40, 0.3, 0.63)
    zones, sticks, u_zones, u_sticks = zones_with_uncertainty(
        x, p, q, status, np.ones(x.size, bool), 0.3)
    assert len(u_zones) == len(zones) == 1 and len(u_sticks) == len(sticks) == 1
    assert all(0 <= u < 0.2 * h for u in u_zones[0] + u_sticks[0])
    assert abs(zones[0][1] - 1.0) <= u_zones[0][1] and abs(sticks[0][1] - 0.63) <= u_sticks[0][1]


# ---------------------------------------------------------------------------------------------
# the stick-zone rule: one flipped flag at each end of a zone
# ---------------------------------------------------------------------------------------------
#: A flag flipped at a stick zone's own edge moves the located stick edge by at most this many
#: elements (the edge comes from mu p - |q|, not from the flags: a slip-flagged node where it is
#: clearly positive stays in the run, the fit skips the two outermost nodes): measured 0 (to
#: round-off) on smooth Cattaneo data, h = a/40.
FLIPPED_AT_STICK_EDGE = 1e-9


def clean(phase: float = 0.3):
    return cattaneo(40, phase, 0.63, noisy=False)


def sticks_of(x, p, q, status):
    return contact_and_stick(x, p, q, status, np.ones(x.size, bool), 0.3)[1]


@pytest.mark.parametrize("side", [0, -1])
def test_stray_stick_flag_at_the_contact_edge_does_not_extend_the_stick_zone(side):
    """The issue's case: the low-pressure node at a contact edge flagged stick (a noisy flag,
    or |q| <= mu p at p ~ 0) would extend the stick run to the contact edge."""
    x, p, q, status, h = clean()
    ref = sticks_of(x, p, q, status)
    flipped = status.copy()
    flipped[np.flatnonzero(status > OPEN)[side]] = STICK
    assert sticks_of(x, p, q, flipped) == ref


@pytest.mark.parametrize("side", [0, -1])
def test_lone_stick_flag_at_an_edge_of_a_full_slip_zone(side):
    x, p, q, status, h = clean()
    full_slip = np.where(status > OPEN, SLIP, OPEN).astype(np.int8)
    assert sticks_of(x, p, mu_q(p), full_slip) == (None,)
    full_slip[np.flatnonzero(full_slip > OPEN)[side]] = STICK
    assert sticks_of(x, p, mu_q(p), full_slip) == (None,)


def mu_q(p: np.ndarray) -> np.ndarray:
    return 0.3 * p


@pytest.mark.parametrize("side", [0, -1])
@pytest.mark.parametrize("flip", ["slip node to stick", "stick node to slip"])
def test_flipped_flag_at_the_stick_edge_keeps_the_edge(side, flip):
    x, p, q, status, h = clean()
    ref = sticks_of(x, p, q, status)[0]
    stick = np.flatnonzero(status == STICK)
    node = stick[side] + (1 if side == -1 else -1) if flip.startswith("slip") else stick[side]
    flipped = status.copy()
    flipped[node] = STICK if flip.startswith("slip") else SLIP
    got = sticks_of(x, p, q, flipped)[0]
    assert abs(got[side] - ref[side]) / h <= FLIPPED_AT_STICK_EDGE
    assert got[1 + side] == ref[1 + side]


def test_a_stick_zone_in_the_middle_of_one_node_is_kept():
    """Near full slip a genuine stick zone may hold one node: away from the zone's ends it is
    kept (only a lone flag at a near-zero-pressure end is a stray flag)."""
    x, p, q, status, h = clean()
    one = np.where(status > OPEN, SLIP, OPEN).astype(np.int8)
    mid = int(np.argmax(p))
    one[mid] = STICK
    got = sticks_of(x, p, q, one)
    assert got[0] is not None and got[0][0] < x[mid] < got[0][1]
