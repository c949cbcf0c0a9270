"""The near-target rules of analytic._cauchy_integrals: the graded sub-panels partition the
panel, the upsampled rule and the graded sub-panels agree where both apply, and a target's
value does not depend on the other targets evaluated with it."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import analytic
import analytic._cauchy_integrals as ci
from analytic import profiles
from analytic._traction_panels import quadrature

#: Agreement of the upsampled rule and the graded sub-panels, relative to max |F| (both are
#: accurate to ~RHO_NEAR^-32 = 5e-16 of the integrand's scale; observed ~1e-15).
RULES_AGREE = 1e-13


@pytest.fixture(scope="module")
def state():
    A, P, mu = 4 * (1 - 0.3**2) / 2.0, 1.0, 0.4
    normal = analytic.solve_normal(profiles.cylinder(10.0), P, A)
    return analytic.solve_stick(normal, mu, 0.5 * mu * P)


def near_pairs(state, n: int = 4000, seed: int = 5):
    (a, b), = state.normal.zones
    rng = np.random.default_rng(seed)
    w = rng.uniform(1.2 * a, 1.2 * b, n) + 1j * (b - a) * 10.0 ** rng.uniform(-9, 0, n)
    pan = quadrature(state).panels
    it, jp, up = ci._near_pairs(pan, w)
    return pan, w[it], jp, up


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_graded_sub_panels_partition_the_panel(seed):
    rng = np.random.default_rng(seed)
    n = 500
    tc = rng.uniform(-1.0, 1.0, n)
    tc[:50] = -1.0  # feet on the panel ends
    tc[50:100] = 1.0
    d = 10.0 ** rng.uniform(-13, 0.5, n)
    lo, hi = -1.0 - tc, 1.0 - tc
    left = ci._side_levels(-lo, d)
    total = left + ci._side_levels(hi, d)
    for m in np.unique(total):
        k = total == m
        a, b = ci._subpanels(lo[k], hi[k], d[k], left[k], int(m))
        assert np.all(a[:, 0] == lo[k]) and np.all(b[:, -1] == hi[k])
        assert np.all(b[:, :-1] == a[:, 1:])  # contiguous
        assert np.all(b >= a)
        # every sub-panel off the foot is at least its own width away from it (ratio GRADE)
        width, dist = b - a, np.minimum(np.abs(a), np.abs(b))
        off = (a > 0) | (b < 0)
        assert np.all(dist[off] >= width[off] / (ci.GRADE - 1) * (1 - 1e-12))


def test_upsampled_and_graded_rules_agree(state):
    pan, w, jp, up = near_pairs(state)
    ok = ci._upsampled_suffices(up)
    assert 0 < ok.sum() < ok.size  # both kinds of targets are present
    F1, dF1 = ci._upsampled_sums(ci.upsample(pan), w[ok], jp[ok])
    F2, dF2 = ci._graded(pan, w[ok], jp[ok], up[ok])
    assert np.max(np.abs(F1 - F2)) < RULES_AGREE * np.max(np.abs(F2))
    assert np.max(np.abs(dF1 - dF2)) < RULES_AGREE * np.max(np.abs(dF2))


def test_plain_panel_sums_fail_where_the_graded_rule_is_used(state):
    """The graded targets are the ones the plain 16-node sums cannot do (else the tiers would
    be pointless): their plain sums err by far more than RULES_AGREE."""
    pan, w, jp, up = near_pairs(state)
    fine = ~ci._upsampled_suffices(up)
    F1, _ = ci._block_sums(pan, w[fine], jp[fine])
    F2, _ = ci._graded(pan, w[fine], jp[fine], up[fine])
    assert np.max(np.abs(F1 - F2)) > 1e3 * RULES_AGREE * np.max(np.abs(F2))


def test_a_target_has_the_same_bits_in_any_set_of_targets(state):
    (a, b), = state.normal.zones
    rng = np.random.default_rng(11)
    x = rng.uniform(1.5 * a, 1.5 * b, 900)
    y = -(b - a) * np.concatenate([rng.uniform(0, 1, 450), 10.0 ** rng.uniform(-12, -3, 450)])
    full = analytic.stress(state, x, y, nu=0.3)
    for sub in (slice(0, 1), slice(3, 5), slice(100, 700, 7), slice(None, None, -1)):
        part = analytic.stress(state, x[sub], y[sub], nu=0.3)
        for c in ("sxx", "syy", "sxy"):
            assert getattr(part, c).tobytes() == getattr(full, c)[sub].tobytes()


#: Principal values on the surface with the near panels on the surface itself against the
#: lifted evaluation of every panel (error O(e^2) of the lift, ~1e-12 of the density scale;
#: observed 1.3e-13 of max |PV| here, 5e-14 of max |sxx| on the cattaneo states).
AXIS_AGREE = 1e-11


def surface_points(state, n: int = 1500, seed: int = 7) -> np.ndarray:
    (a, b), = state.normal.zones
    rng = np.random.default_rng(seed)
    return np.r_[rng.uniform(a - 0.3 * (b - a), b + 0.3 * (b - a), n), list(state.stick_zones[0])]


def test_surface_principal_values_match_the_lifted_ones(state):
    """analytic.surface_stress's principal values (near panels on the surface, symmetric about
    the pole) agree with every panel taken at the lift, for points inside and outside the
    panels; the stick edges (sub-interval ends) keep the lift and its bits."""
    stress_mod = importlib.import_module("analytic.stress")
    quad = quadrature(state)
    x = surface_points(state)
    pan = quad.panels
    ends = np.unique(np.r_[pan.lo, pan.hi])
    span = state.normal.zones[0][1] - state.normal.zones[0][0]
    dist = np.min(np.abs(x[:, None] - ends[None, :]), axis=1)
    e = stress_mod.SURFACE_LIFT * np.maximum(dist, stress_mod.SURFACE_LIFT_MIN * span)
    lifted = ci.principal_values(quad, x, e, np.zeros(x.size, bool))
    on = stress_mod._principal_values(state, quad, x)
    assert np.max(np.abs(on - lifted)) < AXIS_AGREE * np.max(np.abs(lifted))
    assert np.array_equal(on[-2:], lifted[-2:])
    assert np.mean(np.any(on != lifted, axis=1)) > 0.9  # nearly every point on the surface


def test_surface_principal_values_have_the_same_bits_in_any_set(state):
    quad = quadrature(state)
    x = surface_points(state)
    e = 1e-9 * np.ones(x.size)
    axis = np.arange(x.size) % 3 > 0
    full = ci.principal_values(quad, x, e, axis)
    for sub in (slice(0, 1), slice(3, 5), slice(100, 700, 7), slice(None, None, -1)):
        part = ci.principal_values(quad, x[sub], e[sub], axis[sub])
        assert part.tobytes() == full[sub].tobytes()
