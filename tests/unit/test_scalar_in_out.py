"""Vectorised methods of the results follow numpy: scalar in, scalar out; shape in, shape out."""

from __future__ import annotations

import numpy as np
import pytest

from analytic import profiles, solve_normal, solve_stick

A = 4 * (1 - 0.3**2) / 210e3
#: One point alone or in a batch: the same formula, summed in another order (measured 2e-15).
SAME_VALUE_RTOL = 1e-12


@pytest.fixture(scope="module")
def states():
    punch = profiles.union(profiles.cylinder(R=10.0, center=-3.0),
                           profiles.cylinder(R=5.0, center=3.0, lift=2e-4))
    normal = solve_normal(punch, P=100.0, A=A)
    stick2 = solve_stick(normal, mu=0.5, Q=30.0)
    stick3 = solve_stick(normal, mu=0.5, Q=-10.0, Q0=30.0)
    return normal, stick2, stick3


def methods(states):
    normal, stick2, stick3 = states
    return {"pressure": normal.pressure, "gap": normal.gap, "shear2": stick2.shear,
            "slip2": stick2.slip, "shear3": stick3.shear, "slip3": stick3.slip}


@pytest.mark.parametrize("name", ["pressure", "gap", "shear2", "slip2", "shear3", "slip3"])
def test_scalar_in_scalar_out(states, name) -> None:
    f = methods(states)[name]
    (a, b) = states[0].zones[0]
    x = np.linspace(a - 0.5 * (b - a), b + 0.5 * (b - a), 41)
    vec = f(x)
    assert vec.shape == x.shape and np.any(vec != 0)
    picks = [int(np.argmax(np.abs(vec))), 0, 20]
    for xi, vi in zip(x[picks], vec[picks], strict=True):
        for arg in (float(xi), np.float64(xi)):
            out = f(arg)
            assert np.ndim(out) == 0 and isinstance(out, float), type(out)
            assert out == pytest.approx(vi, rel=SAME_VALUE_RTOL, abs=1e-300)
    grid = x[:40].reshape(5, 8)
    assert f(grid).shape == (5, 8)
    assert np.allclose(f(grid).ravel(), vec[:40], rtol=SAME_VALUE_RTOL, atol=0)
    assert f(list(x)).shape == x.shape
    assert f(x[:0]).shape == (0,)
