"""Cheap starting guess at a target load: the free-interpenetration (overlap) zones.

The zones ``{h0(x) - theta x < delta}`` (paper Section 6) are taken as the initial contact
zones, with ``delta`` chosen so that the single-zone Hertz-type load estimate
``P_k = (1/A) int (s - c_k) h'(s) / sqrt((s - a)(b - s)) ds`` of each zone adds up to P.  It is
only a starting point for Newton: the consistency, interconnection and admissibility checks decide.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from analytic._sie import Layout
from analytic.profiles import Profile

CHEB = 24
GUESS_RTOL = 1e-4  # the guess only seeds Newton; log-delta to this accuracy is ample
RAYS = np.geomspace(1e-12, 20.0, 240)  # distances from a minimum, in units of profile.scale


@dataclass(frozen=True)
class _Ray:
    """``h0 - theta x`` tabulated outwards from one side of a minimum."""

    x: np.ndarray
    f: np.ndarray


def _rays(profile: Profile, theta: float):
    out = []
    for lo, hi, v in profile.local_minima(theta):
        sides = []
        for x0, side in ((lo, -1.0), (hi, 1.0)):
            x = np.concatenate([[x0], x0 + side * profile.scale * RAYS])
            f = profile.h0(x) - theta * x
            f[~np.isfinite(f)] = np.inf
            sides.append(_Ray(x, f))
        out.append((v, sides[0], sides[1]))
    return out


def _edge(ray: _Ray, level: float) -> float:
    k = int(np.argmax(ray.f >= level)) if np.any(ray.f >= level) else ray.x.size - 1
    if k == 0:
        return float(ray.x[0])
    f0, f1 = ray.f[k - 1], ray.f[k]
    if not np.isfinite(f1):
        return float(ray.x[k - 1])  # a corner (or the end of the support) bounds the zone
    t = (level - f0) / (f1 - f0) if f1 > f0 else 1.0
    return float(ray.x[k - 1] + t * (ray.x[k] - ray.x[k - 1]))


def _zones(rays, level: float) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for v, left, right in rays:
        if v >= level:
            continue
        a, b = _edge(left, level), _edge(right, level)
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(b, out[-1][1]))
        else:
            out.append((a, b))
    return out


def _load(profile: Profile, theta: float, A: float, rays, level: float) -> float:
    u = np.cos(np.pi * (np.arange(CHEB) + 0.5) / CHEB)
    total = 0.0
    for a, b in _zones(rays, level):
        c, r = 0.5 * (a + b), 0.5 * (b - a)
        s = c + r * u
        total += float(np.sum((s - c) * (profile.dh0(s) - theta))) * np.pi / CHEB / A
    return total


def overlap_guess(profile: Profile, theta: float, P: float, A: float) -> Layout | None:
    """Overlap zones carrying about P, or None when no sensible guess exists."""
    rays = _rays(profile, theta)
    if not rays:
        return None
    f0 = min(v for v, _, _ in rays)

    def excess(log_d: float) -> float:
        return _load(profile, theta, A, rays, f0 + np.exp(log_d)) - P

    lo = np.log(1e-14 * max(profile.scale, 1e-300))
    if excess(lo) >= 0:
        return None
    hi = lo
    for _ in range(20):
        hi += np.log(100.0)
        if excess(hi) >= 0:
            break
    else:
        return None
    hi = np.exp(brentq(excess, hi - np.log(100.0), hi, xtol=GUESS_RTOL))
    zones = _zones(rays, f0 + hi)
    edges = np.asarray([v for z in zones for v in z], float)
    if edges.size == 0 or np.any(np.diff(edges) <= 0):
        return None
    if np.any(np.isin(edges, profile.pin_points)):
        return None
    return Layout(edges, np.zeros(edges.size, bool))
