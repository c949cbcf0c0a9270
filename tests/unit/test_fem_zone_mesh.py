"""Zone-aware meshes (issue 14 item 4): one refined window per expected contact zone."""

import numpy as np
import pytest

import fem
from fem.mesh import as_windows, build_mesh, window_axis

#: Elements across the narrowest zone at the default level (issue 14: at least 40).
MIN_ZONE_ELEMENTS = 40


def zone_sets():
    """Zone widths 1e-3 to 1 of the span, one to five zones, gaps narrow and wide."""
    return [
        ((0.0, 1.0),),
        ((-2.55, -1.45), (0.9, 1.1)),
        ((0.0, 1e-3), (0.3, 0.301), (0.5, 0.7), (0.9, 0.99), (0.999, 1.0)),
        ((0.0, 1.0), (1.0001, 1.002)),
        ((0.0, 1e-3), (0.0011, 1.0)),
        ((0.0, 1e-3), (1.0 - 1e-3, 1.0)),
    ]


@pytest.mark.parametrize("zones", zone_sets())
def test_every_zone_is_resolved_and_the_grading_is_smooth(zones):
    spec = fem.MeshSpec()
    span = zones[-1][1] - zones[0][0]
    x = window_axis(as_windows(zones), (), spec, spec.size_factor * 0.5 * span)
    for lo, hi in zones:
        inside = np.count_nonzero((x > lo) & (x < hi)) + 1
        assert inside >= MIN_ZONE_ELEMENTS, (lo, hi, inside)
    d = np.diff(x)
    assert np.all(d > 0)
    ratio = np.maximum(d[1:] / d[:-1], d[:-1] / d[1:])
    assert ratio.max() <= spec.growth * (1 + 1e-6)


def test_coarse_across_the_gaps():
    """Two narrow zones far apart: the node count does not scale with span / zone width."""
    spec, W = fem.MeshSpec(), 12.5
    x = window_axis(as_windows(((0.0, 1e-3), (1.0 - 1e-3, 1.0))), (), spec, W)
    h = np.diff(x).min()
    fine = 2 * (1 + 2 * spec.margin) * spec.n_window * 2**spec.level
    graded = 6 * np.log(W / h) / np.log(spec.growth)  # gap (2 sides) and outside: geometric
    assert x.size < fine + graded  # a uniform mesh would need span / h = 1e5 elements


def test_single_window_api_unchanged():
    """A pair (xmin, xmax) and a one-element sequence of it give the same mesh."""
    a = build_mesh(fem.MeshSpec(level=0), (-1.5, 1.5), kinks=(-1.0, 1.0))
    b = build_mesh(fem.MeshSpec(level=0), [(-1.5, 1.5)], kinks=(-1.0, 1.0))
    assert np.array_equal(a.bodies[0].p, b.bodies[0].p)


def test_windows_are_sorted_merged_and_validated():
    assert as_windows(((1.0, 2.0), (0.0, 0.5))) == ((0.0, 0.5), (1.0, 2.0))
    assert as_windows(((0.0, 1.0), (0.5, 2.0))) == ((0.0, 2.0),)
    for bad in ((1.0, 0.0), ((0.0, 1.0), (2.0, np.inf)), (0.0, 1.0, 2.0)):
        with pytest.raises(fem.InputError, match="window="):
            as_windows(bad)


def test_kinks_in_windows_and_gaps_are_nodes():
    kinks = (-2.5, -1.5, 0.3)
    m = build_mesh(fem.MeshSpec(level=0), ((-2.55, -1.45), (0.9, 1.1)), kinks=kinks)
    x = np.sort(m.bodies[0].p[0, m.nodes["contact_upper"]])
    for k in kinks:
        assert np.min(np.abs(x - k)) < 1e-12
