"""Topology events of the normal problem: zones appear, grow, merge, split, shrink; singular
edges pin at corners and ridges or release.

An inadmissible state (negative pressure or negative gap, found by
:mod:`analytic._admissibility`) is classified into an :class:`Event`, and
:func:`apply_event` gives the new, unsolved layout.  A new zone starts on the overlap
``{g < 0}`` (the free-interpenetration guess of the paper's Section 6).  A free edge that
converges onto a corner, or whose Newton solve fails near one, pins there (:func:`pin_nearest`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from analytic._gap import deformed_gap
from analytic._newton import State, beta_for, fresh_state
from analytic._roots import brentq
from analytic._sie import Layout, System
from analytic.profiles import Profile


@dataclass(frozen=True)
class Event:
    """A change of topology: ``kind`` at x = ``where``, of edge or zone ``index``;
    ``interval``: the overlap ``{g < 0}`` a new zone starts on."""

    kind: str       # "add", "merge", "grow", "split", "shrink", "release", "pin", "reseed"
    where: float
    index: int = -1
    interval: tuple[float, float] | None = None


def pressure_event(st: State, xi: np.ndarray, p: np.ndarray) -> Event:
    """Classify the most negative pressure ``p`` (at the points ``xi``): near an edge, a pinned
    edge releases and a free edge moves inwards; elsewhere the zone splits there."""
    x = float(xi[int(np.argmin(p))])
    e = st.layout.edges
    k = int(np.searchsorted(e, x) // 2)
    a, b = e[2 * k], e[2 * k + 1]
    near = min(x - a, b - x) < 0.05 * (b - a)
    i_edge = 2 * k if x - a < b - x else 2 * k + 1
    if near and st.layout.pinned[i_edge]:
        return Event("release", float(e[i_edge]), i_edge)
    if near:
        return Event("shrink", x, i_edge)
    return Event("split", x, k)


def gap_event(st: State, x: float, sys_: System, profile: Profile) -> Event:
    """Classify a negative deformed gap at x by the extent of ``{g < 0}`` around it: touching
    both neighbouring edges -> merge; one edge -> that edge grows to the end of the overlap;
    neither -> a new zone on the overlap interval (the Section 6 guess)."""
    lo, hi = _negative_gap_interval(sys_, x, profile)
    e = st.layout.edges
    k = int(np.searchsorted(e, x))
    left = k - 1 if k > 0 else None        # index of the edge bounding the gap on the left
    right = k if k < e.size else None
    at_left = left is not None and lo <= e[left]
    at_right = right is not None and hi >= e[right]
    if at_left and at_right:
        return Event("merge", x, k // 2 - 1)
    if at_left:
        return Event("grow", hi, left)
    if at_right:
        return Event("grow", lo, right)
    return Event("add", x, interval=(lo, hi))


def apply_event(st: State, ev: Event, sys_: System, profile: Profile) -> State:
    edges = list(st.layout.edges)
    pinned = list(st.layout.pinned)
    if ev.kind == "merge":
        m = ev.index
        del edges[2 * m + 1: 2 * m + 3]
        del pinned[2 * m + 1: 2 * m + 3]
    elif ev.kind == "grow":
        edges[ev.index] = ev.where
    elif ev.kind == "add":
        lo, hi = ev.interval
        k = int(np.searchsorted(edges, ev.where))
        edges[k:k] = [lo, hi]
        pinned[k:k] = [lo in profile.pin_points, hi in profile.pin_points]
    elif ev.kind == "split":
        k = ev.index
        a, b = edges[2 * k], edges[2 * k + 1]
        w = 0.02 * (b - a)
        edges[2 * k + 1: 2 * k + 1] = [ev.where - w, ev.where + w]
        pinned[2 * k + 1: 2 * k + 1] = [False, False]
    elif ev.kind == "release":
        i = ev.index
        a, b = edges[i - (i % 2)], edges[i - (i % 2) + 1]
        across = _across_notch(edges, i, profile)
        edges[i] += (across if i % 2 == 0 else -across) if across else \
            (0.02 if i % 2 == 0 else -0.02) * (b - a)
        pinned[i] = False
    elif ev.kind == "shrink":
        i = ev.index
        a, b = edges[i - (i % 2)], edges[i - (i % 2) + 1]
        edges[i] += (0.05 if i % 2 == 0 else -0.05) * (b - a)
    layout = Layout(np.asarray(edges, float), np.asarray(pinned, bool))
    new = fresh_state(layout, st.theta, st.P)
    return new


def _across_notch(edges: list[float], i: int, profile: Profile) -> float | None:
    """For edge i pinned at a ridge with the neighbouring zone's edge across the ridge at d from
    it, d (< 2 % of the zone): released, edge i goes to the same distance on its own side.  The
    two edges of such a notch stay about equally far from it (the gap closes only exponentially
    in the load); released 2 % of its zone from the ridge, 1e3 times too far, Newton failed and
    the edge pinned there again until the step failed (audit seed 103644 vertical)."""
    q = edges[i]
    j = i + 1 if i % 2 else i - 1  # the facing edge of the neighbouring zone
    if q not in profile.ridges or not 0 <= j < len(edges):
        return None
    d = abs(edges[j] - q)
    width = abs(edges[i + 1 if i % 2 == 0 else i - 1] - q)
    return d if 0 < d < 0.02 * width else None


def _negative_gap_interval(sys_: System, x: float, profile: Profile) -> tuple[float, float]:
    """The overlap ``{g < 0}`` around x: the free-interpenetration guess of the new zone."""
    def g(t: float) -> float:
        return float(deformed_gap(sys_, np.array([t]))[0])

    e = sys_.layout.edges
    k = int(np.searchsorted(e, x))
    left_wall = e[k - 1] if k > 0 else profile.support[0]
    right_wall = e[k] if k < e.size else profile.support[1]
    ridges = np.asarray(profile.ridges)  # a zone cannot span a ridge: stop there
    left_wall = max([left_wall, *ridges[ridges < x]])
    right_wall = min([right_wall, *ridges[ridges > x]])
    span = max(e[-1] - e[0], profile.scale)
    lo = _walk(g, x, max(left_wall, x - 2 * span), profile)
    hi = _walk(g, x, min(right_wall, x + 2 * span), profile)
    if hi - lo < 1e-9 * span:
        lo, hi = x - 1e-6 * span, x + 1e-6 * span
    return lo, hi


def _walk(g, x: float, wall: float, profile: Profile) -> float:
    ts = np.linspace(x, wall, 65)[1:]
    prev = x
    for t in ts:
        gt = g(t) if np.isfinite(profile.h0(np.array([t]))[0]) else np.inf
        if gt >= 0:
            if not np.isfinite(gt):
                corner = [c for c in profile.pin_points if min(prev, t) <= c <= max(prev, t)]
                return corner[0] if corner else prev
            return brentq(g, prev, t, xtol=1e-14 * max(1.0, abs(t)))
        prev = t
    return prev


PIN_DISTANCE = 0.05  # a free edge this close to a corner (fraction of its zone) may pin there
VERTICAL_LANDING = 3e-9
"""A free edge converged this close (x span) to a vertical end pins there: its load grows only
like -ln d, so below ~1e-9 span it is rounding-limited (the face +-1, radius 0.5 punch at d =
5e-10: int p off the zone load by 2e-8 P) while the pinned state differs only within d."""


def pin_nearest(st: State, profile: Profile, A: float, limits: np.ndarray,
                points: tuple[float, ...] | None = None) -> tuple[State, float] | None:
    """The free edge nearest a pin point (corner or ridge; or one of ``points``), if within its
    limit, becomes singular there: the new (unsolved) state and the pin position, or None."""
    e, pinned = st.layout.edges.copy(), st.layout.pinned.copy()
    best = None
    for i in np.flatnonzero(~pinned):
        for c in profile.pin_points if points is None else points:
            d = abs(e[i] - c)
            if d <= limits[i] and (best is None or d < best[0]):
                best = (d, i, c)
    if best is None:
        return None
    _, i, c = best
    e[i], pinned[i] = c, True
    new = fresh_state(Layout(e, pinned), st.theta, st.P)
    new.beta = beta_for(new, A, st.P)
    return new, float(c)


def _slope_jumps(profile: Profile, q: float) -> bool:
    """Whether h0's slope jumps at the kink q (a wedge's apex, a ridge, a vertical end), not only
    its curvature (a rounded punch's face meeting its corner arc)."""
    d = 1e-9 * max(profile.scale, abs(q))
    x = np.array([q - d, q + d])
    left, right = profile.dh0(x)
    if not (np.isfinite(left) and np.isfinite(right)):
        return True
    curvature = float(np.nanmax(np.abs(profile.d2h0(x))))
    return abs(right - left) > 4 * d * curvature + 1e-9 * (abs(left) + abs(right))


RESEED_FRACTION = 0.25  # a new zone Newton failed from restarts at this part of its seed


def shrunk_new_zone(st: State, history: list[Event], A: float, profile: Profile
                    ) -> State | None:
    """After a failed Newton solve from a zone just added on its overlap interval, the same
    state with that zone shrunk towards the deepest overlap to RESEED_FRACTION of the interval
    (just after a zone's birth the zone is several times narrower than its overlap: a birth load
    of two cylinders failed with "continuation stalled" while loads 1e-14 off solved; a zone
    born at a double wedge's apex, audit seed 178); after a failure from that seed too, the
    next of :func:`reseeds`; else None."""
    adds = [i for i, ev in enumerate(history) if ev.kind == "add"]
    if not adds or history[adds[-1]].interval is None:
        return None
    tried = len(history) - 1 - adds[-1]
    if any(ev.kind != "reseed" for ev in history[adds[-1] + 1:]):
        return None
    add = history[adds[-1]]
    seeds = reseeds(profile, *add.interval, add.where)
    if tried >= len(seeds):
        return None
    lo, hi = add.interval if tried == 0 else seeds[tried - 1]
    e = st.layout.edges.copy()
    k = np.flatnonzero((e[:-1] == lo) & (e[1:] == hi))
    if not k.size:
        return None
    e[k[0]], e[k[0] + 1] = seeds[tried]
    new = fresh_state(Layout(e, st.layout.pinned), st.theta, st.P)
    new.beta = beta_for(new, A, st.P)
    return new


def reseeds(profile: Profile, lo: float, hi: float, c: float) -> list[tuple[float, float]]:
    """Seeds of a new zone on the overlap ``(lo, hi)`` with its deepest point ``c``, in the order
    tried: RESEED_FRACTION of the overlap about ``c`` in its proportions (a wedge's apex: the
    faces set both sides); then, where no slope kink of h0 lies in that seed, the same fraction
    of the shorter side symmetric about ``c`` (a new, small zone at a smooth minimum sees the
    local parabola, not the overlap's far ends: a tilted rounded corner's overlap of -0.0030 /
    +0.0062 about ``c`` held a zone of -0.00072 / +0.00071, and Newton stalled from the
    proportional seed at three loads in a row, 1.2 s of audit seed 104623's 4.3 s).  Symmetric
    first was slower elsewhere: a nearly level face beside a corner's minimum (audit seeds
    104376, 104414) holds a zone that spreads along the face."""
    a, b = c - RESEED_FRACTION * (c - lo), c + RESEED_FRACTION * (hi - c)
    out = [(a, b)]
    half = min(c - a, b - c)
    if (c - half, c + half) != (a, b) and not any(
            a <= q <= b and _slope_jumps(profile, q) for q in profile.features):
        out.append((c - half, c + half))
    return out
