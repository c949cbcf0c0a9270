"""Roache's grid convergence index (compare.verify_sequence.grid_convergence_index) on exact
power laws f_k = f* + C h_k^p: the index is Fs times the true error of the finest value, the
asymptotic-range ratio is 1, and it is refused where Richardson's extrapolation is."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.verify_sequence import GCI_SAFETY_ASSUMED, GCI_SAFETY_OBSERVED, grid_convergence_index

H = np.array([0.04, 0.02, 0.01])


@pytest.mark.parametrize("p", [1.0, 1.5, 2.0])
def test_three_values_observe_the_order_and_bound_the_error(p):
    f = 0.3 + 2.0 * H**p
    gci, order, fs, asym, reason = grid_convergence_index(f, 2.0, 0.5, 1.0)
    assert not reason and fs == GCI_SAFETY_OBSERVED
    assert order == pytest.approx(p)
    assert gci == pytest.approx(GCI_SAFETY_OBSERVED * (f[-1] - 0.3) / 0.5)
    assert asym == pytest.approx(1.0)


def test_two_values_use_the_expected_order_and_safety_3():
    f = 0.3 + 2.0 * H[:2] ** 1.0
    gci, order, fs, asym, reason = grid_convergence_index(f, 2.0, 1.0, 1.0)
    assert (order, fs, reason) == (1.0, GCI_SAFETY_ASSUMED, "")
    assert gci == pytest.approx(3.0 * (f[-1] - 0.3)) and math.isnan(asym)


@pytest.mark.parametrize("f, why", [
    ([1.0, 1.2, 1.1], "non-monotone"),          # oscillates: no asymptotic power law
    ([1.0, 1.1, 1.19], "outside"),              # differences grow: order < 0
    ([1.0, 1.5, 1.5001], "outside"),            # order ~12: noise, not a power law
])
def test_refused_where_richardson_is(f, why):
    gci, _, _, asym, reason = grid_convergence_index(f, 2.0, 1.0, 1.0)
    assert math.isnan(gci) and math.isnan(asym) and why in reason


def test_refused_without_one_refinement_ratio():
    gci, *_, reason = grid_convergence_index([1.0, 1.1, 1.12], math.nan, 1.0, 1.0)
    assert math.isnan(gci) and "not constant" in reason
