"""Admissibility of a converged state: ``p >= 0`` in every zone and ``g >= 0`` outside them.

The pressure is sampled at Chebyshev points of every zone, at the local maxima of
``h0 - theta x`` inside it, and just inside every singular edge (the sign of its stress
intensity).  The deformed gap is checked where it can be smallest: ``g'`` is cheap (no
integral), so its sign changes are found on runs across every gap and beyond the outer edges,
the candidates are refined by Newton steps on ``g'``, and only there ``g`` itself is evaluated.
A violation becomes a topology event (:mod:`analytic._topology`).
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np

from analytic._gap import deformed_gap, in_zones
from analytic._newton import State
from analytic._sie import System
from analytic._topology import Event, gap_event, pressure_event
from analytic.profiles import Profile

ADMISSIBLE_TOL = 1e-9       # relative tolerance of the p >= 0 and g >= 0 checks


def find_event(st: State, sys_: System, profile: Profile, A: float) -> Event | None:
    """The first violation of ``p >= 0`` in the zones or ``g >= 0`` outside them, as a topology
    event, or None; the smallest pressure and gap found are recorded in ``st.checks``."""
    P_scale = st.P / max(st.layout.edges[1::2].sum() - st.layout.edges[0::2].sum(), 1e-300)
    xi = np.concatenate([_check_points_inside(st.layout.edges, profile=profile, theta=st.theta),
                         _pinned_edge_points(st, profile)])
    runs, closed = _gap_runs(st, profile)
    p, gp = sys_.pressure_and_slope(xi, np.concatenate(runs))
    st.checks = {"min_pressure": float(np.min(p)), "min_gap": 0.0}
    if np.min(p) < -ADMISSIBLE_TOL * P_scale:
        return pressure_event(st, xi, p)
    xo = _gap_candidates(st, profile, runs, closed, gp)
    xo = np.concatenate([xo, _refined_minima(sys_, xo, profile)])
    if xo.size:
        g = deformed_gap(sys_, xo)
        st.checks["min_gap"] = float(np.min(g))
        g_scale = A * st.P + 1e-300
        if np.min(g) < -ADMISSIBLE_TOL * g_scale:
            return gap_event(st, float(xo[int(np.argmin(g))]), sys_, profile)
    return None


_SCAN = np.linspace(0.0, 1.0, 401)        # profile scan for pressure dips inside a zone
_OUTER_RUN = np.geomspace(1e-4, 3.0, 24)  # gap-slope samples beyond the outer edges (x span)


@lru_cache(maxsize=8)
def _cheb_unit(n: int) -> np.ndarray:
    """Chebyshev points of the first kind mapped to (0, 1)."""
    return 0.5 * (1 - np.cos(np.pi * (np.arange(n) + 0.5) / n))


def _check_points_inside(edges: np.ndarray, n_pts: int = 49,
                         profile: Profile | None = None, theta: float = 0.0) -> np.ndarray:
    """Chebyshev points of every zone plus, when a profile is given, the local maxima of
    ``h0 - theta x`` inside the zones (where the pressure dips first when zones separate)."""
    z = edges.reshape(-1, 2)
    t = _cheb_unit(n_pts)
    pts = [(z[:, :1] + (z[:, 1:] - z[:, :1]) * t[None, :]).ravel()]
    if profile is not None:  # one scan of all zones at once, zone by zone in the output
        x = z[:, :1] + (z[:, 1:] - z[:, :1]) * _SCAN[None, 1:-1]
        h = profile.h0(x) - theta * x
        peak = (h[:, 1:-1] >= h[:, :-2]) & (h[:, 1:-1] >= h[:, 2:])
        pts.append(x[:, 1:-1][peak])
    return np.concatenate(pts)


PINNED_PROBE = 1e-15
"""Distance (relative to max(|x|, scale)) inside a singular edge, away from a vertical end, at
which p is also sampled: ``p ~ K d^(-1/2)`` there, so ``p >= 0`` at this d asks ``K >= 0`` to
the level that :mod:`analytic.selfcheck` resolves (its graded rule has nodes ~4e-15 |x| from an
edge).  The Chebyshev points alone (the nearest ~1e-4 of the zone inside) passed an edge pinned
at a ridge with K = -1.05e-4 (p < 0 only for d < 1e-6): a wrong topology that the self-check
then refused (audit seed 103644, vertical: min p = -46 times the mean)."""


def _pinned_edge_points(st: State, profile: Profile) -> np.ndarray:
    """Points PINNED_PROBE inside every singular edge that is not a vertical end (there p has a
    log term besides K, checked by the self-check on its own)."""
    e = st.layout.edges
    idx = np.flatnonzero(st.layout.pinned)
    idx = idx[~np.isin(e[idx], np.asarray(profile.vertical_ends, float))]
    if not idx.size:
        return np.zeros(0)
    d = PINNED_PROBE * np.maximum(np.abs(e[idx]), profile.scale)
    return e[idx] + np.where(idx % 2 == 0, d, -d)


def _gap_runs(st: State, profile: Profile) -> tuple[list[np.ndarray], list[bool]]:
    """The runs of g' samples: across every gap (from its left edge) and beyond the right and
    the left outer edge, inside the support and where h0 is finite; per run whether it ends at
    the next zone's edge (an untruncated run across a gap)."""
    e = st.layout.edges
    span = max(e[-1] - e[0], profile.scale)
    d = span * _OUTER_RUN
    t = _cheb_unit(24)
    runs = [e[2 * m + 1] + (e[2 * m + 2] - e[2 * m + 1]) * t for m in range(st.layout.n - 1)]
    runs += [e[-1] + d, e[0] - d]
    starts = [*e[1:-1:2], e[-1], e[0]]
    runs = [_with_kink_sides(x, x0, profile) for x, x0 in zip(runs, starts, strict=True)]
    lo, hi = profile.support
    full = [x.size for x in runs]
    runs = [x[(x >= lo) & (x <= hi)] for x in runs]
    if profile.pieces_have_gaps:
        runs = [x[np.isfinite(profile.h0(x))] for x in runs]
    closed = [x.size == m for x, m in zip(runs[:-2], full, strict=False)] + [False, False]
    return runs, closed


