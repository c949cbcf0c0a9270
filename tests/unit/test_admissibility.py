"""Unit tests of the normal solver's internals: where the admissibility checks sample the
deformed gap (``analytic._admissibility``), the zone-load ellipses (``analytic._contour``), and
the continuation's predictor and cycle guard (``analytic._continuation``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import analytic
from analytic import _admissibility, _continuation, _contour, _newton, profiles
from analytic._sie import Layout


@pytest.fixture
def hertz():
    sol = analytic.solve_normal(profiles.cylinder(1.0), 0.1, 1.0)
    st = _newton.fresh_state(sol._system.layout, 0.0, sol.P)
    return sol, st


def _candidates(st, sys_, profile) -> np.ndarray:
    """The gap-check candidates with ``g'`` from ``sys_`` on the runs of ``st``."""
    runs, closed = _admissibility._gap_runs(st, profile)
    gp = sys_.gap_slope(np.concatenate(runs))
    return _admissibility._gap_candidates(st, profile, runs, closed, gp)


def _with_slope(sys_, value: float):
    """The system with a constant deformed-gap slope ``g' = value`` outside the zones."""
    return SimpleNamespace(gap_slope=lambda x: np.full(np.shape(x), value),
                           layout=sys_.layout)


@pytest.mark.parametrize(("slope", "side"), [(1.0, "left"), (-1.0, "right")])
def test_gap_falling_away_from_an_outer_edge_is_checked(hertz, slope: float, side: str) -> None:
    """g' > 0 left of the zone means g falls leftwards away from the left edge (and g' < 0
    right of it, rightwards): the check must sample g just beyond that edge, and only there."""
    sol, st = hertz
    (a, b), = sol.zones
    cands = _candidates(st, _with_slope(sol._system, slope), sol.profile)
    cands = cands[np.abs(cands) > 1e-12]  # the profile's own minimum (x = 0) is inside the zone
    if side == "left":
        assert cands.size >= 1 and np.all(cands < a) and a - cands.max() < 1e-3 * (b - a)
    else:
        assert cands.size >= 1 and np.all(cands > b) and cands.min() - b < 1e-3 * (b - a)


def test_healthy_outer_gap_needs_no_samples(hertz) -> None:
    """The converged Hertz contact: g rises away from both edges, nothing to sample outside."""
    sol, st = hertz
    assert _candidates(st, sol._system, sol.profile).size == 0


def test_slope_minima_finds_the_turn_and_the_falling_ends() -> None:
    x = np.linspace(0.0, 1.0, 11)
    gp = x - 0.55  # falls first, then rises: the minimum at 0.55, and it falls at the start
    out = _admissibility._slope_minima(x, gp)
    assert out[0] == 0.0 and out[1] == pytest.approx(0.55)
    assert _admissibility._slope_minima(x, -np.ones(11)).tolist() == [0.0, 1.0]
    assert _admissibility._slope_minima(x, np.ones(11)).size == 0
    # a run across a gap ends at the next zone's edge (g = 0): falling into it needs no sample
    assert _admissibility._slope_minima(x, -np.ones(11), end_at_edge=True).tolist() == [0.0]


def test_gap_falling_into_the_next_zone_is_not_sampled() -> None:
    """Between two zones g falls towards the right zone's edge (g = 0 there): the healthy gap
    of the bi-quadratic punch needs no integral for g, while a gap that falls away from the
    left zone's edge is still sampled next to it."""
    sol = analytic.solve_normal(profiles.biquadratic(1.0, 1.0), 0.4, 1.0)
    st = _newton.fresh_state(sol._system.layout, 0.0, sol.P)
    assert _candidates(st, sol._system, sol.profile).size == 0
    (_, b1), (a2, _) = sol.zones
    cands = _candidates(st, _with_slope(sol._system, -1.0), sol.profile)
    inner = cands[(cands > b1) & (cands < a2)]
    assert inner.size == 1 and inner[0] - b1 < 1e-2 * (a2 - b1)


@pytest.mark.parametrize("gap", [1.0, 1e-2, 1e-5])
def test_zone_ellipse_is_the_bernstein_ellipse_halfway_to_the_neighbour(gap: float) -> None:
    """Foci at the zone's edges, parameter the geometric mean of 1 and the neighbour's: the
    ellipse clears the neighbouring zone by the same rate it clears its own."""
    lay = Layout(np.array([-1.0, 0.0, gap, gap + 2.0]), np.zeros(4, bool))
    (c, ax, ay), _ = _contour._zone_ellipses(lay)
    rx = 0.5
    assert c == -0.5 and ax**2 - ay**2 == pytest.approx(rx**2)
    rho = (ax + ay) / rx
    far = rx + gap  # the neighbour's edge relative to the centre
    rho_out = (far + np.sqrt(far**2 - rx**2)) / rx
    assert rho == pytest.approx(min(np.sqrt(rho_out), _contour.RHO_ISOLATED))
    assert c + ax < gap


