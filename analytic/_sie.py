"""Singular-integral machinery for the normal problem with any number of zones and edge types.

Notation (p >= 0 compressive; the paper's p <= 0 is flipped here, once).  The governing equation
in the contact set ``L = U [a_k, b_k]`` is ``h'(x) = (A/pi) PV int_L p(s)/(x - s) ds`` with
``h = h0 - theta x`` (paper Table 1, stage 1, sign-flipped).  Let the edges be split into
nonsingular ``gamma`` (p -> 0, ``eps = +1/2``) and singular ``eta`` (corners, ``eps = -1/2``) and

    W(z) = prod_N (z - gamma)^(1/2) / prod_S (z - eta)^(1/2),    W ~ z^(e - n) at infinity.

On zone k the boundary value is ``W^+ = i W_s`` with the real, signed ``W_s = s_k |W|`` and
``s_k = (-1)^((d - 1)/2)``, ``d`` = (#nonsingular - #singular) edges to the right of x
(for e = 2n this is the paper's ``(-1)^(n-k)``, Eq. 2).  In a gap ``W`` itself is real with sign
``(-1)^(d/2)``.  Writing ``omega = 1/W_s`` the inversion (paper Eqs. 3-13, generalised) is

    p(x)  = W_s(x) B(x) / (pi A)            x in L,
    g'(x) = W(x)  B(x) / pi                 x outside L  (deformed-gap slope),
    B(x)  = int_L (h'(s) - H) omega(s)/(s - x) ds + pi H Poly(x) + T(x),

with ``H = h'(x)`` (any value works away from L; near an edge the analytic continuation of the
edge's profile piece removes the near-singularity), ``Poly`` the polynomial part of ``1/W`` at
infinity (zero when e > n, from ``PV int_L omega/(s-x) ds = pi Poly(x)``), and
``T(x) = sum_k beta_k x^k`` of degree ``n - e - 1`` (only when e < n; ``beta_{n-e-1} = -A P``).
The consistency conditions (paper Eqs. 12/14) are ``mu_j = int_L s^j h' omega ds = 0``,
``j < e - n``; equilibrium is ``P = mu_{e-n}/A`` (e >= n) and the moment about the shift centre
``M = (mu_{e-n+1} + w1 mu_{e-n})/A`` with ``W = z^(e-n)(1 + w1/z + ...)``.  The rigid
interconnection (paper Eq. 17) between zones m and m+1 is
``h(a_{m+1}) - h(b_m) + int_{b_m}^{a_{m+1}} w'(x) dx = 0``, ``w' = g' - h'``.

All coordinates here are shifted by the centre ``xc`` (powers stay well scaled).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property, lru_cache

import numpy as np
from scipy.special import roots_jacobi

from analytic.profiles import Piece, Profile

BASE_NODES = 32
MAX_NODES = 640


@lru_cache(maxsize=512)
def jacobi_rule(n: int, alpha_hi: float, alpha_lo: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Jacobi rule on [-1, 1] for the weight ``(1 - t)^alpha_hi (1 + t)^alpha_lo``."""
    t, w = roots_jacobi(n, alpha_hi, alpha_lo)
    return t, w


def mapped_rule(lo: float, hi: float, alpha_lo: float, alpha_hi: float, n: int):
    """Nodes and weights on [lo, hi] for ``(x - lo)^alpha_lo (hi - x)^alpha_hi f(x)``."""
    t, w = jacobi_rule(int(n), float(alpha_hi), float(alpha_lo))
    half = 0.5 * (hi - lo)
    return 0.5 * (lo + hi) + half * t, w * half ** (1.0 + alpha_lo + alpha_hi)


def nodes_for(length: float, clearance: float) -> int:
    """Quadrature size for an interval whose nearest outside singularity is ``clearance`` away."""
    ratio = float(length) / max(float(clearance), 1e-300)
    if not ratio < 1e300:
        return MAX_NODES
    n = BASE_NODES + 14.0 * math.sqrt(max(ratio, 0.0))
    return int(min(MAX_NODES, 8 * math.ceil(n / 8)))


GRADING = 4.0
KINK_ZONE = 0.25  # points this close to a kink (fraction of its pieces) get graded rules
KINK_ULPS = 64.0  # the graded rules start this many ulps of the kink away from it


