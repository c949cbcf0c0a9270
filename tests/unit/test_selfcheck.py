"""The a-posteriori check of normal solutions (analytic.selfcheck) on closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from analytic import profiles
from analytic.errors import ConvergenceError
from analytic.selfcheck import (
    APPROACH_TOL,
    EDGE_ROUNDING,
    HEIGHT_ROUNDING,
    LOAD_TOL,
    _allowances,
    check_normal,
    graded_half,
)

RULE_TOL = 1e-10
"""Load figures of exact closed-form pressures (measured: 2e-11 on the punch's 1/sqrt ends)."""
RULE_APPROACH_TOL = 2e-9
"""Spread of delta / (A P) for exact pressures (measured 6.4e-10 on Hertz: the log kernel at the
edges, LOG_DEPTH = 4)."""


def hertz_pressure(a: float, P: float):
    """Hertz: ``p = 2P/(pi a^2) sqrt(a^2 - x^2)``, ``a^2 = 2 A R P / pi`` (R = 1)."""
    return lambda x: 2 * P / (np.pi * a * a) * np.sqrt(np.maximum(a * a - x * x, 0.0))


def punch_pressure(b: float, P: float):
    """Sharp flat punch on [-b, b]: ``p = P / (pi sqrt(b^2 - x^2))``."""
    return lambda x: P / (np.pi * np.sqrt(b * b - x * x))


@pytest.mark.parametrize("alpha", [-0.5, 0.5])
def test_graded_half_integrates_edge_powers(alpha: float) -> None:
    x, w = graded_half(1.0, 0.5, -1.0, 1e-3)
    assert np.all((x > 0.5) & (x < 1.0))
    assert np.sum(w * (1.0 - x) ** alpha) == pytest.approx(0.5 ** (1 + alpha) / (1 + alpha),
                                                             rel=1e-13)


def test_closed_forms_pass_with_small_figures() -> None:
    P, A = 1.0, 1.0
    a = np.sqrt(2 * A * P / np.pi)
    figs = check_normal(profiles.cylinder(1.0), [(-a, a)], [(False, False)], [P], P, 0.0, 0.0, A,
                        hertz_pressure(a, P))
    assert figs.load < RULE_TOL and figs.approach < RULE_APPROACH_TOL and figs.min_gap == 0.0
    figs = check_normal(profiles.flat_punch(-1, 1), [(-1.0, 1.0)], [(True, True)], [P], P, 0.0,
                        0.0, A, punch_pressure(1.0, P))
    assert figs.load < RULE_TOL and figs.approach < RULE_APPROACH_TOL and figs.moment < RULE_TOL


def test_a_wrong_pressure_is_caught() -> None:
    P, A = 1.0, 1.0
    a = np.sqrt(2 * A * P / np.pi)
    with pytest.raises(ConvergenceError, match="load"):
        check_normal(profiles.cylinder(1.0), [(-a, a)], [(False, False)], [P], P, None, 0.0, A,
                     lambda x: (1 + 10 * LOAD_TOL) * hertz_pressure(a, P)(x))
    wide = 1.001 * a  # the Hertz pressure on a wider zone: delta varies across it
    with pytest.raises(ConvergenceError, match="approach"):
        check_normal(profiles.cylinder(1.0), [(-wide, wide)], [(False, False)], [P], P, None,
                     0.0, A, hertz_pressure(wide, P))
    assert APPROACH_TOL < 1e-3


def test_contact_beyond_a_corner_step_is_caught() -> None:
    prof = profiles.union(profiles.flat_punch(-1, 1), profiles.cylinder(1.0, center=4, lift=0.5))
    with pytest.raises(ConvergenceError, match="sharp corner"):
        check_normal(prof, [(-1.01, 1.0)], [(False, True)], [1.0], 1.0, None, 0.0, 1.0,
                     punch_pressure(1.0, 1.0))


def test_errors_the_old_tolerances_accepted_are_caught() -> None:
    """Before issue 29 the tolerances were 1e-6 P / 1e-5 A P on tabulated splines and 1e-7 A P
    on the approach: a spline's pressure 1e-7 too large passed, and so did a Hertz pressure on a
    zone 1e-7 wider than its own (delta spread 6e-8 A P); both fail now, 0.3 LOAD_TOL passes."""
    P, A = 1.0, 1.0
    a = np.sqrt(2 * A * P / np.pi)
    x = np.linspace(-2.0, 2.0, 41)
    for prof in (profiles.cylinder(1.0), profiles.tabulated(x, x * x / 2)):
        args = (prof, [(-a, a)], [(False, False)], [P], P, None, 0.0, A)
        with pytest.raises(ConvergenceError, match="load"):
            check_normal(*args, lambda x: (1 + 1e-7) * hertz_pressure(a, P)(x))
        assert check_normal(*args, lambda x: (1 + 0.3 * LOAD_TOL) * hertz_pressure(a, P)(x)
                            ).load < LOAD_TOL
    wide = (1 + 1e-7) * a
    with pytest.raises(ConvergenceError, match="approach"):
        check_normal(profiles.cylinder(1.0), [(-wide, wide)], [(False, False)], [P], P, None,
                     0.0, A, hertz_pressure(wide, P))


def test_allowances_follow_the_rounding_of_edges_and_heights() -> None:
    """An edge d past a kink rounds the load by eps |x| / d (EDGE_ROUNDING); zones far apart on
    a steep profile are interconnected to 1e-13 of the relief |h'| span (HEIGHT_ROUNDING); a
    Hertz zone gets neither."""
    a = np.sqrt(2 / np.pi)
    hertz = _allowances(profiles.cylinder(1.0), [(-a, a)], 0.0, 1.0, 1.0, np.linspace(-a, a, 9))
    assert hertz.load < 1e-14 and hertz.height < 1e-12
    punch = profiles.flat_punch(-1.0, 1.0, corner_radius=0.5)
    d = 4.1e-9
    corner = _allowances(punch, [(-1 - d, 1 + d)], 0.0, 1.0, 1e-12, np.zeros(0))
    assert corner.load == pytest.approx(EDGE_ROUNDING * np.finfo(float).eps * (1 + d) / d)
    dw = profiles.double_wedge(1.0, 0.11, 0.07)
    x = np.array([-1.0 - 1e-6, -1.0 + 1e-6, 1.0 - 1e-6, 1.0 + 1e-6])
    wedges = _allowances(dw, [(-1.0 - 5e-6, -1.0 + 5e-6), (1.0 - 5e-6, 1.0 + 5e-6)], 0.0, 1.0,
                         1e-6, x)
    assert wedges.height == pytest.approx(HEIGHT_ROUNDING * 0.5 * (np.tan(0.11) + np.tan(0.07))
                                          * (2 + 1e-5) / 1e-6)
