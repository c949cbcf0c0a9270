"""Cheap starting guess at a target load: the free-interpenetration (overlap) zones.

The zones ``{h0(x) - theta x < delta}`` (paper Section 6) are taken as the initial contact
zones, with ``delta`` chosen so that the single-zone Hertz-type load estimate
``P_k = (1/A) int (s - c_k) h'(s) / sqrt((s - a)(b - s)) ds`` of each zone adds up to P.  It is
only a starting point for Newton: the consistency, interconnection and admissibility checks decide.

The load is evaluated for many trial deltas at once (one ``dh0`` call per pass).  The first pass
takes a coarse ladder of ``delta`` (factors of 100; the root lies in the first step that reaches
P) together with a fan of deltas around the parabolic-minima (Hertz) estimate, which for smooth
profiles usually brackets the root tightly already.  Further passes take a fan around the chord
of ``log(load)`` against ``log(delta)`` (nearly linear: Hertz-type zones give ``P ~ delta^k``)
until the bracket is narrow enough to trust its chord.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from analytic._roots import brentq
from analytic._sie import Batch, Layout
from analytic.profiles import Profile

CHEB = 24
GUESS_RTOL = 1e-4  # the guess only seeds Newton; log-delta to this accuracy is ample
BRACKET = 3e-3  # log-delta bracket whose chord is well inside GUESS_RTOL of the root
RAYS = np.geomspace(1e-12, 20.0, 240)  # distances from a minimum, in units of profile.scale
LADDER_STEP = math.log(100.0)  # coarse steps of log(delta) when bracketing the target load
LADDER_STEPS = 20  # steps tried above the smallest delta before giving up

_LADDER = LADDER_STEP * np.arange(LADDER_STEPS + 1)
_OFFSETS = np.concatenate([[0.0, 0.0], RAYS])  # the minimum twice (a pad point, see _rays)
_NODES = np.cos(np.pi * (np.arange(CHEB) + 0.5) / CHEB)  # Chebyshev (first kind) on [-1, 1]
_LEFT, _RIGHT = 0.5 * (1.0 - _NODES), 0.5 * (1.0 + _NODES)  # node = LEFT a + RIGHT b
_FAN = BRACKET / 4 * 4.0 ** np.arange(7)  # log-delta offsets tried around an estimate
_SPREAD = np.concatenate([-_FAN[::-1], [0.0], _FAN])

LoadFn = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class _Rays:
    """``h0 - theta x`` tabulated outwards from both sides of every local minimum.

    Row ``2i`` runs left from minimum ``i`` (value ``v[i]``), row ``2i + 1`` right.  ``top`` is
    the running maximum of ``f`` along each row (sorted, so the first point at or above a level is
    a binary search).  ``x``, ``f`` and ``gain`` (the slope ``dx/df`` of the segment leaving each
    point) are flattened row by row; ``near0`` are the flat indices just before the row starts.
    """

    v: np.ndarray
    top: tuple[np.ndarray, ...]
    x: np.ndarray
    f: np.ndarray
    gain: np.ndarray
    near0: np.ndarray


def _rays(profile: Profile, theta: float) -> _Rays | None:
    """Tabulate the rays of all minima with one ``h0`` call; None without minima.

    The edge of a level is interpolated on the segment leaving the last point ``k`` with
    ``top[k] < level``, i.e. ``f[k] < level <= f[k + 1]``; a step into ``+inf`` (a corner, the end
    of the support) has zero gain, so the edge stays at ``x[k]``.  Each row starts with a
    zero-gain point at ``f = -1e300`` on the minimum (so a level not above the minimum's value
    gives the minimum itself).  A level above a whole ray extrapolates its last segment if that
    rises, else ends at the ray's end (moved into ``x[-2]``, which only that segment reads).
    """
    minima = profile.local_minima(theta)
    if not minima:
        return None
    ends = np.asarray(minima, float)
    sides = np.array([-profile.scale, profile.scale] * len(minima))
    x = ends[:, :2].reshape(-1, 1) + sides[:, None] * _OFFSETS
    f = profile.h0(x.ravel()).reshape(x.shape) - theta * x
    f[~np.isfinite(f)] = np.inf
    f[:, 0] = -1e300
    gain = np.zeros_like(x)
    with np.errstate(invalid="ignore", divide="ignore"):
        np.divide(np.diff(x[:, 1:]), np.diff(f[:, 1:]), out=gain[:, 1:-1])
    flat = f[:, -1] <= f[:, -2]
    x[flat, -2], gain[flat, -2] = x[flat, -1], 0.0
    near0 = np.arange(-1, f.size - 1, f.shape[1])
    return _Rays(ends[:, 2], tuple(np.maximum.accumulate(f, axis=1)), x.ravel(), f.ravel(),
                 gain.ravel(), near0)


def _edges(rays: _Rays, levels: np.ndarray) -> np.ndarray:
    """Where each ray first reaches each level, shape ``(levels, rays)``."""
    near = np.array([row.searchsorted(levels) for row in rays.top]).T
    near = np.minimum(near, rays.top[0].size - 1, out=near)
    near += rays.near0
    return rays.x[near] + (levels[:, None] - rays.f[near]) * rays.gain[near]


def _zones(rays: _Rays, levels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Overlap zones at every level as flat arrays ``(level index, a, b)``, in x order per level.

    The zones of the minima below a level merge where they overlap: a zone starts at a minimum
    whose left edge lies beyond the right edges of all lower-x minima, and its right edge is the
    largest right edge up to the next start.
    """
    edges = _edges(rays, levels)
    start = rays.v < levels[:, None]  # the active minima; then the starts among them
    right = np.where(start, edges[:, 1::2], -np.inf)
    start[:, 1:] &= edges[:, 2::2] > np.maximum.accumulate(right, axis=1)[:, :-1]
    first = np.flatnonzero(start)
    return (first // start.shape[1], edges.ravel()[2 * first],
            np.maximum.reduceat(right.ravel(), first))