@lru_cache(maxsize=4096)
def graded_rule(length: float, clearance: float, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Rule for ``int_0^length t^eps f(t) dt`` where f varies on the scale ``clearance`` near 0.

    Sub-intervals grow geometrically from ``clearance``: Gauss-Jacobi (weight ``t^eps``) on the
    first, Gauss-Legendre with ``t^eps`` folded into the weights on the others.
    """
    first = min(length, max(clearance, 1e-300))
    t, w = mapped_rule(0.0, first, eps, 0.0, nodes_for(first, clearance))
    ts, ws = [t], [w]
    lo = first
    while lo < length * (1 - 1e-14):
        hi = min(length, lo * GRADING)
        tt, ww = mapped_rule(lo, hi, 0.0, 0.0, 24)
        ts.append(tt)
        ws.append(ww * tt**eps)
        lo = hi
    return np.concatenate(ts), np.concatenate(ws)


@dataclass(frozen=True)
class Layout:
    """Contact topology: edges ``[a1, b1, a2, b2, ...]`` (absolute x) and singular flags."""

    edges: np.ndarray
    pinned: np.ndarray

    @property
    def n(self) -> int:
        return self.edges.size // 2

    @property
    def e(self) -> int:
        """Number of nonsingular edges."""
        return _edge_flags(self.pinned.tobytes())[0]

    @property
    def eps(self) -> np.ndarray:
        """Exponent of each edge in W: +1/2 nonsingular, -1/2 singular (read-only)."""
        return _edge_flags(self.pinned.tobytes())[1]

    @property
    def free(self) -> np.ndarray:
        """Indices of the nonsingular edges (read-only)."""
        return _edge_flags(self.pinned.tobytes())[2]

    def zones(self) -> list[tuple[float, float]]:
        return [(float(a), float(b)) for a, b in self.edges.reshape(-1, 2)]

    def edge_widths(self) -> np.ndarray:
        """Width of the zone each edge belongs to ``(2n,)``."""
        return np.repeat(np.diff(self.edges.reshape(-1, 2), axis=1).ravel(), 2)

    def with_edges(self, edges: np.ndarray) -> Layout:
        return Layout(np.asarray(edges, float), self.pinned)


@lru_cache(maxsize=256)
def _edge_flags(pinned: bytes) -> tuple[int, np.ndarray, np.ndarray]:
    """``e``, the exponents ``eps`` and the free-edge indices of the singular flags ``pinned``
    (as bytes); the arrays are read-only."""
    flags = np.frombuffer(pinned, dtype=bool)
    eps = np.where(flags, -0.5, 0.5)
    free = np.flatnonzero(~flags)
    eps.flags.writeable = free.flags.writeable = False
    return int(free.size), eps, free


def sign_exponent(x: np.ndarray, edges: np.ndarray, pinned: np.ndarray) -> np.ndarray:
    """``d = #nonsingular - #singular`` edges strictly to the right of each x."""
    right = edges[None, :] > np.asarray(x)[:, None]
    return (right & ~pinned).sum(1) - (right & pinned).sum(1)


def sign_from_d(d: np.ndarray) -> np.ndarray:
    """Real sign of ``W`` (d even, outside L) or of ``W_s`` (d odd, inside L)."""
    k = (d - (d % 2)) // 2
    return 1.0 - 2.0 * (k % 2)


def w_abs(x: np.ndarray, edges: np.ndarray, eps: np.ndarray, skip: np.ndarray | None = None):
    """``prod |x - e_i|^eps_i`` over the edges not in ``skip`` (boolean mask)."""
    use = np.ones(edges.size, bool) if skip is None else ~skip
    diff = np.abs(np.asarray(x)[..., None] - edges[use])
    return np.exp(np.sum(eps[use] * np.log(diff), axis=-1))


def series_coeffs(edges: np.ndarray, eps: np.ndarray, power: float, order: int) -> np.ndarray:
    """Coefficients ``c_j`` (j <= order) of ``prod (1 - e_i u)^(power*eps_i)`` in powers of u."""
    c = np.zeros(order + 1)
    c[0] = 1.0
    for ei, pi_ in zip(edges, eps, strict=True):
        f = _binomial_series(power * pi_, order) * (-ei) ** np.arange(order + 1)
        c = np.convolve(c, f)[: order + 1]
    return c


def _binomial_series(alpha: float, order: int) -> np.ndarray:
    """``binom(alpha, j)`` for j <= order by the product formula (valid for any real alpha)."""
    out = np.ones(order + 1)
    for j in range(1, order + 1):
        out[j] = out[j - 1] * (alpha - j + 1) / j
    return out


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
    kinks = [q for q in profile.kinks
             if any(a < q < b for a, b in zip(el[::2], el[1::2], strict=True))]
    anchors = _vertical_anchors(layout, profile)
    kinks += sorted(set(anchors.values()) - set(kinks))
    where = {q: len(el) + j for j, q in enumerate(kinks)}
    segments, mids = [], []
    for k in range(len(el) // 2):
        a, b = el[2 * k], el[2 * k + 1]
        before = [anchors[2 * k]] if 2 * k in anchors else []
        after = [anchors[2 * k + 1]] if 2 * k + 1 in anchors else []
        cuts = [*before, a, *[q for q in profile.kinks if a < q < b], b, *after]
        idx = [where[q] for q in before] + [2 * k] + [where[q] for q in cuts[len(before) + 1:
               len(cuts) - len(after) - 1]] + [2 * k + 1] + [where[q] for q in after]
        for i in range(len(before), len(cuts) - len(after) - 1):
            base = min(clearance[k], _kink_clearance(cuts[i], cuts[i + 1], a, b))
            for panel, lo, hi in _graded_panels(cuts, idx, i, base):
                segments.append((k, *panel))
                mids.append(0.5 * (lo + hi))
    pieces = None
    if profile.global_piece is None and len(segments) > 1:
        pieces = tuple(profile.pieces[k] if k >= 0 else None
                       for k in profile.piece_index(np.array(mids)).tolist())
    return _squad_plan(tuple(layout.pinned.tolist()), tuple(kinks), tuple(segments), pieces,
                       vertical_edges(layout, profile))


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


@lru_cache(maxsize=64)
def sine_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre in v on [-1, 1] mapped by ``t = sin(pi v / 2)``: ``(1 -+ t)^(+-1/2)`` and
    ``d^(-1/2)`` slopes (a vertical end) times ``dt`` are smooth in v (no Jacobi weight)."""
    v, wv = np.polynomial.legendre.leggauss(n)
    return np.sin(0.5 * np.pi * v), wv * 0.5 * np.pi * np.cos(0.5 * np.pi * v)


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


def zone_signs(pinned: Sequence[bool]) -> list[float]:
    """``s_k``: the sign of ``W_s`` on each zone (from d, the edges to the right of its middle),
    given the singular flags of the edges."""
    d, out = 0, []
    for i, pin in reversed(list(enumerate(pinned))):
        d += -1 if pin else 1
        if i % 2 == 1:  # d now counts b_k and everything right of it
            out.append(1.0 - 2.0 * (((d - (d % 2)) // 2) % 2))
    return out[::-1]


def zone_clearances(edges: list[float]) -> list[float]:
    """Distance from each zone to the nearest edge of another zone (inf for a single zone);
    the edges are sorted, so only the neighbouring zones matter."""
    n = len(edges) // 2
    return [min(edges[2 * k] - edges[2 * k - 1] if k > 0 else math.inf,
                edges[2 * k + 2] - edges[2 * k + 1] if k + 1 < n else math.inf)
            for k in range(n)]


def _kink_clearance(lo: float, hi: float, a: float, b: float) -> float:
    # a piece ending at a kink is smooth there, but the zone's own other edge may be close
    return max(hi - lo, 1e-300) if (lo == a and hi == b) else max(min(hi - lo, b - a), 1e-300)


def cauchy_sums(sq: SQuad, xh: np.ndarray, H: np.ndarray,
                dH: np.ndarray | Callable[[], np.ndarray] | None = None,
                off_nodes: bool = False) -> np.ndarray:
    """``int_L (h'(s) - H) omega(s)/(s - x) ds`` at shifted points ``xh`` ``(K, M)`` with the
    subtraction values ``H`` ``(K, M)``, for a batch rule ``sq`` ``(K, N)``.

    Where a point coincides with a node (closer than 1e-13 relative) the divided difference is
    replaced by its limit ``dH`` (an array, a callable giving it, or None for 0); the check is
    skipped for points known to lie outside the zones (``off_nodes``)."""
    if xh.shape[0] > 1:  # member by member: one member's matrix stays in cache
        fill = None if dH is None else np.asarray(dH() if callable(dH) else dH,
                                                  float).reshape(xh.shape)
        return np.concatenate([cauchy_sums(
            SQuad(sq.s[k:k + 1], sq.Omega[k:k + 1], sq.absOmega[k:k + 1], sq.dh[k:k + 1]),
            xh[k:k + 1], H[k:k + 1], None if fill is None else fill[k:k + 1], off_nodes)
            for k in range(xh.shape[0])])
    diff = sq.s[0][None, :] - xh[0][:, None]
    q = sq.dh[0][None, :] - H[0][:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        q /= diff
    if not off_nodes:
        np.abs(diff, out=diff)
        tiny = 1e-13 * (1.0 + np.abs(xh[0]))
        if xh.size and diff.min() < tiny.max():
            small = diff < tiny[:, None]
            fill = np.zeros(xh.shape[1]) if dH is None else np.asarray(
                dH() if callable(dH) else dH, float).reshape(xh.shape)[0]
            q = np.where(small, np.broadcast_to(fill[:, None], q.shape), q)
    return (q @ sq.Omega[0])[None, :]


FAR_NODES = 48
SUBTRACT_REACH = 2.0
"""Interconnection integrals subtract the edge piece's slope in B (near-singular at the edge)
only up to this many widths of the edge's zone: farther, the zone rule (sized for points a
clearance away) resolves ``B`` without it."""
GAP_CHUNK = 32  # targets per batch of gap integrals (a plan's maps are dense: parts x nodes)


@dataclass(frozen=True)
class GapPlan:
    """Structure of integrals of ``g'`` from edges towards targets, every node affine in three
    per-integral lengths: ``D = |x_to - x_edge|``, ``L = min(D, reach limit)`` (the part graded
    towards the edge) and ``f = min(L, clearance)`` (its first sub-interval).  A node sits at
    ``x = x_edge + dir t`` with ``t = a . (f, L, D)``, the half-width of its sub-interval is
    ``c . (f, L, D)`` and its weight ``w hw base^ex`` with ``base = b_f f + b_t t`` (``w`` holds
    the direction and the sign of W in the gap).

    Graded part: Gauss-Jacobi on ``[0, f]`` with the edge factor ``t^eps`` of W in the weight,
    then Gauss-Legendre on sub-intervals growing geometrically (ratio GRADING) up to ``L`` with
    ``t^eps`` folded into the weights; the edge piece's continuation is the subtraction value.
    Beyond ``L`` (half-way to the end of that continuation): plain Gauss-Legendre, ``H = 0``.
    A part may also drop the subtraction (``H = 0``) from the ``switch``-th graded boundary
    ``f GRADING^switch`` on (see :meth:`Batch.gap_plan`), so its sum there is ``int w'``.
    """

    edge: np.ndarray        # (parts,) edge index
    direction: np.ndarray   # (parts,) +1 rightwards, -1 leftwards
    reach: np.ndarray       # (parts,) end of the edge piece's continuation on that side
    pieces: tuple           # (parts,) edge piece
    far: tuple              # (parts,) whether a plain part follows the graded one
    part: np.ndarray        # (nodes,) integral of each node
    own: np.ndarray         # (nodes,) edge whose factor is in the weight, -1 for plain nodes
    a: np.ndarray           # (3, nodes) t coefficients of (f, L, D)
    c: np.ndarray           # (3, nodes) half-width coefficients
    b: np.ndarray           # (2, nodes) base coefficients of (f, t)
    ex: np.ndarray          # (nodes,) exponent of the base (eps of the edge; 0 on plain parts)
    w: np.ndarray           # (nodes,) reference weight times the direction and the sign of W
    groups: tuple           # (piece, node indices) of the graded nodes, per piece
    sums: np.ndarray        # (nodes, parts) indicator: which integral each node adds to
    n_edges: int            # 2n
    switch: np.ndarray      # (parts,) graded boundary where H drops to 0, -1: never

    @cached_property
    def maps(self) -> np.ndarray:
        """The matrix from ``[edges, f, L, D]`` ``(K, 2n + 3 parts)`` to the nodes' ``[x,
        half-width, base]`` ``(K, 3 nodes)``, all three affine in those."""
        per_part = self.sums.T
        t, hw = (np.concatenate([per_part * m[i] for i in range(3)]) for m in (self.a, self.c))
        f_term = np.concatenate([per_part * self.b[0], 0.0 * per_part, 0.0 * per_part])
        pick = (np.arange(self.n_edges)[:, None] == self.edge[self.part]).astype(float)
        none = np.zeros(pick.shape)
        return np.concatenate([np.concatenate([pick, t * self.direction[self.part]]),
                               np.concatenate([none, hw]),
                               np.concatenate([none, f_term + t * self.b[1]])], axis=1)

    def nodes(self, edges: np.ndarray, lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nodes ``x`` and weights ``(K, nodes)`` for edges ``(K, 2n)`` and the per-integral
        lengths ``[f, L, D]`` ``(K, 3 parts)``."""
        m = self.part.size
        xhb = np.concatenate([edges, lengths], axis=1) @ self.maps
        return xhb[:, :m], self.w * xhb[:, m:2 * m] * xhb[:, 2 * m:] ** self.ex

    @cached_property
    def graded(self) -> tuple[np.ndarray, np.ndarray]:
        """The graded nodes and the edge whose factor their weight holds."""
        rows = np.flatnonzero(self.own >= 0)
        return rows, self.own[rows]


def _graded_part(n_first: int, n_graded: int) -> list[tuple]:
    """Per sub-interval of the graded part: (reference rule, t = lo(1-tau)/2 + hi(1+tau)/2 with
    lo and hi as (f, L, D) coefficients, Jacobi flag)."""
    out = [(n_first, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), True)]
    for m in range(n_graded):
        lo = (GRADING**m, 0.0, 0.0)
        hi = (0.0, 1.0, 0.0) if m == n_graded - 1 else (GRADING ** (m + 1), 0.0, 0.0)
        out.append((24, lo, hi, False))
    return out


