"""``Profile.local_minima`` lists true local minima only (issue 29): property-based over random
unions of cylinders, wedges and flat punches, tilted or not."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from analytic import profiles as pr

PROBE = 1e-7
"""Relative distance (of the profile's scale) of the probes beside a reported minimum: well
above the rounding of h0 (~1e-16 relative), well below every feature of the drawn members."""


def _member(kind: int, x: float, size: float, lift: float) -> pr.Profile:
    if kind == 0:
        return pr.cylinder(size, x, lift)
    if kind == 1:
        return pr.wedge(0.05 + 0.3 * size / 3.0, 0.05 + 0.3 * (3.0 - size) / 3.0, x, lift)
    return pr.flat_punch(x - 0.1 * size, x + 0.1 * size, lift=lift)


def half_gap(u: pr.Profile, lo: float, hi: float) -> float:
    """Half the distance from a minimum [lo, hi] to the profile's nearest other kink: two
    members crossing just beside a minimum (a wedge's apex 3e-10 from where a cylinder crosses
    it) make a feature finer than PROBE, and a probe beyond it would judge the next piece."""
    ks = np.array(u.kinks, dtype=float)
    others = ks[(ks < lo) | (ks > hi)]
    gaps = np.minimum(np.abs(others - lo), np.abs(others - hi))
    return 0.5 * float(gaps.min()) if gaps.size else np.inf


def _coarse(v: float) -> float:
    """A drawn number on a 1e-6 grid: the members' features (a wedge's apex 2e-308 from a
    cylinder's axis, a lift of 3e-111) stay far above PROBE's resolution, as PROBE assumes."""
    return round(v, 6)


members = st.lists(st.tuples(st.integers(0, 2), st.floats(-3.0, 3.0).map(_coarse),
                             st.floats(0.3, 3.0).map(_coarse), st.floats(0.0, 0.3).map(_coarse)),
                   min_size=2, max_size=4)
tilts = st.floats(-0.05, 0.05).map(_coarse)


@settings(max_examples=25, deadline=None)
@given(members, tilts)
def test_every_reported_minimum_is_a_local_minimum(spec, theta) -> None:
    u = pr.union(*[_member(*m) for m in spec])
    if not u.admits_tilt(theta):
        theta = 0.0
    for lo, hi, value in u.local_minima(theta):
        d = min(PROBE * max(u.scale, abs(lo), abs(hi)), half_gap(u, lo, hi))
        x = np.array([lo - d, hi + d])
        beside = u.h0(x) - theta * x
        tol = 1e-12 * max(1.0, abs(value))
        assert np.all(beside >= value - tol), (lo, hi, value, beside)


@settings(max_examples=25, deadline=None)
@given(members)
def test_the_lowest_sampled_point_is_a_reported_minimum(spec) -> None:
    u = pr.union(*[_member(*m) for m in spec])
    x = np.linspace(-6.0, 6.0, 6001)
    h = u.h0(x)
    found = u.local_minima()
    assert found
    assert min(m[2] for m in found) <= float(np.min(h)) + 1e-12


def test_a_concave_kink_on_a_rising_flank_is_no_minimum() -> None:
    """Issue 29 item 2: h0 rises 0.21930 -> 0.22014 -> 0.22028 through x = 1.5472."""
    u = pr.union(pr.wedge(0.37694438378945166, 0.1413358305910268),
                 pr.cylinder(0.6218232080292125, 1.0239449588943053, 0.0))
    assert 1.5471812683061577 in u.ridges
    xs = [m[0] for m in u.local_minima()]
    assert xs == [0.0, 1.0239449588943053]


def test_a_minimum_within_one_sample_of_a_ridge_is_found() -> None:
    """Audit seed 102518: the lowest point of the cylinder R = 2.57 lies 0.08 from the ridge that
    ends its infinite piece, inside the last of the piece's samples; it was dropped with the
    ridge and the first touch started on the other cylinder, 7.7e-4 higher."""
    u = pr.union(pr.flat_punch(-0.7886841388552277, 0.7886841388552277,
                               corner_radius=0.31711253074994755, lift=0.006386096984933542),
                 pr.cylinder(1.3127253765649063, -1.8846096389439158, 0.006302915148183161),
                 pr.cylinder(2.571046323936924, -1.9956653697209379, 0.005528199815070189))
    lowest = min(u.local_minima(), key=lambda m: m[2])
    assert lowest[0] == lowest[1] == pytest.approx(-1.9956653697209379, abs=1e-12)
    x = np.linspace(-3.0, 1.0, 40001)
    assert lowest[2] <= float(np.min(u.h0(x))) + 1e-15


def test_a_piece_end_above_a_step_down_is_no_minimum() -> None:
    """Found by the property test above (CI, 27 Nov 2026): a flat punch lifted by 0.25 with its
    left end on the flank of a cylinder where the cylinder stands at 0.36.  h0 steps down from
    0.36 to 0.25 at x = -1.85, so the cylinder's end there is no minimum (it was listed at 0.36),
    and the punch's face, with the cylinder lower again beyond its right end, is none either."""
    u = pr.union(pr.cylinder(0.5, -1.25, 0.0), pr.flat_punch(-1.85, -1.65, lift=0.25))
    assert u.local_minima() == [(-1.25, -1.25, 0.0)]


def test_an_infinite_piece_is_sampled_beyond_its_own_start() -> None:
    """Found by the property test above (3000 examples): the cylinders at 0 and 1.5 cross at
    x = -10.3 as well, so the profile spans 134 scales and the far stand-in of its last piece
    (3.1, inf) fell at 1.4, behind the piece's start; the piece's cylinder, sampled outside the
    piece, gave a 'minimum' at 1.5024 beside the true one at 1.5."""
    spec = [(0, 0.0, 1.0, 0.0), (0, 1.5, 1.3125, 0.0), (2, 0.0, 0.5, 0.0), (2, 3.0, 1.0, 0.0)]
    u = pr.union(*[_member(*m) for m in spec])
    assert [m[0] for m in u.local_minima()] == [0.0, 1.5, 2.9]


def test_a_member_minimum_beyond_the_far_stand_in_is_found() -> None:
    """Found by the property test above (3000 examples): the union's scale is the narrow punch's
    (0.075), the cylinder's axis lies 53 scales away, beyond the far stand-in of its infinite
    piece, and its lowest point (0.25 below the punch) was missed."""
    u = pr.union(*[_member(*m) for m in [(0, -2.0, 1.0, 0.0), (2, 2.0, 0.375, 0.25)]])
    assert u.local_minima() == [(-2.0, -2.0, 0.0), (1.9625, 2.0375, 0.25)]
