"""Unit tests of ``analytic.profiles``: values, slopes, kinks/corners, union, tabulated, minima.

Each constructor is checked against its defining formula (given in its docstring / issue 2),
its slope against a central finite difference of ``h0`` and its curvature against one of the
slope, so a wrong derivative (which the solver integrates) is caught here.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from analytic import InputError, profiles

ROUNDOFF = 1e-13
"""Relative tolerance for evaluating a closed-form profile (a few ulps)."""
FD_STEP = 1e-6
"""Central-difference step: truncation ~ h^2 |h'''| ~ 1e-12, cancellation ~ 1e-16 / h."""
FD_TOL = 1e-7
"""Slope agreement with the central difference (truncation plus cancellation, with margin)."""

CASES = {
    "cylinder": (profiles.cylinder(0.7, center=0.2, lift=0.05),
                 lambda x: (x - 0.2) ** 2 / 1.4 + 0.05),
    "wedge": (profiles.wedge(0.1, 0.3, apex=0.4, lift=0.0),
              lambda x: np.where(x < 0.4, np.tan(0.1) * (0.4 - x), np.tan(0.3) * (x - 0.4))),
    "biquadratic": (profiles.biquadratic(1.2, 0.8),
                    lambda x: (x**2 - 1.44) ** 2 / (8 * 0.8 * 1.44)),
    "double_wedge": (profiles.double_wedge(1.0, 0.11, 0.07),
                     lambda x: np.where(np.abs(x) <= 1.0, np.tan(0.11) * (1 - np.abs(x)),
                                        np.tan(0.07) * (np.abs(x) - 1))),
    "rounded_punch_parabolic": (
        profiles.flat_punch(-0.5, 0.5, corner_radius=2.0, corner_shape="parabolic"),
        lambda x: np.maximum(np.abs(x) - 0.5, 0.0) ** 2 / 4.0),
    "rounded_punch_circular": (
        profiles.flat_punch(-0.5, 0.5, corner_radius=2.0),
        lambda x: np.where(np.abs(x) <= 2.5,
                           2.0 - np.sqrt(np.clip(4.0 - np.maximum(np.abs(x) - 0.5, 0) ** 2,
                                                 0, None)), np.inf)),
}


def sample(prof: profiles.Profile, n: int = 301) -> np.ndarray:
    """Points in the support away from kinks and corners (where slopes are one-sided)."""
    lo, hi = prof.support
    lo = max(lo, -3.0)
    hi = min(hi, 3.0)
    x = np.linspace(lo, hi, n)[1:-1]
    marks = np.asarray(list(prof.kinks) + list(prof.corners) + [-0.5, 0.5])
    return x[np.min(np.abs(x[:, None] - marks[None, :]), axis=1) > 10 * FD_STEP]


@pytest.mark.parametrize("name", CASES)
def test_profile_matches_its_formula(name: str) -> None:
    prof, formula = CASES[name]
    x = sample(prof)
    np.testing.assert_allclose(prof.h0(x), formula(x), rtol=ROUNDOFF, atol=ROUNDOFF)
    assert np.all(prof.h0(x) >= -ROUNDOFF)  # expanded polynomials cancel to ~1e-17 at roots


@pytest.mark.parametrize("name", CASES)
def test_slope_and_curvature_match_finite_differences(name: str) -> None:
    prof, _ = CASES[name]
    x = sample(prof)
    if name == "rounded_punch_circular":
        x = x[np.abs(x) < 2.4]  # the arc's slope is unbounded at its vertical end
    fd = (prof.h0(x + FD_STEP) - prof.h0(x - FD_STEP)) / (2 * FD_STEP)
    assert np.all(np.abs(prof.dh0(x) - fd) <= FD_TOL * (1 + np.abs(fd)))
    fd2 = (prof.dh0(x + FD_STEP) - prof.dh0(x - FD_STEP)) / (2 * FD_STEP)
    assert np.all(np.abs(prof.d2h0(x) - fd2) <= FD_TOL * (1 + np.abs(fd2)))


def test_biquadratic_touches_at_pm_c_with_radius_R() -> None:
    c, R = 1.2, 0.8
    prof = profiles.biquadratic(c, R)
    np.testing.assert_allclose(prof.h0(np.array([-c, c])), 0.0, atol=ROUNDOFF)
    np.testing.assert_allclose(prof.d2h0(np.array([-c, c])), 1 / R, rtol=ROUNDOFF)
    mins = prof.local_minima()
    assert [m[0] for m in mins] == pytest.approx([-c, c], abs=1e-12)


def test_sharp_flat_punch_has_corners_and_no_support_beyond() -> None:
    prof = profiles.flat_punch(-0.3, 0.6, lift=0.0)
    assert prof.corners == (-0.3, 0.6)
    assert prof.support == (-0.3, 0.6)
    assert np.all(np.isinf(prof.h0(np.array([-0.31, 0.61]))))
    assert np.all(prof.h0(np.array([-0.3, 0.0, 0.6])) == 0.0)
    assert prof.local_minima() == [(-0.3, 0.6, 0.0)]


def test_rounded_punch_is_C1_at_the_tangent_points() -> None:
    for shape in ("circular", "parabolic"):
        prof = profiles.flat_punch(-0.5, 0.5, corner_radius=1.0, corner_shape=shape)
        assert prof.corners == ((-1.5, 1.5) if shape == "circular" else ())  # the arcs' ends
        for x0 in (-0.5, 0.5):
            left, right = prof.dh0(np.array([x0 - 1e-9, x0 + 1e-9]))
            assert abs(left) < 1e-8 and abs(right) < 1e-8


def test_circular_corner_is_vertical_at_its_ends_without_a_warning() -> None:
    """The arc's slope and curvature are infinite at its vertical ends (the tilted-punch search
    brackets its minimum with them): +-inf by design, not a divide-by-zero warning."""
    arc = profiles.flat_punch(-0.5, 0.5, corner_radius=1.0).pieces[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        slope, curvature = arc.dh(np.array([1.5])), arc.d2h(np.array([1.5]))
        assert arc.dh(np.array([0.5]))[0] == 0.0  # its other end: tangent to the face
    assert slope[0] == np.inf and curvature[0] == np.inf
    assert profiles.flat_punch(-0.5, 0.5, corner_radius=1.0).pieces[0].dh(
        np.array([-1.5]))[0] == -np.inf


def test_circular_corner_beyond_its_vertical_end_is_nan_without_a_warning() -> None:
    """Beyond the arc (|x - x_tan| > rho: outside the piece's reach, where a Newton start of the
    zone edges can put a gap node, audit seed 52) slope and curvature are undefined: NaN,
    which the Newton iteration refuses, not an invalid-value warning."""
    arc = profiles.flat_punch(-0.5, 0.5, corner_radius=1.0).pieces[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        slope, curvature = arc.dh(np.array([1.7])), arc.d2h(np.array([1.7]))
    assert np.isnan(slope[0]) and np.isnan(curvature[0])


def test_wedge_and_double_wedge_kinks() -> None:
    assert profiles.wedge(0.1, 0.2, apex=0.3).kinks == (0.3,)
    assert profiles.double_wedge(2.0, 0.1, 0.2).kinks == (-2.0, 0.0, 2.0)
    dw = profiles.double_wedge(2.0, 0.1, 0.2)
    assert [m[0] for m in dw.local_minima()] == pytest.approx([-2.0, 2.0], abs=1e-12)


def test_wedge_slopes_are_the_tangents_of_the_angles() -> None:
    prof = profiles.wedge(0.1, 0.3, apex=0.4)
    np.testing.assert_allclose(prof.dh0(np.array([-1.0, 1.0])), [-np.tan(0.1), np.tan(0.3)],
                               rtol=ROUNDOFF)


def test_union_is_the_minimum_shifted_to_zero() -> None:
    c1 = profiles.cylinder(1.0, center=-1.0, lift=0.3)
    c2 = profiles.cylinder(0.5, center=1.2, lift=0.32)
    u = profiles.union(c1, c2)
    x = np.linspace(-3, 3, 601)
    exact = np.minimum(c1.h0(x), c2.h0(x)) - 0.3
    np.testing.assert_allclose(u.h0(x), exact, rtol=1e-12, atol=1e-12)
    assert [m[0] for m in u.local_minima()] == pytest.approx([-1.0, 1.2], abs=1e-10)
    assert len(u.kinks) == 1  # where the two parabolas cross
    assert u.corners == ()


def test_union_of_punch_and_cylinder_keeps_the_punch_corners() -> None:
    u = profiles.union(profiles.flat_punch(-1.0, -0.4),
                       profiles.cylinder(1.0, center=0.8, lift=0.01))
    assert -1.0 in u.corners and -0.4 in u.corners
    assert u.h0(np.array([-0.7]))[0] == 0.0
    assert u.h0(np.array([0.8]))[0] == pytest.approx(0.01, rel=1e-12)


def test_union_corner_takes_the_lower_side_of_the_step() -> None:
    """h0 = min of the members also at a sharp corner node of a union (issue 14 item 3: the
    neighbouring member's gap was returned there, so an FE corner node was left open)."""
    punch, cyl = profiles.flat_punch(-2.5, -1.5), profiles.cylinder(10.0, center=1.0, lift=2e-4)
    u = profiles.union(punch, cyl)
    corners = np.array([-2.5, -1.5])
    np.testing.assert_array_equal(u.h0(corners), [0.0, 0.0])
    assert u.h0(-2.5) == 0.0  # scalar input too
    outside = np.array([-2.5 - 1e-9, -1.5 + 1e-9])
    np.testing.assert_allclose(u.h0(outside), cyl.h0(outside), rtol=1e-12)


def test_tabulated_reproduces_a_smooth_profile_between_samples() -> None:
    x = np.linspace(-2, 2, 81)
    h = x**2 / 2 + 0.1 * x**3 + 0.5
    prof = profiles.tabulated(x, h)
    xi = np.linspace(-1.5, 1.5, 97)
    exact = xi**2 / 2 + 0.1 * xi**3 + 0.5
    np.testing.assert_allclose(prof.h0(xi), exact, atol=1e-5)
    np.testing.assert_allclose(prof.dh0(xi), xi + 0.3 * xi**2, atol=1e-4)
    assert np.isinf(prof.h0(np.array([2.1]))[0])


def test_tabulated_with_kink_keeps_the_slope_jump() -> None:
    x = np.linspace(-1, 1, 41)
    prof = profiles.tabulated(x, np.abs(x), kinks=[0.0])
    assert prof.kinks == (0.0,)
    np.testing.assert_allclose(prof.dh0(np.array([-0.5, 0.5])), [-1.0, 1.0], atol=1e-12)


def test_with_lift_and_local_minima_under_rotation() -> None:
    prof = profiles.cylinder(2.0)
    assert prof.with_lift(0.25).h0(np.array([0.0]))[0] == pytest.approx(0.25)
    # h0 - theta x = x^2/(2R) - theta x has its minimum at x = theta R
    assert prof.local_minima(theta=0.1)[0][0] == pytest.approx(0.2, abs=1e-12)


@pytest.mark.parametrize(
    ("build", "named"),
    [
        (lambda: profiles.cylinder(-1.0), "R=-1.0"),
        (lambda: profiles.cylinder(0.0), "R=0.0"),
        (lambda: profiles.biquadratic(1.0, -2.0), "R=-2.0"),
        (lambda: profiles.biquadratic(0.0, 1.0), "c=0.0"),
        (lambda: profiles.wedge(-0.1, 0.2), "angle_left=-0.1"),
        (lambda: profiles.wedge(0.1, 0.0), "angle_right=0.0"),
        (lambda: profiles.double_wedge(1.0, 0.1, 2.0), "phi_outer=2.0"),
        (lambda: profiles.flat_punch(1.0, 0.0), "right=0.0"),
        (lambda: profiles.flat_punch(-1.0, 1.0, corner_radius=-0.1), "corner_radius=-0.1"),
        (lambda: profiles.flat_punch(-1, 1, corner_radius=1, corner_shape="square"), "square"),
        (lambda: profiles.tabulated([0, 1, 2, 3], [1, 0, -1, 2]), "-1"),
        (lambda: profiles.tabulated([0, 2, 1, 3], [1, 0, 1, 2]), "increasing"),
    ],
)
def test_bad_profile_parameters_raise_one_clear_input_error(build, named: str) -> None:
    with pytest.raises(InputError, match=named.replace("(", r"\(")):
        build()


def test_tabulated_kinks_outside_the_table_are_refused():
    """A kink outside the table was dropped silently; one at an end is the end."""
    x = np.linspace(-1.0, 1.0, 21)
    with pytest.raises(InputError, match=r"kinks=\[5.0\] is not allowed: need .* within the "
                                         r"table \[-1.0, 1.0\]"):
        profiles.tabulated(x, x**2, kinks=[5.0])
    assert profiles.tabulated(x, x**2, kinks=[-1.0, 0.0]).kinks == (0.0,)
