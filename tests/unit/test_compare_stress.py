"""Pure helpers of compare/stress.py: boxes, exclusion discs, peak windows and peaks."""

from __future__ import annotations

import math

import numpy as np

from compare import stress as cs


def test_box_mask_keeps_the_box_below_the_surface_outside_the_discs():
    zones = [(-1.0, 1.0)]
    x = np.array([0.0, 0.0, 0.0, 2.5, 0.0, -1.0, -1.0])
    y = np.array([-0.5, 0.0, -2.5, -0.5, -1.9, -0.1, -0.3])
    keep = cs.box_mask(x, y, zones, points=[-1.0])
    # inside; on the surface; too deep; beyond the pad; inside; in the disc; outside it
    assert keep.tolist() == [True, False, False, False, True, False, True]


def test_peak_windows_stop_half_way_to_the_neighbour():
    wins = cs.peak_windows([(0.0, 1.0), (1.2, 2.2)])
    assert wins == [(-0.5, 1.1), (1.1, 2.7)]


def test_zone_peaks_per_zone_and_singular_sup_is_not_a_peak():
    zones = [(0.0, 1.0), (3.0, 4.0)]
    xa = np.linspace(-0.5, 4.5, 501)
    sa = np.where(xa < 2.0, np.exp(-((xa - 0.2) / 0.05) ** 2), 1.0 / (np.abs(xa - 4.0) + 1e-3))
    xf = xa[::5]
    sf = 0.9 * sa[::5]
    peaks = cs.zone_peaks(xa, sa, xf, sf, zones, points=[4.0])
    pa, xpa, pf, xpf = peaks[0]
    assert xpa == xpf and abs(xpa - 0.2) < 1e-12 and math.isclose(pf, 0.9 * pa)
    assert all(math.isnan(v) for v in peaks[1])  # its sup sits on the singular point x = 4
