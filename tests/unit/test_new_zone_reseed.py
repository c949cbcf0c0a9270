"""The reseeds of a new zone after Newton failed from its overlap interval
(analytic._topology.shrunk_new_zone, reseeds): RESEED_FRACTION of the overlap about the deepest
point in its proportions, then, where h0's slope does not jump inside that seed, symmetric about
that point."""

from __future__ import annotations

import numpy as np

from analytic import profiles
from analytic._newton import fresh_state
from analytic._sie import Layout
from analytic._topology import RESEED_FRACTION, Event, _slope_jumps, reseeds, shrunk_new_zone

F = RESEED_FRACTION


def _state(lo: float, hi: float):
    return fresh_state(Layout(np.array([-5.0, -4.0, lo, hi]), np.zeros(4, bool)), 0.0, 1.0)


def test_a_smooth_minimum_is_reseeded_in_proportion_then_symmetrically() -> None:
    cyl = profiles.cylinder(1.0)
    assert reseeds(cyl, -0.3, 0.6, 0.0) == [(-F * 0.3, F * 0.6), (-F * 0.3, F * 0.3)]
    history = [Event("add", 0.0, interval=(-0.3, 0.6))]
    first = shrunk_new_zone(_state(-0.3, 0.6), history, 1.0, cyl)
    assert np.allclose(first.layout.edges, [-5, -4, -F * 0.3, F * 0.6])
    history.append(Event("reseed", 0.0))
    second = shrunk_new_zone(first, history, 1.0, cyl)
    assert np.allclose(second.layout.edges, [-5, -4, -F * 0.3, F * 0.3])
    history.append(Event("reseed", 0.0))
    assert shrunk_new_zone(second, history, 1.0, cyl) is None


def test_a_wedge_apex_is_reseeded_in_proportion_only() -> None:
    assert reseeds(profiles.wedge(0.1, 0.2), -0.4, 0.2, 0.0) == [(-F * 0.4, F * 0.2)]


def test_no_reseed_after_another_event() -> None:
    history = [Event("add", 0.0, interval=(-0.3, 0.6)), Event("pin", 0.5)]
    assert shrunk_new_zone(_state(-0.3, 0.6), history, 1.0, profiles.cylinder(1.0)) is None


def test_a_rounded_corner_junction_is_no_slope_kink() -> None:
    """The face of a rounded punch meets its corner arc with a curvature jump only (audit seed
    104623's new zone sat there); its vertical end, a wedge's apex and a union's ridge jump."""
    punch = profiles.flat_punch(-0.8, 0.8, corner_radius=0.37)
    assert not _slope_jumps(punch, -0.8) and not _slope_jumps(punch, 0.8)
    assert _slope_jumps(punch, -0.8 - 0.37)
    assert _slope_jumps(profiles.wedge(0.1, 0.2), 0.0)
    union = profiles.union(profiles.cylinder(1.0, -1.0), profiles.cylinder(1.0, 1.0))
    assert union.ridges and all(_slope_jumps(union, q) for q in union.ridges)