def test_isolated_zone_ellipse() -> None:
    lay = Layout(np.array([1.0, 3.0]), np.zeros(2, bool))
    (c, ax, ay), = _contour._zone_ellipses(lay)
    assert c == 2.0 and (ax + ay) == pytest.approx(_contour.RHO_ISOLATED)


def test_predictor_is_exact_for_edges_cubic_in_log_load() -> None:
    """Through four states whose edges are cubic in log P the predictor reproduces the cubic."""
    prof = profiles.cylinder(1.0)
    loads = [0.1, 0.12, 0.15, 0.2]
    target = 0.25

    def edges(P: float) -> np.ndarray:
        u = np.log(P)
        return np.array([-1.0 - 0.1 * u - 0.01 * u**3, 1.0 + 0.2 * u + 0.02 * u**2])

    states = [_newton.State(analytic._sie.Layout(edges(P), np.zeros(2, bool)), np.zeros(0),
                            0.0, P, 0.0, 2.0) for P in loads]
    pred = _continuation._predict(states[-1], tuple(states[-2::-1]), target, prof)
    np.testing.assert_allclose(pred.layout.edges, edges(target), rtol=1e-12)


def test_predictor_raises_its_degree_while_the_corrections_shrink() -> None:
    """Eight states on a quintic path in log P: the quintic is reproduced; a linear-only
    history (two states) gives the secant."""
    prof = profiles.cylinder(1.0)
    loads = [0.1 * 1.1**k for k in range(8)]
    target = loads[-1] * 1.1

    def edges(P: float) -> np.ndarray:
        u = np.log(P) + 2.0
        return np.array([-1.0 - 0.1 * u + 0.02 * u**5, 1.0 + 0.2 * u + 0.03 * u**4])

    states = [_newton.State(analytic._sie.Layout(edges(P), np.zeros(2, bool)), np.zeros(0),
                            0.0, P, 0.0, 2.0) for P in loads]
    pred = _continuation._predict(states[-1], tuple(states[-2::-1]), target, prof)
    np.testing.assert_allclose(pred.layout.edges, edges(target), rtol=1e-10)
    secant = _continuation._predict(states[-1], (states[-2],), target, prof)
    w = (np.log(target) - np.log(loads[-2])) / (np.log(loads[-1]) - np.log(loads[-2]))
    np.testing.assert_allclose(secant.layout.edges,
                               (1 - w) * edges(loads[-2]) + w * edges(loads[-1]), rtol=1e-13)
    assert np.max(np.abs(secant.layout.edges - edges(target))) > 1e-6  # the test has teeth


def test_gap_minimum_just_before_a_ridge_is_sampled() -> None:
    """Two cylinders meeting in a ridge at x = 0 inside the gap between their zones.  g falls
    away from the left zone, turns to rise only 1e-6 before the ridge and falls beyond it (g'
    jumps down at a ridge): the minimum of g lies between the last sample before the ridge and
    the ridge, so samples just either side of every kink are needed to see it."""
    prof = profiles.union(profiles.cylinder(1.0, center=-1.0), profiles.cylinder(1.0, center=1.0))
    assert prof.ridges == (0.0,)
    lay = Layout(np.array([-1.2, -0.8, 0.8, 1.2]), np.zeros(4, bool))
    st = _newton.fresh_state(lay, 0.0, 0.1)

    def slope(x):
        x = np.asarray(x, float)
        return np.where((x > -1e-6) & (x < 0.0), 1.0, -1.0)

    cands = _candidates(st, SimpleNamespace(gap_slope=slope, layout=lay), prof)
    assert np.any((cands > -0.1) & (cands < 0.0))  # not only the kink itself (x = 0)


def test_repeated_start_layout_fails_the_step_at_once() -> None:
    """A Newton start already tried in the same step means the topology events cycle."""
    lay = Layout(np.array([-1.0, 0.0, 0.5, 1.0]), np.array([False, True, False, False]))
    starts: set[bytes] = set()
    _continuation._check_cycle(lay, starts, [])
    _continuation._check_cycle(lay.with_edges(lay.edges + 1e-3), starts, [])
    _continuation._check_cycle(Layout(lay.edges, np.zeros(4, bool)), starts, [])
    with pytest.raises(_continuation.StepFailed, match="cycles"):
        _continuation._check_cycle(Layout(lay.edges.copy(), lay.pinned.copy()), starts, [])