KINK_SIDE = 1e-9  # the g' samples either side of a kink, relative to max(scale, |kink|)


def _with_kink_sides(x: np.ndarray, x0: float, profile: Profile) -> np.ndarray:
    """The run ``x`` (ordered away from its edge ``x0``) with a sample just before and just
    after every kink of h0 that it crosses.  g' jumps at a kink: at a ridge (the slope drops,
    e.g. where two members of a union meet) g rises into the kink and falls beyond it, so a
    minimum of g just before the ridge leaves no sign change of g' between the samples on either
    side of it (stress case: a new zone's overlap 4.8e-4 deep went unseen next to a ridge)."""
    lo, hi = sorted((x0, float(x[-1])))
    q = np.array([k for k in profile.kinks if lo < k < hi], float)
    if not q.size:
        return x
    dq = KINK_SIDE * np.maximum(profile.scale, np.abs(q))
    sides = np.concatenate([q - dq, q + dq])
    sides = sides[(sides > lo) & (sides < hi)]
    out = np.concatenate([x, sides])
    return out[np.argsort(np.abs(out - x0), kind="stable")]


def _gap_candidates(st: State, profile: Profile, runs: list[np.ndarray], closed: list[bool],
                    gp: np.ndarray) -> np.ndarray:
    """Where the deformed gap can be smallest outside the zones, given ``g'`` on the
    concatenated :func:`_gap_runs`.

    ``g = 0`` at every edge and ``g' = W B/pi`` is cheap (no integral), so the minima of g are
    found from sign changes of ``g'`` on a grid in every gap and on geometric grids beyond the
    outer edges; the profile's own local minima, kinks and corners are added (new zones touch
    there).  Only these few points need the integral for g itself.
    """
    e = st.layout.edges
    ends = list(itertools.accumulate(x.size for x in runs))
    slopes = [gp[hi - x.size:hi] for x, hi in zip(runs, ends, strict=True)]
    slopes[-1] = -slopes[-1]  # the last run goes leftwards: the slope along it is -g'
    cands = [np.asarray([0.5 * (m[0] + m[1]) for m in profile.local_minima(st.theta)]
                        + list(profile.pin_points) + list(profile.kinks), float)]
    cands += [_slope_minima(x, s, end_at_edge)
              for x, s, end_at_edge in zip(runs, slopes, closed, strict=True) if x.size]
    x = np.concatenate(cands)
    lo, hi = profile.support
    x = x[(x >= lo) & (x <= hi)]
    return x[~in_zones(x, e) & ~np.any(x[:, None] == e[None, :], axis=1)]


def _slope_minima(x: np.ndarray, gp: np.ndarray, end_at_edge: bool = False) -> np.ndarray:
    """Points of a run ``x`` (ordered away from its edge) where the slope of g along the run,
    ``gp``, turns from negative to positive, the first point if g already falls there, and the
    last point if g still falls there - unless the run ends at the next zone's edge
    (``end_at_edge``): g = 0 there, so g falling into it is positive before it."""
    out = [x[0]] if gp[0] < 0 else []
    for i in np.flatnonzero((gp[:-1] < 0) & (gp[1:] >= 0)):
        f = gp[i] / (gp[i] - gp[i + 1])
        out.append(x[i] + f * (x[i + 1] - x[i]))
    if gp[-1] < 0 and not end_at_edge:
        out.append(x[-1])
    return np.asarray(out, float)


REFINE_STEPS = 4     # Newton steps on g' from every gap candidate
REFINE_FD = 1e-6     # their finite-difference step for g'' (x scale, at most 1/4 of the clearance)


def _refined_minima(sys_: System, x: np.ndarray, profile: Profile) -> np.ndarray:
    """The candidates moved by Newton steps on ``g'`` (``g''`` by central differences, steps
    only where ``g'' > 0`` and at most half-way to the nearest edge), kept where they stay outside
    the zones on finite h0.  A candidate is a minimum of ``h0 - theta x`` or a linear
    interpolation of a sign change of ``g'`` on a coarse run; the minimum of g lies off it by
    ``u'/h''`` (the elastic slope from the zones), and just before a zone is born g there is still
    positive while the true minimum is not (g = -2.2e-7 = -1.4e-5 A P accepted on a union of
    cylinders).  The originals are kept, so a stray step only costs a sample."""
    e = sys_.layout.edges
    if not x.size:
        return x
    for _ in range(REFINE_STEPS):
        clear = np.min(np.abs(x[:, None] - e[None, :]), axis=1)
        d = np.minimum(REFINE_FD * profile.scale, 0.25 * clear)
        _, gp = sys_.pressure_and_slope(np.zeros(0), np.concatenate([x - d, x + d]))
        lo, hi = gp[:x.size], gp[x.size:]
        curv = (hi - lo) / (2 * d)
        step = np.where(curv > 0, -0.5 * (lo + hi) / np.where(curv > 0, curv, 1.0), 0.0)
        x = x + np.clip(step, -0.5 * clear, 0.5 * clear)
    lo_s, hi_s = profile.support
    keep = (x > lo_s) & (x < hi_s) & ~in_zones(x, e) & np.isfinite(x)
    x = x[keep]
    return x[np.isfinite(profile.h0(x))]
