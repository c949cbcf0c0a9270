"""Quadrature over the contact set L: the zone rule ``int_L f(s) omega(s) ds ~ sum f(s_q) Omega_q``.

:func:`squad_plan` cuts every zone at the profile's kinks (and at a vertical end just beyond a
free edge), grades a segment towards a kink with a close feature beyond it, sizes each panel from
its clearance to the neighbouring zones and picks its reference rule (Gauss-Jacobi with the edge
factor of ``omega = 1/W_s`` in the weight, or the sine-mapped rule at a pinned vertical end).  The
plan holds panel ends as affine maps of ``[edges, kinks]``, so :func:`squad_nodes` places the
nodes for a whole batch of nearby edge sets at once (the frozen discretisation of
:class:`analytic._sie.Batch`).  Points of B close to an interior kink or a pinned vertical end
get local rules graded towards it (:func:`kink_rule`, :func:`vertical_end_rule`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from analytic._layout import Layout, sign_exponent, sign_from_d, w_abs, zone_signs
from analytic._rules import (
    BASE_NODES,
    GRADING,
    capped,
    graded_rule,
    jacobi_rule,
    mapped_rule,
    nodes_for,
    sine_rule,
)
from analytic.profiles import Profile

CLOSE_FLOOR = 1e-12
"""A neighbouring zone is graded towards (:func:`_close_neighbours`) only when the gap is at least
this fraction of the segment: at most ~19 graded panels (~1100 nodes); narrower gaps, and
crossed zones of a trial step, keep the one capped rule."""
KINK_ZONE = 0.25  # points this close to a kink (fraction of its pieces) get graded rules
KINK_ULPS = 64.0  # the graded rules start this many ulps of the kink away from it
NEIGHBOUR_REACH = 10.0
"""The edge half of a local rule near a kink or a vertical end (BASE_NODES Gauss-Jacobi nodes,
error ~exp(-4 BASE_NODES sqrt(gap / length)), ~1e-17 at this reach) is graded towards its edge
when the next zone lies closer than 1 / NEIGHBOUR_REACH of the half: the double wedge of 0.01 /
0.02 rad at P = 0.5, zones 6.4e-3 apart across its ridge, had p 7.6e-8 off beside the apex 0.5
beyond that half and int p 5.2e-9 P off."""


@dataclass(frozen=True)
class SQuad:
    """Quadrature over L for ``int_L f(s) omega(s) ds ~ sum f(s_q) Omega_q``: nodes ``s``
    (shifted), weights ``Omega`` (omega folded in), ``|Omega|`` and ``h'`` at the nodes.  Arrays
    are 1-D for one layout or ``(K, N)`` for a batch of K edge sets."""

    s: np.ndarray
    Omega: np.ndarray
    absOmega: np.ndarray
    dh: np.ndarray


@dataclass(frozen=True)
class SquadPlan:
    """The structure of the zone quadrature of one layout, reusable for nearby edge sets: every
    panel (a zone cut at the profile's kinks, graded towards a kink next to a close feature)
    with its ends as affine maps of ``[edges, kinks]``, its reference Gauss-Jacobi rule, the
    exponents of ``|s - e_i|`` outside the rule's weight and the profile piece that holds it."""

    lo: np.ndarray        # (panels,) index of the left end's base point in [edges, kinks]
    hi: np.ndarray
    lo_far: np.ndarray    # (panels,) the end is base + lam (far - base) (lam = 0: the point)
    lo_lam: np.ndarray
    hi_far: np.ndarray
    hi_lam: np.ndarray
    kinks: np.ndarray     # x of the kinks that cut a zone
    power: np.ndarray     # (panels,) 1 + al + ah: the weight's scaling with the half-width
    sign: np.ndarray      # (panels,) s_k of the zone
    t: np.ndarray         # (N,) reference nodes on [-1, 1], all panels
    w: np.ndarray         # (N,) reference weights
    seg: np.ndarray       # (N,) panel of each node
    expo: np.ndarray      # (N, 2n) exponents left outside the Jacobi weight
    pieces: tuple | None  # per panel: its profile piece (None: profile.dh0 on all nodes)
    counts: tuple[int, ...]


KINK_GRADE = 0.25
"""A segment ending at a kink is graded towards it (panels growing by GRADING from the distance
c to the next cut beyond the kink) when c is below this fraction of the segment: B(x) at x near
the kink on the far side (inside the zone, or beyond a close edge in the gap integrals) has a
near-singular divided difference on this segment (a rounded corner's edge 2e-4 of the face width
beyond its kink: p wrong by 5 % of the peak, load shares by 15 %)."""


def squad_plan(layout: Layout, profile: Profile) -> SquadPlan:
    """Gauss-Jacobi rules on every zone, split at the profile's kinks (edge weights at the ends,
    sizes from the clearance to the neighbouring zones, graded towards a kink with a close
    feature beyond it); the arrays are cached per structure."""
    el = layout.edges.tolist()
    clearance = zone_clearances(el)
    marks = cut_marks(profile)
    kinks = [q for q in marks if any(a < q < b for a, b in zip(el[::2], el[1::2], strict=True))]
    anchors = _vertical_anchors(layout, profile)
    kinks += sorted(set(anchors.values()) - set(kinks))
    where = {q: len(el) + j for j, q in enumerate(kinks)}
    segments, mids = [], []
    for k in range(len(el) // 2):
        a, b = el[2 * k], el[2 * k + 1]
        inner = [q for q in marks if a < q < b]
        close = _close_neighbours(el, k, max(np.diff([a, *inner, b])))
        before, i_before = _beyond(2 * k, close[0], anchors, where, el)
        after, i_after = _beyond(2 * k + 1, close[1], anchors, where, el)
        cuts = [*before, a, *inner, b, *after]
        idx = [*i_before, 2 * k, *(where[q] for q in inner), 2 * k + 1, *i_after]
        for i in range(len(before), len(cuts) - len(after) - 1):
            base = min(_segment_clearance(el, k, cuts[i], cuts[i + 1], close, clearance[k]),
                       _kink_clearance(cuts[i], cuts[i + 1], a, b))
            for panel, lo, hi in _graded_panels(cuts, idx, i, base):
                segments.append((k, *panel))
                mids.append(0.5 * (lo + hi))
    pieces = None
    if profile.global_piece is None and len(segments) > 1:
        pieces = tuple(profile.pieces[k] if k >= 0 else None
                       for k in profile.piece_index(np.array(mids)).tolist())
    return _squad_plan(tuple(layout.pinned.tolist()), tuple(kinks), tuple(segments), pieces,
                       vertical_edges(layout, profile))


def cut_marks(profile: Profile) -> tuple[float, ...]:
    """Where the zone rule cuts a zone: the profile's kinks and spline knots (sorted).  Across
    a knot h0''' jumps, so a panel spanning knots converges only algebraically (a tabulated
    profile's int p was 3.7e-8 P off with 41 samples, audit seed 100467); cut there, every
    panel holds one cubic."""
    if not profile.knots:
        return profile.kinks
    return tuple(sorted(set(profile.kinks) | set(profile.knots)))


def _vertical_anchors(layout: Layout, profile: Profile) -> dict[int, float]:
    """Free edge -> the vertical end just beyond it (nothing between, the arc ending there on
    the edge's side): ``h0' ~ (d + t)^(-1/2)`` is near-singular a distance d beyond the edge, and
    the zone's segment is graded towards the edge like towards a kink with a close cut beyond
    (ungraded, a rounded punch's edge 4e-5 short of its arcs' ends carried a load 6 % off)."""
    out: dict[int, float] = {}
    e = layout.edges.tolist()
    for i, free in enumerate((~layout.pinned).tolist()):
        side = -1.0 if i % 2 == 0 else 1.0
        wall = e[i - 1] if 0 < i and i % 2 == 0 else e[i + 1] if i + 1 < len(e) and i % 2 \
            else side * math.inf
        for v in profile.vertical_ends if free else ():
            if (v - e[i]) * side > 0 and (wall - v) * side > 0:
                k = int(profile.piece_index(np.array([0.5 * (v + e[i])]))[0])
                if k >= 0 and v in (profile.pieces[k].lo, profile.pieces[k].hi):
                    out[i] = v
    return out


def vertical_edges(layout: Layout, profile: Profile) -> tuple[bool, ...]:
    """Per edge: pinned at a vertical end of the profile (``h0' ~ d^(-1/2)`` inside it)."""
    ends = profile.vertical_ends
    return tuple(bool(pin) and float(e) in ends
                 for e, pin in zip(layout.edges.tolist(), layout.pinned.tolist(), strict=True))


def _graded_panels(cuts: list[float], idx: list[int], i: int, clearance: float) -> list:
    """Panels of segment ``[cuts[i], cuts[i+1]]``: ``((lo, lo_far, lo_lam, hi, hi_far, hi_lam,
    nodes), x_lo, x_hi)``.  An end at a kink whose next cut beyond lies closer than KINK_GRADE
    of the segment gets panels ``c GRADING^m`` from it (c that distance); one panel otherwise."""
    lo, hi = cuts[i], cuts[i + 1]
    length = hi - lo
    c_lo = lo - cuts[i - 1] if 0 < i else math.inf  # lo is a kink: distance to the cut before
    c_hi = cuts[i + 2] - hi if i + 2 < len(cuts) else math.inf  # hi is a kink: ... after
    ends = [((idx[i], idx[i], 0.0), lo)]
    ends += [((idx[i], idx[i - 1], -g), lo + c_lo * g) for g in _kink_grades(c_lo, length)]
    right = [((idx[i + 1], idx[i + 1], 0.0), hi)]
    right += [((idx[i + 1], idx[i + 2], -g), hi - c_hi * g) for g in _kink_grades(c_hi, length)]
    ends += right[::-1]
    out = []
    for (e0, x0), (e1, x1) in zip(ends[:-1], ends[1:], strict=True):
        near = min(x0 - lo + c_lo, hi - x1 + c_hi)
        n = nodes_for(x1 - x0, min(clearance, near))
        out.append(((*e0, *e1, n), x0, x1))
    return out


def _kink_grades(c: float, length: float) -> list[float]:
    """``GRADING^m``, m = 0, 1, ..., while ``c GRADING^m < KINK_GRADE length`` (none when the
    cut beyond the kink is not close, or there is no kink: ``c = inf``)."""
    out, m = [], 0
    while c * GRADING**m < KINK_GRADE * length:
        out.append(GRADING**m)
        m += 1
    return out


@lru_cache(maxsize=256)
def _squad_plan(pinned: tuple, kinks: tuple, segments: tuple, pieces: tuple | None,
                vertical: tuple) -> SquadPlan:
    """The arrays of a zone quadrature: panels ``(zone, lo, lo_far, lo_lam, hi, hi_far, hi_lam,
    nodes)`` with ``lo, hi, *_far`` indices into ``[edges, kinks]``.  A panel ending at a
    ``vertical`` edge gets the :func:`sine_rule` with every edge factor outside its weight
    (Gauss-Jacobi with the edge weight on ``h' ~ d^(-1/2)`` converges algebraically: the
    pressure of a punch pinned at its arcs' ends was 5e-6 off in the middle)."""
    n_edges = len(pinned)
    eps = np.where(pinned, -0.5, 0.5)
    signs = zone_signs(pinned)
    power, ts, ws, expo = [], [], [], []
    for _zone, lo, _lf, l_lam, hi, _hf, h_lam, n in segments:
        row = -eps  # exponents of |s - e_i| left outside the Jacobi weight
        at_lo = lo < n_edges and l_lam == 0.0
        at_hi = hi < n_edges and h_lam == 0.0
        at_vertical = (at_lo and vertical[lo]) or (at_hi and vertical[hi])
        if at_vertical:  # the sine rule: every edge factor stays outside its weight
            at_lo = at_hi = False
        al = row[lo] if at_lo else 0.0
        ah = row[hi] if at_hi else 0.0
        row[[i for i, at in ((lo, at_lo), (hi, at_hi)) if at]] = 0.0
        t, w = sine_rule(n) if at_vertical else jacobi_rule(n, float(ah), float(al))
        power.append(1.0 + al + ah)
        ts.append(t)
        ws.append(w)
        expo.append(row)
    counts = tuple(sg[7] for sg in segments)
    col = [np.array([sg[j] for sg in segments]) for j in range(1, 7)]
    return SquadPlan(col[0], col[3], col[1], col[2], col[4], col[5],
                     np.array(kinks, float), np.array(power),
                     np.array([signs[sg[0]] for sg in segments]), np.concatenate(ts),
                     np.concatenate(ws), np.repeat(np.arange(len(counts)), counts),
                     np.repeat(np.array(expo), counts, axis=0), pieces, counts)


def squad_nodes(plan: SquadPlan, profile: Profile, edges: np.ndarray, xc: float,
                theta: np.ndarray) -> SQuad:
    """The planned rule for a batch of edge sets ``(K, 2n)`` (absolute x) and rotations ``(K,)``:
    ``(K, N)`` arrays; ``Omega`` is the weight times the rest of ``omega = 1/W_s`` (one log-sum
    for all nodes)."""
    K = edges.shape[0]
    ends = np.concatenate([edges, np.broadcast_to(plan.kinks, (K, plan.kinks.size))], axis=1) \
        if plan.kinks.size else edges
    lo = ends[:, plan.lo] + plan.lo_lam * (ends[:, plan.lo_far] - ends[:, plan.lo])
    hi = ends[:, plan.hi] + plan.hi_lam * (ends[:, plan.hi_far] - ends[:, plan.hi])
    half = 0.5 * (hi - lo)
    s = (0.5 * (lo + hi))[:, plan.seg] + half[:, plan.seg] * plan.t
    # half < 0 (a NaN weight) when a member's edge has crossed a kink its plan grades towards:
    # the Jacobian steps edges away from kinks (analytic._newton._away_from_features) and
    # counts a non-finite column as an event, so no NaN reaches a result
    w = plan.w * (half**plan.power * plan.sign)[:, plan.seg]
    with np.errstate(divide="ignore"):  # a zone within ulps of its width: non-finite, rejected
        logs = np.log(np.abs(s[:, :, None] - edges[:, None, :]))
    Om = w * np.exp(np.einsum("kne,ne->kn", logs, plan.expo))
    dh = _segment_slopes(plan, profile, s) - theta[:, None]
    return SQuad(s - xc, Om, np.abs(Om), dh)


def _segment_slopes(plan: SquadPlan, profile: Profile, s: np.ndarray) -> np.ndarray:
    """``h0'`` at the nodes ``(K, N)``.  Segments end at zone edges and kinks, and every piece
    boundary inside the support is a kink or a corner, so each segment lies in one piece."""
    if plan.pieces is None:
        return profile.dh0(s)
    parts = [s[:, hi - n:hi] for n, hi in zip(plan.counts, itertools.accumulate(plan.counts),
                                              strict=True)]
    return np.concatenate([pc.dh(seg) if pc is not None else np.full(seg.shape, np.nan)
                           for pc, seg in zip(plan.pieces, parts, strict=True)], axis=1)


def zone_clearances(edges: list[float]) -> list[float]:
    """Distance from each zone to the nearest edge of another zone (inf for a single zone);
    the edges are sorted, so only the neighbouring zones matter."""
    return [min(_gap_beyond(edges, 2 * k), _gap_beyond(edges, 2 * k + 1))
            for k in range(len(edges) // 2)]


def _beyond(i: int, neighbour: int | None, anchors: dict[int, float], where: dict[float, int],
            edges: list[float]) -> tuple[list[float], list[int]]:
    """The cut beyond edge i that its segment is graded towards, as ``([x], [index into
    [edges, kinks]])``: the vertical end just beyond it (:func:`_vertical_anchors`), else the
    close neighbour's facing edge (:func:`_close_neighbours`); ``([], [])`` when neither."""
    if i in anchors:
        return [anchors[i]], [where[anchors[i]]]
    if neighbour is not None:
        return [edges[neighbour]], [neighbour]
    return [], []


def _close_neighbours(edges: list[float], k: int, longest: float) -> tuple[int | None, int | None]:
    """Per side of zone k, the index of the neighbouring zone's facing edge when it is too close
    for one rule (:func:`analytic._rules.capped` on the zone's longest segment), else None: the
    zone's segment is then graded towards that edge like towards a kink with a close cut beyond
    (audit seed 106705: two zones 0.42 and 0.45 wide, 1.4e-5 apart across a ridge, capped at
    MAX_NODES, put the rigid approach 2e-8 A P and the zone loads 6e-9 P off)."""
    left = 2 * k - 1 if _graded_gap(longest, _gap_beyond(edges, 2 * k)) else None
    right = 2 * k + 2 if _graded_gap(longest, _gap_beyond(edges, 2 * k + 1)) else None
    return left, right


def _graded_gap(longest: float, gap: float) -> bool:
    """A gap graded towards: one rule would be capped, and the gap is at least CLOSE_FLOOR of
    the segment (crossed or touching zones of a rejected Newton step keep the capped rule; no
    neighbour, ``gap = inf``, is never capped)."""
    return CLOSE_FLOOR * longest < gap and capped(longest, gap)


def _segment_clearance(edges: list[float], k: int, lo: float, hi: float,
                       close: tuple[int | None, int | None], clearance: float) -> float:
    """Distance from segment ``[lo, hi]`` of zone k to the neighbouring zones: the zone's
    clearance, unless a neighbour is graded towards (:func:`_close_neighbours`); on that side
    its distance from the segment (none for the segment at its edge: the graded panels are
    sized on it)."""
    if close == (None, None):
        return clearance
    a, b = edges[2 * k], edges[2 * k + 1]
    n = len(edges) // 2
    out = math.inf
    if k > 0:
        gap = a - edges[2 * k - 1]
        out = min(out, gap if close[0] is None else math.inf if lo == a else gap + lo - a)
    if k + 1 < n:
        gap = edges[2 * k + 2] - b
        out = min(out, gap if close[1] is None else math.inf if hi == b else gap + b - hi)
    return out


def _kink_clearance(lo: float, hi: float, a: float, b: float) -> float:
    # a piece ending at a kink is smooth there, but the zone's own other edge may be close
    return max(hi - lo, 1e-300) if (lo == a and hi == b) else max(min(hi - lo, b - a), 1e-300)


# local rules for B next to an interior kink or a pinned vertical end --------------------------
def near_kinks(layout: Layout, profile: Profile, x: np.ndarray) -> list:
    """(indices, kink, zone cuts, clearances beyond them) per interior kink: the points
    closer to it than KINK_ZONE of its shorter piece."""
    out = []
    marks = cut_marks(profile)
    for a, b in layout.edges.reshape(-1, 2):
        kinks = [q for q in profile.kinks if a < q < b]
        if not kinks:
            continue
        cuts = [a, *(q for q in marks if a < q < b), b]  # the kink's pieces end at spline knots
        for q in kinks:
            m = cuts.index(q)
            reach = KINK_ZONE * min(q - cuts[m - 1], cuts[m + 1] - q)
            beyond = (cuts[m - 1] - cuts[m - 2] if m >= 2 else 0.0,
                      cuts[m + 2] - cuts[m + 1] if m + 2 < len(cuts) else 0.0)
            # at the kink itself (p log-singular at an apex) the plain rule's value stays
            near = np.abs(x - q)
            j = np.flatnonzero((near < reach) & (near > 0.0))
            if j.size:
                out.append((j, q, (cuts[m - 1], q, cuts[m + 1]), beyond))
    return out


def near_vertical_ends(lay: Layout, profile: Profile, x: np.ndarray) -> list:
    """(indices, end, cut) per pinned vertical end: the points inside its zone closer to it
    than KINK_ZONE of its segment (``cut`` the nearest kink or edge inside the zone)."""
    out = []
    for i in np.flatnonzero(vertical_edges(lay, profile)).tolist():
        a, b = lay.edges[2 * (i // 2)], lay.edges[2 * (i // 2) + 1]
        end = float(lay.edges[i])
        inner = [q for q in profile.kinks if a < q < b] + [b if end == a else a]
        cut = min(inner, key=lambda q: abs(q - end))
        d = np.abs(x - end)
        j = np.flatnonzero((d < KINK_ZONE * abs(end - cut)) & (d > 0)
                           & (np.sign(x - end) == np.sign(cut - end)))
        if j.size:
            out.append((j, end, cut))
    return out


def vertical_end_rule(lay: Layout, sq: SQuad, xc: float, x: np.ndarray, end: float,
                      cut: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (absolute) and weights (times omega) of the zone rule for points x near a pinned
    vertical end: on the segment's half at the end ``s = end - L u^2`` (the slope's
    ``d^(-1/2)`` and the edge factor smooth in u) with u-panels graded towards the end down to
    the nearest point's distance; its other half by the edge's Jacobi rule (``cut`` an edge) or
    Gauss-Legendre (a kink); the zone rule ``sq`` elsewhere."""
    edges, eps = lay.edges, lay.eps
    side = math.copysign(1.0, cut - end)
    L = 0.5 * abs(cut - end)
    s_abs = sq.s + xc
    keep = (s_abs - min(end, cut)) * (s_abs - max(end, cut)) > 0
    d = float(np.min(np.abs(x - end)))
    depth = max(1, math.ceil(0.5 * math.log(L / d) / math.log(GRADING)) + 1)
    bounds = np.append(GRADING ** -np.arange(depth + 1.0), 0.0)
    u0, w0 = np.polynomial.legendre.leggauss(16)
    lo_u, hi_u = bounds[1:, None], bounds[:-1, None]
    u = (0.5 * (lo_u + hi_u) + 0.5 * (hi_u - lo_u) * u0).ravel()
    s_near = end + side * L * u * u
    w_near = (0.5 * (hi_u - lo_u) * w0).ravel() * 2.0 * L * u
    off = s_near != end  # a node rounded onto the end carries a negligible weight
    s_near, w_near = s_near[off], w_near[off]
    i_cut = np.flatnonzero(edges == cut)
    skip = np.zeros(edges.size, bool)
    lo_, hi_ = sorted((cut, end + side * L))
    if i_cut.size:
        s_far, w_far = _edge_half(lay, int(i_cut[0]), side, L)
        skip[i_cut[0]] = True
    else:
        s_far, w_far = mapped_rule(lo_, hi_, 0.0, 0.0, BASE_NODES)
    O = [w_near * sign_from_d(sign_exponent(s_near, edges, lay.pinned))
         * w_abs(s_near, edges, -eps),
         w_far * sign_from_d(sign_exponent(s_far, edges, lay.pinned))
         * w_abs(s_far, edges, -eps, skip)]
    s_all = np.concatenate([s_abs[keep], s_near, s_far])
    O_all = np.concatenate([sq.Omega[keep], *O])
    return s_all, O_all


def kink_rule(layout: Layout, profile: Profile, sq: SQuad, xc: float, x: np.ndarray,
              cuts: tuple, beyond: tuple) -> tuple[np.ndarray, np.ndarray, float]:
    """Nodes (absolute) and weights (times omega) of the zone rule for points x near the kink
    ``cuts[1]``: one rule on its two pieces graded towards it down to the nearest point's
    distance (a panel at distance d from the kink is ~d long, so every farther point is
    resolved too), the zone rule ``sq`` elsewhere; and ``tau``, the half-width left out around
    the kink (its part of B is :meth:`analytic._sie.System._kink_core`)."""
    lo, q, hi = cuts
    s_abs = sq.s + xc
    keep = (s_abs <= lo) | (s_abs >= hi)
    s_new, O_new = [sq.s[keep]], [sq.Omega[keep]]
    d = float(np.min(np.abs(x - q)))
    tau = KINK_ULPS * float(np.spacing(abs(q)))
    for end, side, far in ((lo, -1.0, beyond[0]), (hi, 1.0, beyond[1])):
        s_piece, O_piece = _graded_piece(layout, profile, q, end, side, d, far, tau)
        s_new.append(s_piece - xc)
        O_new.append(O_piece)
    return np.concatenate(s_new) + xc, np.concatenate(O_new), tau


def _graded_piece(lay: Layout, profile: Profile, q: float, end: float, side: float,
                  d: float, far: float, tau: float = 0.0):
    """Nodes/weights (times omega) on the piece between kink q and ``end``: graded towards q
    on its inner half; on the outer half Gauss-Jacobi (edge weight) if ``end`` is an edge,
    else graded towards ``end`` from ``far``, the distance to the next cut beyond it (a
    rounded corner's edge close beyond its kink: 32 plain nodes left 8e-7 of the peak)."""
    edges, eps = lay.edges, lay.eps
    L = abs(end - q)
    t, w = graded_rule(0.5 * L - tau, d + tau, 0.0)
    s_in = q + side * (tau + t)
    i_end = np.flatnonzero(edges == end)
    skip = np.zeros(edges.size, bool)
    if i_end.size and vertical_edges(lay, profile)[i_end[0]]:
        t_out, w_out = sine_rule(BASE_NODES)
        s_out = q + side * 0.75 * L + side * 0.25 * L * t_out
        w_out = w_out * 0.25 * L
    elif i_end.size and int(i_end[0]) in (anchors := _vertical_anchors(lay, profile)):
        # a vertical end just beyond the edge: graded towards the edge from its distance
        t_out, w_out = graded_rule(0.5 * L, min(abs(anchors[int(i_end[0])] - end), 0.5 * L),
                                   float(-eps[i_end[0]]))
        s_out = end - side * t_out
        skip[i_end[0]] = True
    elif i_end.size:
        s_out, w_out = _edge_half(lay, int(i_end[0]), side, 0.5 * L)
        skip[i_end[0]] = True
    else:
        t_out, w_out = graded_rule(0.5 * L, min(far, 0.5 * L), 0.0)
        s_out = end - side * t_out
    d_in = sign_exponent(s_in, edges, lay.pinned)
    O_in = w * sign_from_d(d_in) * w_abs(s_in, edges, -eps)
    d_out = sign_exponent(s_out, edges, lay.pinned)
    O_out = w_out * sign_from_d(d_out) * w_abs(s_out, edges, -eps, skip)
    return np.concatenate([s_in, s_out]), np.concatenate([O_in, O_out])


def _edge_half(lay: Layout, i: int, side: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights (edge factor ``|s - e_i|^(-eps_i)`` in the weight) on the ``length``
    inside edge i of a local rule, ``side`` pointing from the inside towards the edge:
    BASE_NODES Gauss-Jacobi nodes, graded towards the edge from the gap when the next zone
    beyond it lies within 1 / NEIGHBOUR_REACH of the length (:func:`analytic._rules.graded_rule`;
    its edge factors are smooth only on the scale of the gap)."""
    end = float(lay.edges[i])
    a_end = float(-lay.eps[i])
    gap = _gap_beyond(lay.edges.tolist(), i)
    if NEIGHBOUR_REACH * gap < length:
        t, w = graded_rule(length, gap, a_end)
        return end - side * t, w
    lo_, hi_ = (end - length, end) if side > 0 else (end, end + length)
    return mapped_rule(lo_, hi_, *((0.0, a_end) if side > 0 else (a_end, 0.0)), BASE_NODES)


def _gap_beyond(edges: list[float], i: int) -> float:
    """Distance from edge i to the facing edge of the next zone on its outer side (inf if none)."""
    if i % 2 == 0:
        return edges[i] - edges[i - 1] if i > 0 else math.inf
    return edges[i + 1] - edges[i] if i + 1 < len(edges) else math.inf
