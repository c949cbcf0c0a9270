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

import math
from collections.abc import Callable
from dataclasses import dataclass
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
        return int(np.count_nonzero(~self.pinned))

    @property
    def eps(self) -> np.ndarray:
        return np.where(self.pinned, -0.5, 0.5)

    def zones(self) -> list[tuple[float, float]]:
        return [(float(a), float(b)) for a, b in self.edges.reshape(-1, 2)]

    def with_edges(self, edges: np.ndarray) -> Layout:
        return Layout(np.asarray(edges, float), self.pinned)


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
    """Quadrature over L for ``int_L f(s) omega(s) ds ~ sum f(s_q) Omega_q``."""

    s: np.ndarray
    Omega: np.ndarray
    absOmega: np.ndarray
    dh: np.ndarray


def build_squad(layout: Layout, profile: Profile, xc: float, theta: float) -> SQuad:
    """Gauss-Jacobi rules on every zone, split at the profile's kinks (edge weights at the ends);
    ``Omega`` is the weight times the rest of ``omega = 1/W_s`` (one log-sum for all nodes)."""
    el = layout.edges.tolist()
    eps = layout.eps
    clearance = zone_clearances(el)
    signs = zone_signs(layout)
    s_parts, w_parts, counts, expo = [], [], [], []
    for k in range(len(el) // 2):
        a, b = el[2 * k], el[2 * k + 1]
        cuts = [a, *[q for q in profile.kinks if a < q < b], b]
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            row = -eps.copy()  # exponents of |s - e_i| left outside the Jacobi weight
            al, ah = (row[2 * k] if lo == a else 0.0), (row[2 * k + 1] if hi == b else 0.0)
            row[2 * k] = 0.0 if lo == a else row[2 * k]
            row[2 * k + 1] = 0.0 if hi == b else row[2 * k + 1]
            n = nodes_for(hi - lo, min(clearance[k], _kink_clearance(lo, hi, a, b)))
            s, w = mapped_rule(lo, hi, al, ah, n)
            s_parts.append(s)
            w_parts.append(w * signs[k])
            counts.append(n)
            expo.append(row)
    s = np.concatenate(s_parts)
    logs = np.log(np.abs(s[:, None] - layout.edges[None, :]))
    rest = np.exp(np.einsum("ij,ij->i", logs, np.repeat(np.array(expo), counts, axis=0)))
    Om = np.concatenate(w_parts) * rest
    dh = _segment_slopes(profile, s_parts) - theta
    return SQuad(s - xc, Om, np.abs(Om), dh)


def _segment_slopes(profile: Profile, s_parts: list[np.ndarray]) -> np.ndarray:
    """``h0'`` at the nodes of every segment.  Segments end at zone edges and kinks, and every
    piece boundary inside the support is a kink or a corner, so each segment lies in one piece
    (found from its middle node)."""
    if profile.global_piece is not None or len(s_parts) == 1:
        return profile.dh0(np.concatenate(s_parts))
    mids = np.array([seg[seg.size // 2] for seg in s_parts])
    pieces = profile.piece_index(mids).tolist()
    return np.concatenate([profile.pieces[k].dh(seg) if k >= 0 else np.full(seg.size, np.nan)
                           for k, seg in zip(pieces, s_parts, strict=True)])


def zone_signs(layout: Layout) -> list[float]:
    """``s_k``: the sign of ``W_s`` on each zone (from d, the edges to the right of its middle)."""
    d, out = 0, []
    for i, pin in reversed(list(enumerate(layout.pinned.tolist()))):
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


@dataclass
class System:
    """Everything needed to evaluate B, p, g' for one layout (shifted coordinates)."""

    layout: Layout
    profile: Profile
    A: float
    theta: float
    xc: float
    beta: np.ndarray
    sq: SQuad

    @classmethod
    def build(cls, layout, profile, A, theta, xc, beta) -> System:
        return cls(layout, profile, A, theta, xc, np.asarray(beta, float),
                   build_squad(layout, profile, xc, theta))

    # shifted edges and polynomial helpers
    @property
    def e_hat(self) -> np.ndarray:
        return self.layout.edges - self.xc

    @cached_property
    def _poly_coeffs(self) -> np.ndarray | None:
        """Coefficients (highest first) of ``Poly``, the polynomial part of ``1/W`` at infinity;
        None when it vanishes (e > n)."""
        lay = self.layout
        deg = lay.n - lay.e
        return series_coeffs(self.e_hat, lay.eps, -1.0, deg) if deg >= 0 else None

    def _polynomial_terms(self, xh: np.ndarray, H: np.ndarray) -> np.ndarray | float:
        """``pi H Poly(x) + T(x)`` at shifted points (0 when both vanish)."""
        out: np.ndarray | float = 0.0
        if self._poly_coeffs is not None:
            out = np.pi * H * np.polyval(self._poly_coeffs, xh)
        if self.beta.size:
            out = out + np.polyval(self.beta[::-1], xh)
        return out

    def B(self, xh: np.ndarray, H: np.ndarray,
          dH: np.ndarray | Callable[[], np.ndarray] | None = None) -> np.ndarray:
        """``B(x)`` at shifted points ``xh`` with subtraction values ``H`` (same shape).

        Where a point coincides with a node (closer than 1e-13 relative) the divided difference
        is replaced by its limit ``dH`` (an array, a callable giving it, or None for 0)."""
        sq = self.sq
        xh = np.asarray(xh, float)
        x, Hr = xh.ravel(), np.asarray(H, float).ravel()
        diff = sq.s[None, :] - x[:, None]
        q = sq.dh[None, :] - Hr[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            q /= diff
        np.abs(diff, out=diff)
        if x.size and diff.min() < 1e-13 * (1.0 + np.abs(x).max()):
            small = diff < 1e-13 * (1.0 + np.abs(x[:, None]))
            fill = np.zeros_like(x) if dH is None else np.asarray(
                dH() if callable(dH) else dH, float).ravel()
            q = np.where(small, np.broadcast_to(fill[:, None], q.shape), q)
        val = q @ sq.Omega + self._polynomial_terms(x, Hr)
        return val.reshape(xh.shape)

    def W_real(self, x: np.ndarray) -> np.ndarray:
        """Signed real W (outside L) or W_s (inside L) at absolute x."""
        lay = self.layout
        d = sign_exponent(np.atleast_1d(x), lay.edges, lay.pinned)
        return sign_from_d(d) * w_abs(np.atleast_1d(x), lay.edges, lay.eps)

    def gap_slope(self, x: np.ndarray) -> np.ndarray:
        """Deformed-gap slope ``g'(x) = W(x) B(x)/pi`` at absolute x outside the zones."""
        x = np.atleast_1d(np.asarray(x, float))
        H = self.profile.dh0(x) - self.theta
        return self.W_real(x) * self.B(x - self.xc, H, lambda: self.profile.d2h0(x)) / np.pi

    def pressure_inside(self, x: np.ndarray) -> np.ndarray:
        """p at absolute x known to lie inside the zones.

        Near an interior kink of h0 (wedge apex, end of a flat face) the divided difference
        ``(h'(s) - h'(x))/(s - x)`` jumps across the kink; those points get a quadrature graded
        towards the kink at their own distance from it (p is log-singular at an apex).
        """
        x = np.atleast_1d(np.asarray(x, float))
        H = self.profile.dh0(x) - self.theta
        dH = self.profile.d2h0(x)
        Bv = self.B(x - self.xc, H, dH)
        for j, kink, cuts in self._near_kinks(x):
            Bv[j] = self._B_graded(x[j], H[j], kink, cuts)
        return self.W_real(x) * Bv / (np.pi * self.A)

    def _near_kinks(self, x: np.ndarray):
        """(index, kink, zone cuts) for points closer to an interior kink than KINK_ZONE."""
        out = []
        for a, b in self.layout.edges.reshape(-1, 2):
            kinks = [q for q in self.profile.kinks if a < q < b]
            if not kinks:
                continue
            cuts = [a, *kinks, b]
            for m, q in enumerate(kinks, start=1):
                reach = KINK_ZONE * min(q - cuts[m - 1], cuts[m + 1] - q)
                for j in np.flatnonzero((np.abs(x - q) < reach) & (x != q)):
                    out.append((int(j), q, (cuts[m - 1], q, cuts[m + 1])))
        return out

    def _B_graded(self, x: float, H: float, kink: float, cuts: tuple) -> float:
        lo, q, hi = cuts
        sq = self.sq
        s_abs = sq.s + self.xc
        keep = (s_abs <= lo) | (s_abs >= hi)
        s_new, O_new = [sq.s[keep]], [sq.Omega[keep]]
        d = abs(x - q)
        for end, side in ((lo, -1.0), (hi, 1.0)):
            s_piece, O_piece = self._graded_piece(q, end, side, d)
            s_new.append(s_piece - self.xc)
            O_new.append(O_piece)
        s_all, O_all = np.concatenate(s_new), np.concatenate(O_new)
        dh = self.profile.dh0(s_all + self.xc) - self.theta
        xh = x - self.xc
        val = np.sum((dh - H) / (s_all - xh) * O_all)
        return float(val + self._polynomial_terms(xh, H))

    def _graded_piece(self, q: float, end: float, side: float, d: float):
        """Nodes/weights (times omega) on the piece between kink q and ``end``: graded towards q
        on its inner half, Gauss-Jacobi (edge weight if ``end`` is an edge) on the outer half."""
        lay = self.layout
        edges, eps = lay.edges, lay.eps
        L = abs(end - q)
        t, w = graded_rule(0.5 * L, d, 0.0)
        s_in = q + side * t
        i_end = np.flatnonzero(edges == end)
        a_end = -eps[i_end[0]] if i_end.size else 0.0
        mid = q + side * 0.5 * L
        lo_, hi_ = (mid, end) if side > 0 else (end, mid)
        al, ah = (0.0, a_end) if side > 0 else (a_end, 0.0)
        s_out, w_out = mapped_rule(lo_, hi_, al, ah, BASE_NODES)
        skip = np.zeros(edges.size, bool)
        if i_end.size:
            skip[i_end[0]] = True
        d_in = sign_exponent(s_in, edges, lay.pinned)
        O_in = w * sign_from_d(d_in) * w_abs(s_in, edges, -eps)
        d_out = sign_exponent(s_out, edges, lay.pinned)
        O_out = w_out * sign_from_d(d_out) * w_abs(s_out, edges, -eps, skip)
        return np.concatenate([s_in, s_out]), np.concatenate([O_in, O_out])

    # moments --------------------------------------------------------------------------------
    def moments(self, jmax: int) -> np.ndarray:
        """``mu_j = sum s^j h' Omega`` for ``j <= jmax`` (shifted coordinate)."""
        sq = self.sq
        return (sq.s[None, :] ** np.arange(jmax + 1)[:, None]) @ self._dh_omega[0]

    @cached_property
    def _dh_omega(self) -> tuple[np.ndarray, np.ndarray]:
        """``h' Omega`` at the nodes and its absolute value (scales of the sums)."""
        sq = self.sq
        return sq.dh * sq.Omega, np.abs(sq.dh) * sq.absOmega

    def consistency_nodes(self) -> np.ndarray:
        """Centres (shifted) of the ``e - n`` zones whose Lagrange polynomials span the
        consistency conditions: a localised basis keeps the rows independent when the zones are
        narrow and far apart (monomials ``s^j`` are then nearly dependent)."""
        lay = self.layout
        e, pinned = lay.edges.tolist(), lay.pinned.tolist()
        free = [2 - pinned[2 * z] - pinned[2 * z + 1] for z in range(lay.n)]
        order = sorted(range(lay.n), key=lambda z: -free[z])[:max(lay.e - lay.n, 0)]
        return np.array(sorted(0.5 * (e[2 * z] + e[2 * z + 1]) - self.xc for z in order))

    @cached_property
    def _node_factors(self) -> tuple[np.ndarray, np.ndarray]:
        """``s - c_j`` at the quadrature nodes for the consistency nodes ``c`` (columns)."""
        c = self.consistency_nodes()
        return c, self.sq.s[:, None] - c[None, :]

    def consistency(self) -> tuple[np.ndarray, np.ndarray]:
        """Consistency residuals ``int_L L_k(s) h'(s) omega(s) ds`` (paper Eq. 12) in the Lagrange
        basis on :meth:`consistency_nodes`, and the absolute sums used to scale them."""
        c, D = self._node_factors
        cl = c.tolist()
        L = np.ones(D.shape)
        for j in range(len(cl)):
            for m in range(len(cl)):
                if m != j:
                    L[:, j] *= D[:, m] * (1.0 / (cl[j] - cl[m]))
        f, f_abs = self._dh_omega
        return f @ L, f_abs @ np.abs(L)

    def load(self) -> float:
        """Total load: ``P = (1/A) int_L prod_k (s - c_k) h' omega ds`` for e >= n (the monic
        degree-(e-n) polynomial; equal to ``mu_{e-n}/A`` once consistency holds) or
        ``-beta_{n-e-1}/A`` for e < n."""
        lay = self.layout
        if lay.e < lay.n:
            return float(-self.beta[lay.n - lay.e - 1] / self.A)
        _, D = self._node_factors
        poly = np.prod(D, axis=1) if D.shape[1] else np.ones(D.shape[0])
        return float(poly @ self._dh_omega[0] / self.A)

    def w1(self) -> float:
        lay = self.layout
        return float(series_coeffs(self.e_hat, lay.eps, 1.0, 1)[1])

    def load_and_moment(self) -> tuple[float, float]:
        """Total load and moment about x = 0 implied by the current state (closed forms)."""
        lay, A = self.layout, self.A
        n, e = lay.n, lay.e
        if e >= n:
            mu = self.moments(e - n + 1)
            P = self.load()
            Mc = (mu[e - n + 1] + self.w1() * mu[e - n]) / A
        else:
            beta = self.beta
            P = -beta[n - e - 1] / A
            lower = beta[n - e - 2] if n - e - 2 >= 0 else 0.0
            mu0 = self.moments(0)[0] if e == n - 1 else 0.0
            Mc = -(lower + self.w1() * beta[n - e - 1] - mu0) / A
        return float(P), float(Mc + self.xc * P)

    # gap integrals -----------------------------------------------------------------------------
    @cached_property
    def edge_pieces(self) -> list[Piece]:
        """Profile piece on the zone side of each edge (its continuation is used near the edge)."""
        el = self.layout.edges.tolist()
        if self.profile.global_piece is not None:
            return [self.profile.global_piece] * len(el)
        probes = np.array([x + (1.0 if i % 2 == 0 else -1.0) * 1e-9
                           * max(self.profile.scale, abs(x), 1e-300) for i, x in enumerate(el)])
        ks = self.profile.piece_index(probes).tolist()
        return [self.profile.pieces[max(k, 0)] for k in ks]

    @cached_property
    def _edge_clearances(self) -> list[float]:
        """Distance from each edge to the nearest other edge."""
        el = self.layout.edges.tolist()
        return [min([abs(x - y) for j, y in enumerate(el) if j != i], default=math.inf)
                for i, x in enumerate(el)]

    def gaps_from_edges(self, idx: np.ndarray, x_to: np.ndarray, h_to: np.ndarray) -> np.ndarray:
        """Deformed gap at ``x_to[j]`` (where ``h = h_to[j]``), integrated from edge ``idx[j]``
        (``g = 0`` there) on the outer side: ``g = h(x) - h(x0) + int_{x0}^{x} w'`` with
        ``int w' = S - (h(x_e) - h(x0))`` (see :meth:`_gap_sums`), so ``g = h(x) - h(x_e) + S``.
        One evaluation of B for all points."""
        S, ends = self._gap_sums(idx, x_to)
        return h_to - self._h_at(ends) + S

    def _gap_sums(self, idx: np.ndarray, x_to: np.ndarray) -> tuple[np.ndarray, list]:
        """``int g'`` from edge ``idx[j]`` to ``x_to[j]`` and the (piece, end) of its graded part.

        Near its edge (up to half-way to the end of the edge piece's continuation) an integral
        uses a rule graded towards the edge, with the edge factor of W in the weight and the
        piece's continuation as the subtraction value (so ``int w' = S - [h]`` over that part);
        beyond, plain Gauss-Legendre segments.  All points share one evaluation of B.
        """
        pairs = list(zip(np.asarray(idx).tolist(), np.asarray(x_to, float).tolist(), strict=True))
        near = [self._near_rule(i, xt) for i, xt in pairs]
        parts = [pt[:4] for pt in near] + [self._far_rule(i, xt) for i, xt in pairs]
        ends = [(pt[4], pt[5]) for pt in near]
        counts = [pt[0].size for pt in parts]
        if sum(counts) == 0:
            return np.zeros(len(pairs)), ends
        x, w, H = (np.concatenate([pt[k] for pt in parts]) for k in (0, 1, 2))
        own = np.repeat([pt[3] for pt in parts], counts)
        logs = np.log(np.abs(x[:, None] - self.layout.edges[None, :]))
        rows = np.flatnonzero(own >= 0)
        logs[rows, own[rows]] = 0.0  # the edge's own factor is in the graded rule's weight
        lay = self.layout
        sign = sign_from_d((lay.edges[None, :] > x[:, None]) @ np.where(lay.pinned, -1, 1))

        def curvature() -> np.ndarray:  # only needed where a point meets a node
            return np.concatenate([near[j][4].d2h(pt[0]) if j < len(near) else 0.0 * pt[0]
                                   for j, pt in enumerate(parts)])

        vals = w * sign * np.exp(logs @ lay.eps) * self.B(x - self.xc, H, curvature) / np.pi
        sums = np.bincount(np.repeat(np.arange(len(parts)), counts), vals, len(parts))
        return sums[: len(pairs)] + sums[len(pairs):], ends

    def _h_at(self, ends: list) -> np.ndarray:
        """``h = h0 - theta x`` at the end of each graded part, from that part's piece."""
        return np.array([float(pc.h(np.array([x]))[0]) - self.theta * x for pc, x in ends])

    @cached_property
    def _edge_reach(self) -> list[tuple[float, Piece, float]]:
        """Per edge: position, piece, and how far out its graded part may go (half-way to the
        end of the piece's continuation)."""
        out = []
        for i, (x0, pc) in enumerate(zip(self.layout.edges.tolist(), self.edge_pieces,
                                         strict=True)):
            reach = pc.reach[1] if i % 2 == 1 else pc.reach[0]
            out.append((x0, pc, 0.5 * abs(reach - x0) if math.isfinite(reach) else math.inf))
        return out

    def _near_extent(self, i: int, x_to: float) -> tuple[float, float, Piece]:
        """Length of the graded part towards ``x_to``, its direction, and the edge piece."""
        x0, pc, lim = self._edge_reach[i]
        return min(abs(x_to - x0), lim), (1.0 if x_to >= x0 else -1.0), pc

    def _near_rule(self, i: int, x_to: float):
        """Points, weights (direction included), H and own edge of the graded part of one
        integral, with its piece and end."""
        x0 = float(self.layout.edges[i])
        length, direction, pc = self._near_extent(i, x_to)
        if length <= 0:
            empty = np.zeros(0)
            return empty, empty, empty, i, pc, x0
        t, w = graded_rule(length, self._edge_clearances[i], float(self.layout.eps[i]))
        x = x0 + direction * t
        x_end = x_to if length == abs(x_to - x0) else x0 + direction * length
        return x, direction * w, pc.dh(x) - self.theta, i, pc, x_end

    def _far_rule(self, i: int, x_to: float, n: int = 48):
        """Gauss-Legendre points and weights of the plain part (beyond the graded one), H = 0."""
        x0 = float(self.layout.edges[i])
        length, direction, _ = self._near_extent(i, x_to)
        if abs(x_to - x0) <= length * (1 + 1e-14):
            empty = np.zeros(0)
            return empty, empty, empty, -1
        x, w = mapped_rule(x0 + direction * length, x_to, 0.0, 0.0, n) if direction > 0 else \
            mapped_rule(x_to, x0 + direction * length, 0.0, 0.0, n)
        return x, direction * w, np.zeros(n), -1

    def interconnections(self) -> np.ndarray:
        """Rigid interconnection residuals between neighbouring zones (paper Eq. 17), all gaps:
        ``h(a) - h(b) + int_b^mid w' - int_a^mid w' = S_b - S_a + [h]`` where ``[h]``, the jump
        of h between the ends of the two graded parts, vanishes when both reach the midpoint on
        the same piece."""
        n = self.layout.n
        if n < 2:
            return np.zeros(0)
        e = self.layout.edges
        ib = 2 * np.arange(n - 1) + 1
        ia = ib + 1
        mid = 0.5 * (e[ib] + e[ia])
        S, ends = self._gap_sums(np.concatenate([ib, ia]), np.concatenate([mid, mid]))
        jump = np.array([0.0 if (pb is pa and xb == xa) else self._h_at([(pa, xa), (pb, xb)])
                         @ np.array([1.0, -1.0]) for (pb, xb), (pa, xa)
                         in zip(ends[: n - 1], ends[n - 1:], strict=True)])
        return S[: n - 1] - S[n - 1:] + jump

