"""Paper Section 6: the overlapped (free-interpenetration) extent and its error (Fig. 5).

The *overlapped* estimate puts every nonsingular edge on the line ``h0(x) - theta x = delta``
(the bodies interpenetrate freely by ``delta``) instead of solving the consistency and
rigid-interconnection conditions.  The load belonging to those edges is the integral of the
Eq. 13 pressure over them (no consistency imposed).  The paper's error measure is

    Pe = (actual extent - overlapped extent) / actual extent * 100,   kappa = actual extent / c,

at equal load P, with "extent" the width ``b - a`` of one contact zone (the right zone of the
symmetric double wedge of Fig. 4).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analytic import _validate as check
from analytic._contour import zone_loads
from analytic._roots import brentq
from analytic._sie import Layout, System
from analytic.errors import InputError
from analytic.normal import check_problem, load_curve
from analytic.profiles import Profile, double_wedge

SCAN_POINTS = 4001


@dataclass(frozen=True)
class OverlapSolution:
    """Free-interpenetration estimate at load P (paper Section 6).

    ``zones``: intervals where ``h0(x) - theta x < delta``; ``zone_loads``: integral of the
    Eq. 13 pressure over each; ``delta``: interpenetration depth (length unit).
    """

    zones: list[tuple[float, float]]
    zone_loads: list[float]
    P: float
    delta: float
    theta: float


def _overlap_zones(profile: Profile, delta: float, theta: float) -> list[tuple[float, float]]:
    lo, hi = profile.support
    mins = [0.5 * (m[0] + m[1]) for m in profile.local_minima(theta)]
    span = (max(mins) - min(mins)) + profile.scale
    lo = max(lo, min(mins) - 4 * span)
    hi = min(hi, max(mins) + 4 * span)
    x = np.unique(np.concatenate([np.linspace(lo, hi, SCAN_POINTS), mins]))
    f = profile.h0(x) - theta * x - delta
    below = f < 0
    zones = []
    for start, stop in _runs(below):
        a = _root(profile, theta, delta, x[start - 1], x[start]) if start > 0 else x[0]
        b = _root(profile, theta, delta, x[stop], x[stop + 1]) if stop + 1 < x.size else x[-1]
        zones.append((a, b))
    return zones


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return [(int(s), int(e) - 1) for s, e in zip(idx[::2], idx[1::2], strict=True)]


def _root(profile: Profile, theta: float, delta: float, a: float, b: float) -> float:
    def f(t: float) -> float:
        v = float(profile.h0(np.array([t]))[0]) - theta * t - delta
        return v if np.isfinite(v) else 1e300

    return brentq(f, a, b, xtol=1e-15 * max(1.0, abs(a)), rtol=1e-15)


def _load_for(profile: Profile, A: float, delta: float, theta: float):
    zones = _overlap_zones(profile, delta, theta)
    if not zones:
        return 0.0, [], []
    edges = np.asarray([v for z in zones for v in z], float)
    if any(v in profile.corners for v in edges):
        raise InputError("the overlapped extent is defined for nonsingular edges only; "
                         f"delta={delta!r} reaches a sharp corner")
    layout = Layout(edges, np.zeros(edges.size, bool))
    sys_ = System.build(layout, profile, A, theta, float(0.5 * (edges[0] + edges[-1])), [])
    loads = zone_loads(sys_)
    return float(sum(loads)), zones, loads


def overlapped(profile: Profile, P: float, A: float, theta: float = 0.0) -> OverlapSolution:
    """Free-interpenetration estimate of the contact zones at load P (paper Section 6)."""
    P, A = check_problem(profile, P, A)
    theta = check.real("theta", theta)
    d_hi = 1e-6 * profile.scale
    for _ in range(200):
        if _load_for(profile, A, d_hi, theta)[0] >= P:
            break
        d_hi *= 2.0
    else:
        raise InputError(f"P={P!r}: no interpenetration depth carries this load")
    delta = brentq(lambda d: _load_for(profile, A, d, theta)[0] - P, 0.0, d_hi,
                   xtol=1e-15 * d_hi, rtol=1e-14)
    total, zones, loads = _load_for(profile, A, delta, theta)
    return OverlapSolution(zones, loads, total, float(delta), theta)


@dataclass(frozen=True)
class Fig5Data:
    """Data behind the paper's Fig. 5 for one angle pair (symmetric double wedge, Fig. 4).

    ``actual``/``overlapped``: width ``b - a`` of the right contact zone at each load ``P``;
    ``Pe`` percent error; ``kappa = actual / c``.
    """

    phi1: float
    phi2: float
    c: float
    A: float
    P: np.ndarray
    actual: np.ndarray
    overlapped: np.ndarray
    Pe: np.ndarray
    kappa: np.ndarray


def fig5_data(phi1: float, phi2: float, loads: Sequence[float] | None = None, c: float = 1.0,
              A: float = 1.0) -> Fig5Data:
    """Actual vs overlapped extent for ``double_wedge(c, phi1, phi2)`` (paper Fig. 5 a-d).

    Default loads: 40 values from small to a zone width of about 0.6 c.
    """
    phi1, phi2 = check.angle("phi1", phi1), check.angle("phi2", phi2)
    c, A = check.positive("c", c), check.positive("A", A, "compliance")
    prof = double_wedge(c, phi1, phi2)
    if loads is None:
        P_ref = c * np.tan(min(phi1, phi2)) / A
        loads = np.geomspace(1e-3, 0.6, 40) * P_ref
    loads = check.vector("loads", loads, 1, lambda v: bool(np.all(v > 0)),
                         "None or a non-empty 1-D sequence of finite loads > 0")
    actual = np.array([s.zones[-1][1] - s.zones[-1][0] for s in load_curve(prof, loads, A)])
    ovl = np.array([(lambda z: z[-1][1] - z[-1][0])(overlapped(prof, P, A).zones)
                    for P in loads])
    Pe = (actual - ovl) / actual * 100.0
    return Fig5Data(phi1, phi2, c, A, loads, actual, ovl, Pe, actual / c)
