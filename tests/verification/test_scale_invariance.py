"""Only A*P matters: ``solve_normal(profile, s*P, A/s)`` is ``solve_normal(profile, P, A)``
for s over 24 orders of magnitude (property test over random profiles, vertical and moment
modes), and small loads A*P that put the edges a few 1e-8 past a kink still solve (issue 18).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import analytic
from analytic import profiles

#: Edges (relative to the contact span) of the scaled problem vs the reference: the solver sees
#: A*P only, so they agree to rounding (measured <= 2e-14); the issue asks for 1e-10.
SCALE_RTOL = 1e-10
SCALES = [1e-12, 1e-6, 1e6, 1e12]


def _profile(kind: str, a: float, b: float) -> profiles.Profile:
    """A profile of family ``kind`` from two parameters a, b in [0, 1]."""
    if kind == "cylinder":
        return profiles.cylinder(0.5 + 2 * a, center=b - 0.5)
    if kind == "rounded":
        return profiles.flat_punch(-1.0, 1.0 + b, corner_radius=0.1 + 0.5 * a)
    if kind == "parabolic":
        return profiles.flat_punch(-1.0, 1.0, corner_radius=0.1 + a, corner_shape="parabolic")
    if kind == "sharp":
        return profiles.flat_punch(-1.0 - a, 1.0)
    if kind == "wedge":
        return profiles.wedge(0.05 + 0.2 * a, 0.05 + 0.2 * b)
    if kind == "double_wedge":
        return profiles.double_wedge(1.0, 0.05 + 0.1 * a, 0.05 + 0.1 * b)
    if kind == "biquadratic":
        return profiles.biquadratic(1.0, 0.5 + a)
    return profiles.union(profiles.cylinder(1.0, center=-1.5),
                          profiles.cylinder(0.5 + a, center=1.5, lift=0.01 * b))


KINDS = ["cylinder", "rounded", "parabolic", "sharp", "wedge", "double_wedge", "biquadratic",
         "two_cylinders"]
unit = st.floats(0.0, 1.0)


def _assert_same(ref: analytic.NormalSolution, got: analytic.NormalSolution) -> None:
    e_ref, e_got = np.ravel(ref.zones), np.ravel(got.zones)
    assert e_got.shape == e_ref.shape and got.singular == ref.singular
    span = e_ref[-1] - e_ref[0]
    assert np.max(np.abs(e_got - e_ref)) <= SCALE_RTOL * span
    assert got.theta == pytest.approx(ref.theta, rel=SCALE_RTOL, abs=SCALE_RTOL * 1e-3)


@pytest.mark.parametrize("kind", KINDS)
@settings(max_examples=4, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(a=unit, b=unit, log_ap=st.floats(-4.0, -1.0))
def test_vertical_depends_on_A_times_P_only(kind, a, b, log_ap) -> None:
    prof, P = _profile(kind, a, b), 10.0**log_ap
    ref = analytic.solve_normal(prof, P, 1.0)
    for s in SCALES:
        _assert_same(ref, analytic.solve_normal(prof, s * P, 1.0 / s))


@pytest.mark.parametrize("kind", ["cylinder", "rounded", "parabolic", "two_cylinders"])
@settings(max_examples=2, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(a=unit, b=unit, log_ap=st.floats(-3.0, -1.0), offset=st.floats(-0.05, 0.05))
def test_moment_mode_depends_on_A_times_P_only(kind, a, b, log_ap, offset) -> None:
    """Applied moment M = P * x_e (load centre x_e) scales with P."""
    prof, P = _profile(kind, a, b), 10.0**log_ap
    ref = analytic.solve_normal(prof, P, 1.0, M=P * offset)
    for s in (SCALES[0], SCALES[-1]):
        _assert_same(ref, analytic.solve_normal(prof, s * P, 1.0 / s, M=s * P * offset))


@pytest.mark.parametrize("shape", ["circular", "parabolic"])
def test_rounded_punch_at_small_loads(shape) -> None:
    """Face [-1, 1], corner radius 0.5: the edges lie d ~ (A rho P)^(2/3) past the face's ends
    (a quadratic corner smoothing the flat punch's square-root singularity), d = 4e-10 at
    P = 1e-12; vertical and moment modes."""
    punch = profiles.flat_punch(-1.0, 1.0, corner_radius=0.5, corner_shape=shape)
    loads = [1e-12, 1e-11, 1e-10, 1e-9, 1e-8]
    d = np.array([analytic.solve_normal(punch, P, 1.0).zones[0][1] - 1.0 for P in loads])
    slope = np.polyfit(np.log(loads), np.log(d), 1)[0]
    assert slope == pytest.approx(2.0 / 3.0, abs=2e-3)
    moment = analytic.solve_normal(punch, 1e-10, 1.0, M=0.0)
    assert moment.zones[0][1] - 1.0 == pytest.approx(d[2], rel=1e-6)


def test_two_cylinders_in_moment_mode_at_small_load() -> None:
    """Each cylinder carries P/2 as a Hertz contact (the zones are 4e5 half-widths apart).  At
    P = 1e-9 this case still fails (ConvergenceError; it was scipy's raw ValueError): the
    interconnection rows are not resolved there (see the double wedge below)."""
    P = 1e-8
    pair = profiles.union(profiles.cylinder(1.0, center=-2.0), profiles.cylinder(1.0, center=2.0))
    sol = analytic.solve_normal(pair, P, 1.0, M=0.0)
    assert sol.n_zones == 2 and abs(sol.theta) < 1e-12
    half = np.sqrt(2 * P / 2 * 1.0 / np.pi)  # Hertz: a^2 = 2 (P/2) R A / pi per cylinder
    for (lo, hi), c in zip(sol.zones, (-2.0, 2.0), strict=True):
        assert (hi - lo) / 2 == pytest.approx(half, rel=1e-6)
        assert (lo + hi) / 2 == pytest.approx(c, abs=1e-5 * half)



def test_double_wedge_at_small_loads_is_right_or_refused() -> None:
    """Zones around the apexes at x = +-1, ~1e-8 wide at P = 1e-9, each carrying P/2 by
    symmetry; a wedge's zone width is linear in P (the ratio at P = 1e-6 is the reference).
    The interconnection between such zones is not resolved below P ~ 1e-7 (its scaling is
    |h'| times the span, not A P): a ConvergenceError, never a wrong load split (a rounding
    floor applied to it once returned shares 0.74 / 0.26 at P = 1e-8)."""
    dw = profiles.double_wedge(1.0, 0.11, 0.07)
    ref = np.diff(analytic.solve_normal(dw, 1e-6, 1.0).zones[1])[0] / 1e-6
    for P in (1e-10, 1e-9, 1e-8):
        try:
            sol = analytic.solve_normal(dw, P, 1.0)
        except analytic.ConvergenceError:
            continue
        assert sol.zone_loads == pytest.approx([P / 2, P / 2], rel=1e-5)
        assert np.diff(sol.zones[1])[0] / P == pytest.approx(ref, rel=1e-5)