def _loads(profile: Profile, A: float, rays: _Rays, levels: np.ndarray) -> np.ndarray:
    """Total Hertz-type load of the overlap zones at each level (one ``dh0`` call for all).

    The rotation does not enter the sum: the nodes are symmetric, so ``theta sum(s - c) = 0``.
    """
    lvl, a, b = _zones(rays, levels)
    s = a[:, None] * _LEFT + b[:, None] * _RIGHT
    per_zone = (b - a) * (profile.dh0(s.ravel()).reshape(s.shape) @ _NODES)
    return np.bincount(lvl, weights=per_zone, minlength=levels.size) * (0.5 * np.pi / CHEB / A)


def _chord(xa: float, La: float, xb: float, Lb: float, P: float) -> float:
    """Where the chord of ``log(load)`` (of the load itself if ``La <= 0``) reaches P; the
    midpoint if that is undefined or outside ``[xa, xb]``."""
    t = math.log(P / La) / math.log(Lb / La) if La > 0 else (P - La) / (Lb - La)
    x = xa + t * (xb - xa)
    return x if xa <= x <= xb else 0.5 * (xa + xb)


def _refine(load: LoadFn, P: float, xs: list[float], Ls: list[float]) -> float:
    """Chord root of ``load = P`` in the first sub-bracket of the sorted samples ``xs``.

    Needs ``Ls[0] < P <= Ls[-1]``.  Each pass evaluates a geometric fan around the chord estimate
    and the midpoint (so the bracket at least halves), and keeps the first sub-bracket where the
    load reaches P.  The chord is taken once the bracket is below GUESS_RTOL, or below BRACKET
    with the load smooth there (the neighbouring chords have the same slope: no jump or kink).
    """
    i = _first_hit(Ls, P)
    while xs[i] - xs[i - 1] > GUESS_RTOL and not (
            xs[i] - xs[i - 1] <= BRACKET and _smooth(xs, Ls, i)):
        xa, La, xb, Lb = xs[i - 1], Ls[i - 1], xs[i], Ls[i]
        trial = np.sort(np.append(_chord(xa, La, xb, Lb, P) + _SPREAD, 0.5 * (xa + xb)))
        trial = _inside(trial, xa, xb)
        xs, Ls = [xa, *trial.tolist(), xb], [La, *load(trial).tolist(), Lb]
        i = _first_hit(Ls, P)
    return _chord(xs[i - 1], Ls[i - 1], xs[i], Ls[i], P)


def _first_hit(Ls: list[float], P: float) -> int:
    """Index of the first load reaching P."""
    return next(k for k, L in enumerate(Ls) if L >= P)