@lru_cache(maxsize=256)
def _gap_plan(structure: tuple, pinned: tuple) -> GapPlan:
    """The plan of the integrals ``(edge, direction, eps, piece, n_first, n_graded, far,
    switch)`` for edges with the singular flags ``pinned``."""
    cols: dict[str, list] = {k: [] for k in ("part", "own", "a", "c", "b", "ex", "w", "subst")}
    groups: dict = {}
    right = np.cumsum(np.where(pinned, -1, 1)[::-1])[::-1]  # d at x just left of each edge
    for j, (edge, direction, eps, _pc, n_first, n_graded, far, switch) in enumerate(structure):
        # the sign of W in the gap next to the edge: d counts the edges to the right of x
        d = right[edge + 1] if direction > 0 and edge + 1 < len(pinned) else \
            (0 if direction > 0 else right[edge])
        sign = float(sign_from_d(np.array(d)))
        subs = _graded_part(n_first, n_graded) if n_first else []
        if far:
            subs.append((FAR_NODES, (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), None))
        for k, (n, lo, hi, jacobi) in enumerate(subs):
            tau, w = jacobi_rule(n, 0.0, eps) if jacobi else jacobi_rule(n, 0.0, 0.0)
            lo_, hi_ = np.array(lo)[:, None], np.array(hi)[:, None]
            cols["a"].append(lo_ * (1 - tau) / 2 + hi_ * (1 + tau) / 2)
            cols["c"].append(np.repeat((hi_ - lo_) / 2, n, axis=1))
            cols["b"].append(np.repeat([[0.5], [0.0]] if jacobi else [[0.0], [1.0]], n, axis=1))
            cols["ex"].append(np.full(n, 0.0 if jacobi is None else eps))
            cols["w"].append(sign * direction * w)
            cols["own"].append(np.full(n, -1 if jacobi is None else edge))
            cols["subst"].append(np.full(n, jacobi is not None and not 0 <= switch < k))
            cols["part"].append(np.full(n, j))
    if not cols["part"]:
        z = np.zeros(0)
        return GapPlan(*_part_arrays(structure), np.zeros(0, int), np.zeros(0, int),
                       np.zeros((3, 0)), np.zeros((3, 0)), np.zeros((2, 0)), z, z, (),
                       np.zeros((0, len(structure))), len(pinned),
                       np.array([s[7] for s in structure], int))
    part = np.concatenate(cols["part"])
    own = np.concatenate(cols["own"])
    subst = np.concatenate(cols["subst"])
    for pc in {s[3] for s in structure}:
        nodes = np.flatnonzero(subst & np.isin(part, [j for j, s in enumerate(structure)
                                                           if s[3] is pc]))
        if nodes.size:
            groups[pc] = nodes
    return GapPlan(*_part_arrays(structure), part, own, np.concatenate(cols["a"], 1),
                   np.concatenate(cols["c"], 1), np.concatenate(cols["b"], 1),
                   np.concatenate(cols["ex"]), np.concatenate(cols["w"]), tuple(groups.items()),
                   (part[:, None] == np.arange(len(structure))).astype(float), len(pinned),
                   np.array([s[7] for s in structure], int))


