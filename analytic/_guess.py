"""Cheap starting guess at a target load: the free-interpenetration (overlap) zones.

The zones ``{h0(x) - theta x < delta}`` (paper Section 6) are taken as the initial contact
zones, with ``delta`` chosen so that the single-zone Hertz-type load estimate
``P_k = (1/A) int (s - c_k) h'(s) / sqrt((s - a)(b - s)) ds`` of each zone adds up to P.  It is
only a starting point for Newton: the consistency, interconnection and admissibility checks decide.
"""

from __future__ import annotations

import numpy as np

from analytic._sie import Layout
from analytic.profiles import Profile

SCAN = 2001
CHEB = 24
MIN_POINTS = 4  # a zone narrower than this many scan points is too small to guess


def overlap_guess(profile: Profile, theta: float, P: float, A: float) -> Layout | None:
    """Overlap zones carrying about P, or None when no sensible guess exists."""
    x, f = _scan(profile, theta)
    if x is None:
        return None
    f0 = float(np.min(f))
    hi = 1e-6 * profile.scale
    for _ in range(80):
        if _load(profile, theta, A, x, f, f0 + hi) >= P:
            break
        hi *= 2.0
    else:
        return None
    lo = 0.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _load(profile, theta, A, x, f, f0 + mid) < P else (lo, mid)
    zones = _zones(x, f, f0 + hi)
    if not zones or any(b - a < MIN_POINTS * (x[1] - x[0]) for a, b in zones):
        return None
    edges = np.asarray([v for z in zones for v in z], float)
    pinned = np.isin(edges, profile.corners)
    if np.any(pinned):
        return None
    return Layout(edges, pinned)


def _scan(profile: Profile, theta: float):
    mins = [0.5 * (m[0] + m[1]) for m in profile.local_minima(theta)]
    if not mins:
        return None, None
    span = (max(mins) - min(mins)) + profile.scale
    lo, hi = profile.support
    lo, hi = max(lo, min(mins) - 2 * span), min(hi, max(mins) + 2 * span)
    x = np.linspace(lo, hi, SCAN)
    return x, profile.h0(x) - theta * x


def _zones(x: np.ndarray, f: np.ndarray, level: float) -> list[tuple[float, float]]:
    below = np.concatenate([[False], f < level, [False]])
    idx = np.flatnonzero(np.diff(below.astype(int)))
    out = []
    for s, e in zip(idx[::2], idx[1::2], strict=True):
        a = _cross(x, f, level, s - 1, s) if s > 0 else x[0]
        b = _cross(x, f, level, e - 1, e) if e < x.size else x[-1]
        out.append((float(a), float(b)))
    return out


def _cross(x, f, level, i, j) -> float:
    if not (np.isfinite(f[i]) and np.isfinite(f[j])):
        return x[j] if np.isfinite(f[j]) else x[i]
    t = (level - f[i]) / (f[j] - f[i])
    return x[i] + t * (x[j] - x[i])


def _load(profile: Profile, theta: float, A: float, x, f, level: float) -> float:
    total = 0.0
    k = np.arange(CHEB)
    u = np.cos(np.pi * (k + 0.5) / CHEB)
    for a, b in _zones(x, f, level):
        c, r = 0.5 * (a + b), 0.5 * (b - a)
        s = c + r * u
        total += float(np.sum((s - c) * (profile.dh0(s) - theta))) * np.pi / CHEB / A
    return total