def _inside(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The part of the sorted ``x`` strictly inside ``(lo, hi)``."""
    return x[x.searchsorted(lo, "right"):x.searchsorted(hi, "left")]


def _smooth(xs: list[float], Ls: list[float], i: int, rtol: float = 0.1) -> bool:
    """Whether the chord slopes of ``log(load)`` on both sides of ``[xs[i-1], xs[i]]`` match its
    own within ``rtol`` (False if a neighbour is missing, repeated or its load not positive)."""
    if i < 2 or i + 1 >= len(xs) or min(Ls[i - 2:i + 2]) <= 0:
        return False
    dx = [xs[k + 1] - xs[k] for k in range(i - 2, i + 1)]
    if min(dx) <= 0:
        return False
    g = [math.log(L) for L in Ls[i - 2:i + 2]]
    s = [(g[k + 1] - g[k]) / dx[k] for k in range(3)]
    return abs(s[0] - s[1]) <= rtol * abs(s[1]) and abs(s[2] - s[1]) <= rtol * abs(s[1])


def _hertz_log_delta(heights: list[float], P: float, A: float) -> float:
    """``log(delta)`` at which parabolic minima at ``heights`` above the lowest carry P.

    Each active one takes ``pi (delta - height) / A`` whatever its curvature; the total is convex
    and piecewise linear in ``delta``, so the root is the least root of its pieces: over the
    ``k`` lowest minima, ``(P A / pi + sum of their heights) / k``.
    """
    best, total = math.inf, P * A / math.pi
    for k, height in enumerate(sorted(heights), start=1):
        total += height
        best = min(best, total / k)
    return math.log(max(best, 1e-300))


def _log_delta(load: LoadFn, P: float, lo: float, guess: float) -> float | None:
    """``log(delta)`` at which the load reaches P, or None.

    None when the load at ``lo`` already reaches P or no step of the ladder
    ``lo + j LADDER_STEP`` reaches it; else the root inside the first step that does.  The first
    pass also samples a fan around ``guess`` (the root of a cheap model).
    """
    ladder = lo + _LADDER
    fan = guess + _SPREAD
    loads = load(np.concatenate([ladder, fan]))
    loads, fan_loads = loads[:ladder.size], loads[ladder.size:]
    if loads[0] >= P:
        return None
    hits = np.flatnonzero(loads >= P)
    if hits.size == 0:
        return None
    j = int(hits[0])
    xa, xb = float(ladder[j - 1]), float(ladder[j])
    k0, k1 = fan.searchsorted(xa, "right"), fan.searchsorted(xb, "left")
    xs = [xa, *fan[k0:k1].tolist(), xb]
    Ls = [float(loads[j - 1]), *fan_loads[k0:k1].tolist(), float(loads[j])]
    return _refine(load, P, xs, Ls)


def overlap_guess(profile: Profile, theta: float, P: float, A: float) -> Layout | None:
    """Overlap zones carrying about P, or None when no sensible guess exists."""
    rays = _rays(profile, theta)
    if rays is None:
        return None
    f0 = float(rays.v.min())

    def load(log_d: np.ndarray) -> np.ndarray:
        return _loads(profile, A, rays, f0 + np.exp(log_d))

    lo = math.log(1e-14 * max(profile.scale, 1e-300))
    log_d = _log_delta(load, P, lo, _hertz_log_delta((rays.v - f0).tolist(), P, A))
    if log_d is None:
        return None
    _, a, b = _zones(rays, np.array([f0 + math.exp(log_d)]))
    edges = [e for zone in zip(a.tolist(), b.tolist(), strict=True) for e in zone]
    if not edges or any(e >= e_next for e, e_next in zip(edges, edges[1:], strict=False)):
        return None
    if not set(profile.pin_points).isdisjoint(edges):
        return None
    return Layout(np.array(edges), np.zeros(len(edges), bool))


CENTRE_SHIFTS = np.linspace(-0.45, 0.45, 19)  # trial shifts of a zone, fractions of its width
CENTRE_XTOL = 1e-6  # relative to the zone width: a starting point, Newton does the rest


def centred(layout: Layout, profile: Profile, theta: float) -> Layout:
    """``layout`` with every zone whose edges are both free shifted (its width kept) to where
    its own consistency condition (paper Eq. 12, the zone alone) holds.

    A wedge's zone must hold its apex at ``sin(pi/2 (t_r - t_l)/(t_r + t_l))`` of its half-width
    off centre whatever the load; zones of a union started symmetric about the apex (the first
    touch) or from the overlap levels are off by a fraction of their width, and the coupled
    Newton then shrank the wedge's zone towards its apex without reducing its (scale-free)
    consistency residual ("no descent", issue 29).  A zone whose residual keeps its sign over
    the trial shifts is kept where it is."""
    edges = layout.edges.copy()
    for k, (a, b) in enumerate(layout.zones()):
        if layout.pinned[2 * k] or layout.pinned[2 * k + 1]:
            continue
        shift = _centring_shift(profile, theta, a, b)
        if shift is not None:
            edges[2 * k: 2 * k + 2] = (a + shift, b + shift)
    return Layout(edges, layout.pinned)


def _centring_shift(profile: Profile, theta: float, a: float, b: float) -> float | None:
    w = b - a
    blocked = [*profile.pin_points]
    lo, hi = profile.support

    def residual(shift: float) -> float:
        e = np.array([[a + shift, b + shift]])
        if e[0, 0] <= lo or e[0, 1] >= hi or any(e[0, 0] < q < e[0, 1] for q in blocked) \
                or not np.all(np.isfinite(profile.h0(e[0]))):
            return math.nan
        one = Layout(e[0], np.zeros(2, bool))
        with np.errstate(all="ignore"):
            mu, norm = Batch.build(one, profile, 1.0, float(e[0].mean()), e,
                                   np.array([theta]), np.zeros((1, 0))).consistency()
        return float(mu[0, 0] / (norm[0, 0] + 1e-300))

    shifts = w * CENTRE_SHIFTS
    values = [residual(float(v)) for v in shifts]
    pairs = [(float(shifts[i]), float(shifts[i + 1])) for i in range(len(values) - 1)
             if values[i] * values[i + 1] < 0]  # nan compares False: skipped
    if not pairs:
        return None
    s0, s1 = min(pairs, key=lambda pr: min(abs(pr[0]), abs(pr[1])))
    try:
        return brentq(residual, s0, s1, xtol=CENTRE_XTOL * w)
    except ValueError:  # a nan inside the bracket
        return None