def _switch(first: float, n_graded: int, reach: float) -> int:
    """The first inner boundary ``first GRADING^m`` (``m < n_graded``) of a graded part at least
    ``reach`` from its edge, -1 if none."""
    for m in range(n_graded):
        if first * GRADING**m >= reach:
            return m
    return -1


def _part_arrays(structure: tuple) -> tuple:
    edge = np.array([s[0] for s in structure], int)
    direction = np.array([s[1] for s in structure], float)
    reach = np.array([s[3].reach[1] if s[0] % 2 == 1 else s[3].reach[0] for s in structure],
                     float)
    return edge, direction, reach, tuple(s[3] for s in structure), tuple(s[6] for s in structure)


@dataclass(frozen=True)
class Batch:
    """The equations of one contact topology for K edge sets at once (paper Eqs. 12/14, 17,
    equilibrium and moment), all with the quadrature structure planned on ``layout`` (a frozen
    discretisation: finite differences through it are derivatives of one smooth function).

    ``edges (K, 2n)`` absolute x; ``theta (K,)``; ``beta (K, n_beta)`` (coefficients of T in the
    coordinate shifted by ``xc``); ``sq`` the zone rule ``(K, N)``.
    """

    layout: Layout
    profile: Profile
    A: float
    xc: float
    edges: np.ndarray
    theta: np.ndarray
    beta: np.ndarray
    sq: SQuad

    @classmethod
    def build(cls, layout: Layout, profile: Profile, A: float, xc: float, edges: np.ndarray,
              theta: np.ndarray, beta: np.ndarray) -> Batch:
        """The batch with the quadrature planned on ``layout``."""
        edges, theta = np.atleast_2d(edges), np.atleast_1d(np.asarray(theta, float))
        beta = np.asarray(beta, float)
        beta = beta.reshape(edges.shape[0], beta.size // edges.shape[0])
        return cls(layout, profile, A, xc, edges, theta, beta,
                   squad_nodes(squad_plan(layout, profile), profile, edges, xc, theta))

    @property
    def size(self) -> int:
        return self.edges.shape[0]

    # B and its polynomial terms ------------------------------------------------------------
    @cached_property
    def _poly_coeffs(self) -> np.ndarray | None:
        """Per member, coefficients (highest first) of ``Poly``, the polynomial part of ``1/W``
        at infinity; None when it vanishes (e > n)."""
        lay = self.layout
        deg = lay.n - lay.e
        if deg < 0:
            return None
        return np.array([series_coeffs(e, lay.eps, -1.0, deg) for e in self.edges - self.xc])

    def polynomial_terms(self, xh: np.ndarray, H: np.ndarray) -> np.ndarray | float:
        """``pi H Poly(x) + T(x)`` at shifted points ``(K, M)`` (0 when both vanish)."""
        out: np.ndarray | float = 0.0
        if self._poly_coeffs is not None:
            out = np.pi * H * _horner_rows(self._poly_coeffs, xh)
        if self.beta.shape[1]:
            out = out + _horner_rows(self.beta[:, ::-1], xh)
        return out

    def B(self, xh: np.ndarray, H: np.ndarray,
          dH: np.ndarray | Callable[[], np.ndarray] | None = None,
          off_nodes: bool = False) -> np.ndarray:
        """``B(x)`` at shifted points ``(K, M)`` (see :func:`cauchy_sums` for ``dH`` and
        ``off_nodes``)."""
        return cauchy_sums(self.sq, xh, H, dH, off_nodes) + self.polynomial_terms(xh, H)

    # consistency, load, moment -------------------------------------------------------------
    @cached_property
    def _dh_omega(self) -> tuple[np.ndarray, np.ndarray]:
        """``h' Omega`` at the nodes and its absolute value (scales of the sums)."""
        sq = self.sq
        return sq.dh * sq.Omega, np.abs(sq.dh) * sq.absOmega

    @cached_property
    def _node_factors(self) -> tuple[np.ndarray, np.ndarray]:
        """The consistency nodes ``c (K, m)`` (centres of :func:`consistency_zones`, shifted)
        and ``s - c_j`` ``(K, N, m)``."""
        zones = 2 * consistency_zones(self.layout)
        e = self.edges - self.xc
        c = 0.5 * (e[:, zones] + e[:, zones + 1])
        return c, self.sq.s[:, :, None] - c[:, None, :]

    def consistency(self) -> tuple[np.ndarray, np.ndarray]:
        """Consistency residuals ``int_L L_j(s) h'(s) omega(s) ds`` (paper Eq. 12) ``(K, m)`` in
        the Lagrange basis on the centres of :func:`consistency_zones` (a localised basis keeps
        the rows independent when the zones are narrow and far apart), and the absolute sums
        used to scale them."""
        c, D = self._node_factors
        m = D.shape[2]
        L = np.ones(D.shape)
        for j in range(m):
            for i in range(m):
                if i != j:
                    L[:, :, j] *= D[:, :, i] / (c[:, j] - c[:, i])[:, None]
        f, f_abs = self._dh_omega
        return (f[:, None, :] @ L)[:, 0, :], (f_abs[:, None, :] @ np.abs(L))[:, 0, :]

    def load(self) -> np.ndarray:
        """Total load ``(K,)``: ``P = (1/A) int_L prod_j (s - c_j) h' omega ds`` for e >= n (the
        monic degree-(e-n) polynomial; equal to ``mu_{e-n}/A`` once consistency holds) or
        ``-beta_{n-e-1}/A`` for e < n."""
        lay = self.layout
        if lay.e < lay.n:
            return -self.beta[:, lay.n - lay.e - 1] / self.A
        poly = np.prod(self._node_factors[1], axis=2)
        return np.sum(poly * self._dh_omega[0], axis=1) / self.A

    def moments(self, jmax: int) -> np.ndarray:
        """``mu_j = sum s^j h' Omega`` ``(K, jmax + 1)`` (shifted coordinate)."""
        return np.einsum("kn,knj->kj", self._dh_omega[0],
                         self.sq.s[:, :, None] ** np.arange(jmax + 1))

    def w1(self) -> np.ndarray:
        """``w1`` of ``W = z^(e-n) (1 + w1/z + ...)``: ``-sum eps_i e_i`` (shifted)."""
        return -(self.edges - self.xc) @ self.layout.eps

    def load_and_moment(self) -> tuple[np.ndarray, np.ndarray]:
        """Total load and moment about x = 0 ``(K,)`` implied by the state (closed forms)."""
        lay, A = self.layout, self.A
        n, e = lay.n, lay.e
        P = self.load()
        if e >= n:
            mu = self.moments(e - n + 1)
            Mc = (mu[:, e - n + 1] + self.w1() * mu[:, e - n]) / A
        else:
            beta = self.beta
            lower = beta[:, n - e - 2] if n - e - 2 >= 0 else 0.0
            mu0 = self.moments(0)[:, 0] if e == n - 1 else 0.0
            Mc = -(lower + self.w1() * beta[:, n - e - 1] - mu0) / A
        return P, Mc + self.xc * P

    # gap integrals -------------------------------------------------------------------------
    @cached_property
    def edge_pieces(self) -> list[Piece]:
        """Profile piece on the zone side of each edge (of the planning layout; its
        continuation is used near the edge)."""
        el = self.layout.edges.tolist()
        if self.profile.global_piece is not None:
            return [self.profile.global_piece] * len(el)
        width = self.layout.edge_widths()
        # never past the zone's middle: a zone narrower than the probe step, pinned at a corner,
        # took the piece beyond the corner (g off by the step of h0 there, 0.0585 accepted)
        probes = np.array([x + (1.0 if i % 2 == 0 else -1.0)
                           * min(1e-9 * max(self.profile.scale, abs(x), 1e-300), 0.5 * w)
                           for i, (x, w) in enumerate(zip(el, width.tolist(), strict=True))])
        ks = self.profile.piece_index(probes).tolist()
        return [self.profile.pieces[max(k, 0)] for k in ks]

    @cached_property
    def _edge_clearances(self) -> np.ndarray:
        """Distance from each edge to the nearest other edge or kink or corner of the profile
        ``(K, 2n)`` (edges are sorted; floored at 1e-300; a mark the edge sits on is not one):
        g' varies on that scale next to the edge (a parabolic corner's kink 2e-4 inside the
        zone, its edge's gap integrals sized on the 0.95 to the next edge: gap(x) 1e-3 A P off
        a distance 1 away, audit seed 6)."""
        d = np.maximum(np.diff(self.edges, axis=1), 1e-300)
        pad = np.full((self.size, 1), np.inf)
        out = np.minimum(np.concatenate([pad, d], 1), np.concatenate([d, pad], 1))
        marks = np.array([*self.profile.kinks, *self.profile.corners], float)
        if marks.size:
            dm = np.abs(self.edges[:, :, None] - marks[None, None, :])
            out = np.minimum(out, np.min(np.where(dm > 0, dm, np.inf), axis=2))
        return out

    def gap_plan(self, idx: Sequence[int], x_to: Sequence[float],
                 subtract_reach: float = math.inf) -> GapPlan:
        """The structure of the integrals from edges ``idx`` to ``x_to``, sized on member 0; each
        target lies in the gap (or the outer region) on the outer side of its edge.  The edge
        piece's slope is subtracted in B (sum ``int g'``) up to the first graded boundary at
        least ``subtract_reach`` widths of the edge's zone away, not beyond (sum ``int w'``)."""
        eps = self.layout.eps.tolist()
        el = self.edges[0].tolist()
        clearance = self._edge_clearances[0].tolist()
        pieces = self.edge_pieces
        structure = []
        for i, xt in zip(idx, x_to, strict=True):
            x0 = el[i]
            pc = pieces[i]
            reach = pc.reach[1] if i % 2 == 1 else pc.reach[0]
            dist = abs(xt - x0)
            length = min(dist, 0.5 * abs(reach - x0))
            n_first = n_graded = 0
            if length > 0:
                c = clearance[i]
                first = min(length, max(c, 1e-300))
                n_first = nodes_for(first, c)
                lo = first
                while lo < length * (1 - 1e-14):
                    lo, n_graded = min(length, lo * GRADING), n_graded + 1
            structure.append((int(i), 1.0 if xt >= x0 else -1.0, eps[i], pc, n_first, n_graded,
                              dist > length * (1 + 1e-14),
                              _switch(first if length > 0 else 0.0, n_graded,
                                      subtract_reach * (el[i | 1] - el[i & ~1]))))
        return _gap_plan(tuple(structure), tuple(self.layout.pinned.tolist()))

    def gap_sums(self, plan: GapPlan, x_to: np.ndarray) -> np.ndarray:
        """``int g'`` ``(K, parts)`` from each planned edge to ``x_to (K, parts)`` (the graded
        parts as ``S - [h]``, see :class:`GapPlan` and :meth:`graded_ends`).  All points share
        one evaluation of B."""
        if plan.part.size == 0:
            return np.zeros(x_to.shape)
        _, D, L = self._graded_lengths(plan, x_to)
        f = self._first_lengths(plan, L)
        x, w = plan.nodes(self.edges, np.concatenate([f, L, D], axis=1))
        H = np.zeros(x.shape)
        for pc, nodes in plan.groups:
            H[:, nodes] = pc.dh(x[:, nodes]) - self.theta[:, None]
        with np.errstate(divide="ignore"):  # a target within an ulp of its edge: x == edge
            logs = np.log(np.abs(x[:, :, None] - self.edges[:, None, :]))
        logs[(slice(None), *plan.graded)] = 0.0  # the edge's own factor is in the graded weight
        vals = w * np.exp(logs @ self.layout.eps) * self.B(x - self.xc, H, off_nodes=True)
        return (vals @ plan.sums) / np.pi

    def graded_ends(self, plan: GapPlan, x_to: np.ndarray) -> np.ndarray:
        """The end of the subtraction in each part of :meth:`gap_sums` ``(K, parts)``: its
        switch (see :meth:`gap_plan`), else the end of the graded part: the target, or the
        limit half-way to the end of the edge piece's continuation."""
        x0, D, L = self._graded_lengths(plan, x_to)
        switched = x0 + plan.direction * self._first_lengths(plan, L) \
            * GRADING ** np.maximum(plan.switch, 0)
        return np.where(plan.switch >= 0, switched,
                        np.where(L == D, x_to, x0 + plan.direction * L))

    def _first_lengths(self, plan: GapPlan, L: np.ndarray) -> np.ndarray:
        """Length ``f`` of the first (Gauss-Jacobi) sub-interval of each graded part."""
        return np.minimum(L, self._edge_clearances[:, plan.edge])

    def _graded_lengths(self, plan: GapPlan, x_to: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per integral ``(K, parts)``: its edge ``x0``, ``D = |x_to - x0|`` and the graded
        length ``L = min(D, half-way to the end of the edge piece's continuation)``."""
        x0 = self.edges[:, plan.edge]
        D = np.abs(x_to - x0)
        return x0, D, np.minimum(D, 0.5 * np.abs(plan.reach - x0))

    def h_at(self, ends: np.ndarray, pieces: Sequence[Piece]) -> np.ndarray:
        """``h = h0 - theta x`` at the ends ``(K, q)`` of graded parts, from their pieces."""
        out = np.empty(ends.shape)
        for j, pc in enumerate(pieces):
            out[:, j] = pc.h(ends[:, j]) - self.theta * ends[:, j]
        return out

    def interconnections(self) -> np.ndarray:
        """Rigid interconnection residuals ``(K, n - 1)`` between neighbouring zones (paper
        Eq. 17), all gaps: ``h(a) - h(b) + int_b^mid w' - int_a^mid w' = S_b - S_a + [h]`` where
        ``[h]`` is the jump of h between the ends of the two subtractions (it vanishes when both
        reach the midpoint on the same piece).  The subtraction stops SUBTRACT_REACH zone widths
        from the edge: beyond, the sums are ``int w'`` (scale A P) and not ``int g'`` (scale
        ``|h'|`` times the gap), which rounded at ``eps |h'| span`` (5e-8 A P for two cylinders 4
        apart at P = 1e-8: the self-check refused the load split)."""
        n = self.layout.n
        if n < 2:
            return np.zeros((self.size, 0))
        e = self.edges
        mid = 0.5 * (e[:, 1:-1:2] + e[:, 2:-1:2])
        x_to = np.concatenate([mid, mid], axis=1)
        plan = self.gap_plan([*range(1, 2 * n - 2, 2), *range(2, 2 * n - 1, 2)], x_to[0].tolist(),
                             SUBTRACT_REACH)
        S = self.gap_sums(plan, x_to)
        out = S[:, : n - 1] - S[:, n - 1:]
        pcs, ends = plan.pieces, None
        for m in range(n - 1):
            pb, pa = pcs[m], pcs[m + n - 1]
            if not (pb is pa and not plan.far[m] and not plan.far[m + n - 1]
                    and plan.switch[m] < 0 and plan.switch[m + n - 1] < 0):
                ends = self.graded_ends(plan, x_to) if ends is None else ends
                h = self.h_at(ends[:, [m + n - 1, m]], [pa, pb])
                out[:, m] += h[:, 0] - h[:, 1]
        return out


def consistency_zones(layout: Layout) -> np.ndarray:
    """The ``e - n`` zones whose centres carry the Lagrange basis of the consistency conditions:
    those with the most nonsingular edges (ties: leftmost), in order of x (read-only)."""
    return _consistency_zones(tuple(layout.pinned.tolist()))


@lru_cache(maxsize=256)
def _consistency_zones(pinned: tuple[bool, ...]) -> np.ndarray:
    n = len(pinned) // 2
    free = [2 - pinned[2 * z] - pinned[2 * z + 1] for z in range(n)]
    order = sorted(range(n), key=lambda z: -free[z])[:max(sum(free) - n, 0)]
    out = np.array(sorted(order), int)
    out.flags.writeable = False
    return out


def _horner_rows(coeffs: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Row k of ``coeffs (K, d+1)`` (highest power first) evaluated at row k of ``x (K, M)``."""
    out = np.zeros(x.shape)
    for c in coeffs.T:
        out *= x
        out += c[:, None]
    return out


@dataclass
class System:
    """One layout's state (shifted coordinates): its zone rule ``sq`` (1-D) and the one-member
    :class:`Batch` that evaluates its equations and gap integrals; B, p and g' at any points."""

    layout: Layout
    profile: Profile
    A: float
    theta: float
    xc: float
    beta: np.ndarray
    sq: SQuad
    batch: Batch = field(repr=False)

    @classmethod
    def build(cls, layout, profile, A, theta, xc, beta) -> System:
        beta = np.asarray(beta, float)
        batch = Batch.build(layout, profile, A, xc, layout.edges[None, :],
                            np.array([float(theta)]), beta[None, :])
        sq = batch.sq
        return cls(layout, profile, A, float(theta), xc, beta,
                   SQuad(sq.s[0], sq.Omega[0], sq.absOmega[0], sq.dh[0]), batch)

    def _polynomial_terms(self, xh: np.ndarray, H: np.ndarray) -> np.ndarray | float:
        """``pi H Poly(x) + T(x)`` at shifted points (0 when both vanish)."""
        xh, H = np.asarray(xh, float), np.asarray(H, float)
        out = self.batch.polynomial_terms(xh.reshape(1, -1), H.reshape(1, -1))
        return np.reshape(out, xh.shape) if isinstance(out, np.ndarray) else out

    def B(self, xh: np.ndarray, H: np.ndarray,
          dH: np.ndarray | Callable[[], np.ndarray] | None = None) -> np.ndarray:
        """``B(x)`` at shifted points ``xh`` with subtraction values ``H`` (same shape); see
        :func:`cauchy_sums` for ``dH``."""
        xh = np.asarray(xh, float)
        val = self.batch.B(xh.reshape(1, -1), np.asarray(H, float).reshape(1, -1), dH)
        return val.reshape(xh.shape)

    def W_real(self, x: np.ndarray) -> np.ndarray:
        """Signed real W (outside L) or W_s (inside L) at absolute x."""
        lay = self.layout
        d = sign_exponent(np.atleast_1d(x), lay.edges, lay.pinned)
        return sign_from_d(d) * w_abs(np.atleast_1d(x), lay.edges, lay.eps)

    def gap_slope(self, x: np.ndarray) -> np.ndarray:
        """Deformed-gap slope ``g'(x) = W(x) B(x)/pi`` at absolute x outside the zones."""
        return self.pressure_and_slope(np.zeros(0), x)[1]

    def pressure_inside(self, x: np.ndarray) -> np.ndarray:
        """p at absolute x known to lie inside the zones (see :meth:`pressure_and_slope`)."""
        return self.pressure_and_slope(x, np.zeros(0))[0]

    def pressure_and_slope(self, x_in: np.ndarray, x_out: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
        """p at absolute ``x_in`` inside the zones and ``g' = W B/pi`` at ``x_out`` outside them,
        from one evaluation of B (``p = W_s B/(pi A)``).

        Near an interior kink of h0 (wedge apex, end of a flat face) the divided difference
        ``(h'(s) - h'(x))/(s - x)`` jumps across the kink; those points get a quadrature graded
        towards the kink at their own distance from it (p is log-singular at an apex).
        """
        x_in = np.atleast_1d(np.asarray(x_in, float))
        x = np.concatenate([x_in, np.atleast_1d(np.asarray(x_out, float))])
        H = self.profile.dh0(x) - self.theta
        Bv = self.B(x - self.xc, H, lambda: self.profile.d2h0(x))
        for j, kink, cuts, beyond in self._near_kinks(x_in):
            Bv[j] = self._B_graded(x[j], H[j], kink, cuts, beyond)
        for j, end, cut in self._near_vertical_ends(x_in):
            Bv[j] = self._B_vertical(x[j], H[j], end, cut)
        WB = self.W_real(x) * Bv / np.pi
        return WB[:x_in.size] / self.A, WB[x_in.size:]

    def _near_kinks(self, x: np.ndarray):
        """(indices, kink, zone cuts, clearances beyond them) per interior kink: the points
        closer to it than KINK_ZONE of its shorter piece."""
        out = []
        for a, b in self.layout.edges.reshape(-1, 2):
            kinks = [q for q in self.profile.kinks if a < q < b]
            if not kinks:
                continue
            cuts = [a, *kinks, b]
            for m, q in enumerate(kinks, start=1):
                reach = KINK_ZONE * min(q - cuts[m - 1], cuts[m + 1] - q)
                beyond = (cuts[m - 1] - cuts[m - 2] if m >= 2 else 0.0,
                          cuts[m + 2] - cuts[m + 1] if m + 2 < len(cuts) else 0.0)
                # at the kink itself (p log-singular at an apex) the plain rule's value stays
                near = np.abs(x - q)
                j = np.flatnonzero((near < reach) & (near > 0.0))
                if j.size:
                    out.append((j, q, (cuts[m - 1], q, cuts[m + 1]), beyond))
        return out

    def _near_vertical_ends(self, x: np.ndarray):
        """(indices, end, cut) per pinned vertical end: the points inside its zone closer to it
        than KINK_ZONE of its segment (``cut`` the nearest kink or edge inside the zone)."""
        lay = self.layout
        out = []
        for i in np.flatnonzero(vertical_edges(lay, self.profile)).tolist():
            a, b = lay.edges[2 * (i // 2)], lay.edges[2 * (i // 2) + 1]
            end = float(lay.edges[i])
            inner = [q for q in self.profile.kinks if a < q < b] + [b if end == a else a]
            cut = min(inner, key=lambda q: abs(q - end))
            d = np.abs(x - end)
            j = np.flatnonzero((d < KINK_ZONE * abs(end - cut)) & (d > 0)
                               & (np.sign(x - end) == np.sign(cut - end)))
            if j.size:
                out.append((j, end, cut))
        return out

    def _B_vertical(self, x: np.ndarray, H: np.ndarray, end: float, cut: float) -> np.ndarray:
        """B at points x near a pinned vertical end: on the segment's half at the end
        ``s = end - L u^2`` (the slope's ``d^(-1/2)`` and the edge factor smooth in u) with
        u-panels graded towards the end down to the nearest point's distance; its other half by
        the edge's Jacobi rule (``cut`` an edge) or Gauss-Legendre (a kink)."""
        lay = self.layout
        edges, eps = lay.edges, lay.eps
        side = math.copysign(1.0, cut - end)
        L = 0.5 * abs(cut - end)
        s_abs = self.sq.s + self.xc
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
            a_cut = -eps[i_cut[0]]
            s_far, w_far = mapped_rule(lo_, hi_, *((a_cut, 0.0) if side > 0 else (0.0, a_cut)),
                                       BASE_NODES)
            skip[i_cut[0]] = True
        else:
            s_far, w_far = mapped_rule(lo_, hi_, 0.0, 0.0, BASE_NODES)
        O = [w_near * sign_from_d(sign_exponent(s_near, edges, lay.pinned))
             * w_abs(s_near, edges, -eps),
             w_far * sign_from_d(sign_exponent(s_far, edges, lay.pinned))
             * w_abs(s_far, edges, -eps, skip)]
        s_all = np.concatenate([s_abs[keep], s_near, s_far])
        O_all = np.concatenate([self.sq.Omega[keep], *O])
        return self._divided_sums(x, H, s_all, O_all)

    def _divided_sums(self, x: np.ndarray, H: np.ndarray, s_all: np.ndarray,
                      O_all: np.ndarray) -> np.ndarray:
        """``sum (h'(s) - H)/(s - x) O + pi H Poly + T`` at absolute x and nodes ``s_all``."""
        dh = self.profile.dh0(s_all) - self.theta
        xh, sh = x - self.xc, s_all - self.xc
        diff = sh[None, :] - xh[:, None]
        # a graded node can round onto x within ulps: its weight is negligible
        q_ = np.where(diff != 0.0, (dh[None, :] - H[:, None]) / np.where(diff != 0.0, diff, 1.0),
                      0.0)
        return q_ @ O_all + self._polynomial_terms(xh, H)

    def _B_graded(self, x: np.ndarray, H: np.ndarray, kink: float, cuts: tuple,
                  beyond: tuple) -> np.ndarray:
        """B at points x near ``kink`` with one rule on its two pieces graded towards it down to
        the nearest point's distance (a panel at distance d from the kink is ~d long, so every
        farther point is resolved too)."""
        lo, q, hi = cuts
        sq = self.sq
        s_abs = sq.s + self.xc
        keep = (s_abs <= lo) | (s_abs >= hi)
        s_new, O_new = [sq.s[keep]], [sq.Omega[keep]]
        d = float(np.min(np.abs(x - q)))
        tau = KINK_ULPS * float(np.spacing(abs(q)))
        for end, side, far in ((lo, -1.0, beyond[0]), (hi, 1.0, beyond[1])):
            s_piece, O_piece = self._graded_piece(q, end, side, d, far, tau)
            s_new.append(s_piece - self.xc)
            O_new.append(O_piece)
        return (self._divided_sums(x, H, np.concatenate(s_new) + self.xc, np.concatenate(O_new))
                + self._kink_core(x, H, q, tau))

    def _kink_core(self, x: np.ndarray, H: np.ndarray, q: float, tau: float) -> np.ndarray:
        """The part of B from ``|s - q| < tau`` (left out of the graded rules: nodes there
        round onto the kink), to first order in tau: on x's side ``omega h'' tau``, on the other
        side sigma ``omega (h'_sigma(q) - H) ln(1 + tau / d)`` (the apex's log term for x a
        distance d < tau from it; 1e-12 from a wedge's apex p was 0.35 mu p short)."""
        lay = self.layout
        qa = np.array([q])
        omega = float(sign_from_d(sign_exponent(qa, lay.edges, lay.pinned))[0]
                      * w_abs(qa, lay.edges, -lay.eps)[0])
        d = np.abs(x - q)
        out = np.zeros(x.shape)
        for side in (-1.0, 1.0):
            slope = float(self.profile.dh0(np.array([q + 0.5 * side * tau]))[0]) - self.theta
            same = (x - q) * side > 0
            with np.errstate(divide="ignore"):
                other = side * (slope - H) * np.log1p(tau / d)
            out += np.where(same, self.profile.d2h0(x) * tau, other)
        return omega * out

    def _graded_piece(self, q: float, end: float, side: float, d: float, far: float,
                      tau: float = 0.0):
        """Nodes/weights (times omega) on the piece between kink q and ``end``: graded towards q
        on its inner half; on the outer half Gauss-Jacobi (edge weight) if ``end`` is an edge,
        else graded towards ``end`` from ``far``, the distance to the next cut beyond it (a
        rounded corner's edge close beyond its kink: 32 plain nodes left 8e-7 of the peak)."""
        lay = self.layout
        edges, eps = lay.edges, lay.eps
        L = abs(end - q)
        t, w = graded_rule(0.5 * L - tau, d + tau, 0.0)
        s_in = q + side * (tau + t)
        i_end = np.flatnonzero(edges == end)
        skip = np.zeros(edges.size, bool)
        if i_end.size and vertical_edges(lay, self.profile)[i_end[0]]:
            t_out, w_out = sine_rule(BASE_NODES)
            s_out = q + side * 0.75 * L + side * 0.25 * L * t_out
            w_out = w_out * 0.25 * L
        elif i_end.size and int(i_end[0]) in (anchors := _vertical_anchors(lay, self.profile)):
            # a vertical end just beyond the edge: graded towards the edge from its distance
            t_out, w_out = graded_rule(0.5 * L, min(abs(anchors[int(i_end[0])] - end), 0.5 * L),
                                       float(-eps[i_end[0]]))
            s_out = end - side * t_out
            skip[i_end[0]] = True
        elif i_end.size:
            mid = q + side * 0.5 * L
            lo_, hi_ = (mid, end) if side > 0 else (end, mid)
            a_end = -eps[i_end[0]]
            al, ah = (0.0, a_end) if side > 0 else (a_end, 0.0)
            s_out, w_out = mapped_rule(lo_, hi_, al, ah, BASE_NODES)
            skip[i_end[0]] = True
        else:
            t_out, w_out = graded_rule(0.5 * L, min(far, 0.5 * L), 0.0)
            s_out = end - side * t_out
        d_in = sign_exponent(s_in, edges, lay.pinned)
        O_in = w * sign_from_d(d_in) * w_abs(s_in, edges, -eps)
        d_out = sign_exponent(s_out, edges, lay.pinned)
        O_out = w_out * sign_from_d(d_out) * w_abs(s_out, edges, -eps, skip)
        return np.concatenate([s_in, s_out]), np.concatenate([O_in, O_out])

    # equations and gap integrals (the one-member batch) -------------------------------------
    def moments(self, jmax: int) -> np.ndarray:
        """``mu_j = sum s^j h' Omega`` for ``j <= jmax`` (shifted coordinate)."""
        return self.batch.moments(jmax)[0]

    def consistency(self) -> tuple[np.ndarray, np.ndarray]:
        """Consistency residuals and their scales (see :meth:`Batch.consistency`)."""
        mu, norm = self.batch.consistency()
        return mu[0], norm[0]

    def load(self) -> float:
        return float(self.batch.load()[0])

    def load_and_moment(self) -> tuple[float, float]:
        """Total load and moment about x = 0 implied by the current state (closed forms)."""
        P, M = self.batch.load_and_moment()
        return float(P[0]), float(M[0])

    def interconnections(self) -> np.ndarray:
        """Rigid interconnection residuals (paper Eq. 17, see :meth:`Batch.interconnections`)."""
        return self.batch.interconnections()[0]

    def gaps_from_edges(self, idx: np.ndarray, x_to: np.ndarray, h_to: np.ndarray) -> np.ndarray:
        """Deformed gap at ``x_to[j]`` (where ``h = h_to[j]``), integrated from edge ``idx[j]``
        (``g = 0`` there) on the outer side: ``g = h(x) - h(x0) + int_{x0}^{x} w'`` with
        ``int w' = S - (h(x_e) - h(x0))`` (see :meth:`Batch.gap_sums`), so
        ``g = h(x) - h(x_e) + S``.  One evaluation of B per GAP_CHUNK points (memory and time
        stay linear in the number of points)."""
        x_to, idx, h_to = (np.asarray(v) for v in (x_to, idx, h_to))
        if x_to.size > GAP_CHUNK:
            return np.concatenate([self.gaps_from_edges(idx[k:k + GAP_CHUNK],
                                                        x_to[k:k + GAP_CHUNK],
                                                        h_to[k:k + GAP_CHUNK])
                                   for k in range(0, x_to.size, GAP_CHUNK)])
        x_to = x_to.astype(float)
        plan = self.batch.gap_plan(idx.tolist(), x_to.tolist())
        S = self.batch.gap_sums(plan, x_to[None, :])
        ends = self.batch.graded_ends(plan, x_to[None, :])
        return h_to - self.batch.h_at(ends, plan.pieces)[0] + S[0]
