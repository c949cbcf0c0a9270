"""Pure metric functions."""

from __future__ import annotations

import numpy as np
import pytest

from compare import metrics as mt


def test_edge_errors_pair_same_kind_nearest():
    an = [(-1.0, -0.5), (0.5, 1.0)]
    fe = [(-1.01, -0.49), (0.52, 0.97)]
    errs = mt.edge_errors(an, fe)
    assert np.ravel(errs) == pytest.approx([0.01, 0.01, 0.02, 0.03])


def test_edge_errors_missing_zone_is_large():
    errs = mt.edge_errors([(-1.0, -0.5), (0.5, 1.0)], [(-1.0, -0.5)])
    assert max(errs[1]) > 1.0


def test_stick_edge_error_cases():
    assert mt.stick_edge_error(None, None, 1.0) == 0.0
    assert mt.stick_edge_error((0.0, 0.2), None, 1.0) == pytest.approx(0.1)
    assert mt.stick_edge_error((0.0, 0.2), (0.01, 0.23), 2.0) == pytest.approx(0.015)


def test_relative_l2_and_floor():
    w = np.ones(4)
    assert mt.relative_l2(np.array([1.0, 1, 1, 1]), np.array([1.0, 1, 1, 2]), w) == \
        pytest.approx(1 / np.sqrt(7))
    assert mt.relative_l2(np.ones(4) * 1e-3, np.zeros(4), w, floor=1.0) == pytest.approx(2e-3)


def test_bounded_l2_is_in_units_of_the_bound():
    w = np.array([1.0, 2.0, 1.0])
    fe, an = np.array([1.0, 2.0, 3.0]), np.array([1.0, 1.0, 1.0])
    assert mt.bounded_l2(fe, an, w, 4.0) == pytest.approx(np.sqrt(2 + 4) / 4)
    assert np.isnan(mt.bounded_l2(fe, an, w, 0.0))


def test_observed_order_recovers_slope():
    h = np.array([0.1, 0.05, 0.025])
    assert mt.observed_order(h, 3 * h**1.5) == pytest.approx(1.5)


def test_richardson_exact_for_power_law():
    h = np.array([0.4, 0.2, 0.1])
    f = 2.0 + 0.7 * h**2
    val, order = mt.richardson(f)
    assert order == pytest.approx(2.0) and val == pytest.approx(2.0)


def test_regular_mask_excludes_singular_neighbourhood():
    x = np.linspace(-1, 1, 201)
    keep = mt.regular_mask(x, [(-1.0, 1.0)], [-1.0, 0.0])
    assert not keep[np.abs(x) < 0.05].any() and keep[np.abs(x - 0.5) < 0.01].all()
