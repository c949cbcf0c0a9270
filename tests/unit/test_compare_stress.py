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


def test_tied_analytic_peak_located_nearest_the_fe_peak():
    """A plateau (sharp_punch after Q returns to 0: sxx = 0 on the whole surface outside the
    zone, computed at rounding level) has no one peak: the FE peak's location is measured from
    the nearest tied point, not from the plateau's first sample; a distinct peak is unchanged,
    and a tie wider than rounding is no tie."""
    zones = [(-1.0, 1.0)]
    xa = np.linspace(-2.0, 2.0, 401)
    plateau = np.where(np.abs(xa) < 1.0, -(1.0 - xa**2), 1e-16 * np.cos(xa))  # max at x=-2
    xf = xa[::4]
    noise = np.where(np.abs(xf) < 1.0, -(1.0 - xf**2), 0.0) + 1e-6 * (xf > 1.5)
    _, x_an, _, x_fe = cs.zone_peaks(xa, plateau, xf, noise, zones, points=[])[0]
    assert x_fe > 1.5 and x_an == x_fe
    bump = plateau + 1e-6 * np.exp(-((xa + 1.6) / 0.05) ** 2)  # a real peak, 1e-6 of the scale
    _, x_an, _, _ = cs.zone_peaks(xa, bump, xf, noise, zones, points=[])[0]
    assert abs(x_an + 1.6) < 1e-12
