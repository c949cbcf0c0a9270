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

from dataclasses import dataclass
from functools import lru_cache

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
    ratio = length / max(clearance, 1e-300)
    n = BASE_NODES + 14.0 * np.sqrt(max(ratio, 0.0))
    return int(min(MAX_NODES, 8 * np.ceil(n / 8)))


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
    edges, pinned, eps = layout.edges, layout.pinned, layout.eps
    s_all, O_all = [], []
    zones = edges.reshape(-1, 2)
    for k, (a, b) in enumerate(zones):
        cuts = [a, *[q for q in profile.kinks if a < q < b], b]
        clearance = _zone_clearance(edges, k)
        d = int(sign_exponent(np.array([0.5 * (a + b)]), edges, pinned)[0])
        sk = sign_from_d(np.array([d]))[0]
        for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
            al = -eps[2 * k] if lo == a else 0.0
            ah = -eps[2 * k + 1] if hi == b else 0.0
            n = nodes_for(hi - lo, min(clearance, _kink_clearance(lo, hi, a, b)))
            s, w = mapped_rule(lo, hi, al, ah, n)
            skip = np.zeros(edges.size, bool)
            skip[2 * k] = lo == a
            skip[2 * k + 1] = hi == b
            rest = sk * w_abs(s, edges, -eps, skip)
            s_all.append(s)
            O_all.append(w * rest)
    s = np.concatenate(s_all)
    Om = np.concatenate(O_all)
    dh = profile.dh0(s) - theta
    return SQuad(s - xc, Om, np.abs(Om), dh)


def _zone_clearance(edges: np.ndarray, k: int) -> float:
    a, b = edges[2 * k], edges[2 * k + 1]
    others = np.delete(edges, [2 * k, 2 * k + 1])
    if others.size == 0:
        return np.inf
    return float(np.min(np.minimum(np.abs(others - a), np.abs(others - b))))


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

    def poly_part(self, xh: np.ndarray) -> np.ndarray:
        """``Poly(x)``: polynomial part of ``1/W`` at infinity (shifted coordinate)."""
        lay = self.layout
        deg = lay.n - lay.e
        if deg < 0:
            return np.zeros_like(xh)
        c = series_coeffs(self.e_hat, lay.eps, -1.0, deg)
        return np.polyval(c, xh) if deg >= 0 else 0.0 * xh

    def T(self, xh: np.ndarray) -> np.ndarray:
        if self.beta.size == 0:
            return np.zeros_like(xh)
        return np.polyval(self.beta[::-1], xh)

    def B(self, xh: np.ndarray, H: np.ndarray, dH: np.ndarray | None = None) -> np.ndarray:
        """``B(x)`` at shifted points ``xh`` with subtraction values ``H`` (same shape)."""
        sq = self.sq
        xh = np.asarray(xh, float)
        diff = sq.s[None, :] - xh.reshape(-1, 1)
        num = sq.dh[None, :] - H.reshape(-1, 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            q = num / diff
        small = np.abs(diff) < 1e-13 * (1.0 + np.abs(xh.reshape(-1, 1)))
        if np.any(small):
            fill = np.zeros_like(xh) if dH is None else dH
            q = np.where(small, np.broadcast_to(fill.reshape(-1, 1), q.shape), q)
        val = q @ sq.Omega
        return (val + np.pi * H.ravel() * self.poly_part(xh.ravel()) + self.T(xh.ravel())
                ).reshape(xh.shape)

    def W_real(self, x: np.ndarray) -> np.ndarray:
        """Signed real W (outside L) or W_s (inside L) at absolute x."""
        lay = self.layout
        d = sign_exponent(np.atleast_1d(x), lay.edges, lay.pinned)
        return sign_from_d(d) * w_abs(np.atleast_1d(x), lay.edges, lay.eps)

    def gap_slope(self, x: np.ndarray) -> np.ndarray:
        """Deformed-gap slope ``g'(x) = W(x) B(x)/pi`` at absolute x outside the zones."""
        x = np.atleast_1d(np.asarray(x, float))
        H = self.profile.dh0(x) - self.theta
        return self.W_real(x) * self.B(x - self.xc, H, self.profile.d2h0(x)) / np.pi

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
        return float(val + np.pi * H * self.poly_part(np.array([xh]))[0]
                     + self.T(np.array([xh]))[0])

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
    def moments(self, jmax: int) -> tuple[np.ndarray, np.ndarray]:
        """``mu_j = sum s^j h' Omega`` and the matching absolute sums (for scaling)."""
        sq = self.sq
        pw = sq.s[None, :] ** np.arange(jmax + 1)[:, None]
        return pw @ (sq.dh * sq.Omega), np.abs(pw) @ (np.abs(sq.dh) * sq.absOmega)

    def consistency_nodes(self) -> np.ndarray:
        """Centres (shifted) of the ``e - n`` zones whose Lagrange polynomials span the
        consistency conditions: a localised basis keeps the rows independent when the zones are
        narrow and far apart (monomials ``s^j`` are then nearly dependent)."""
        lay = self.layout
        k = lay.e - lay.n
        free_count = (~lay.pinned).reshape(-1, 2).sum(1)
        order = np.argsort(-free_count, kind="stable")[:max(k, 0)]
        z = self.e_hat.reshape(-1, 2)
        return np.sort(z[order].mean(1))

    def consistency(self) -> tuple[np.ndarray, np.ndarray]:
        """Consistency residuals ``int_L L_k(s) h'(s) omega(s) ds`` (paper Eq. 12) in the Lagrange
        basis on :meth:`consistency_nodes`, and the absolute sums used to scale them."""
        c = self.consistency_nodes()
        sq = self.sq
        rows, norms = [], []
        for k in range(c.size):
            others = np.delete(c, k)
            L = np.prod((sq.s[:, None] - others[None, :]) / (c[k] - others[None, :]), axis=1)
            rows.append(L @ (sq.dh * sq.Omega))
            norms.append(np.abs(L) @ (np.abs(sq.dh) * sq.absOmega))
        return np.asarray(rows), np.asarray(norms)

    def load(self) -> float:
        """Total load: ``P = (1/A) int_L prod_k (s - c_k) h' omega ds`` for e >= n (the monic
        degree-(e-n) polynomial; equal to ``mu_{e-n}/A`` once consistency holds) or
        ``-beta_{n-e-1}/A`` for e < n."""
        lay = self.layout
        if lay.e < lay.n:
            return float(-self.beta[lay.n - lay.e - 1] / self.A)
        c = self.consistency_nodes()
        sq = self.sq
        poly = np.prod(sq.s[:, None] - c[None, :], axis=1) if c.size else np.ones_like(sq.s)
        return float(poly @ (sq.dh * sq.Omega) / self.A)

    def w1(self) -> float:
        lay = self.layout
        return float(series_coeffs(self.e_hat, lay.eps, 1.0, 1)[1])

    def load_and_moment(self) -> tuple[float, float]:
        """Total load and moment about x = 0 implied by the current state (closed forms)."""
        lay, A = self.layout, self.A
        n, e = lay.n, lay.e
        if e >= n:
            mu, _ = self.moments(e - n + 1)
            P = self.load()
            Mc = (mu[e - n + 1] + self.w1() * mu[e - n]) / A
        else:
            beta = self.beta
            P = -beta[n - e - 1] / A
            lower = beta[n - e - 2] if n - e - 2 >= 0 else 0.0
            mu0 = self.moments(0)[0][0] if e == n - 1 else 0.0
            Mc = -(lower + self.w1() * beta[n - e - 1] - mu0) / A
        return float(P), float(Mc + self.xc * P)

    # gap integrals -----------------------------------------------------------------------------
    def edge_piece(self, i: int) -> Piece:
        """Profile piece on the zone side of edge i (its continuation is used near the edge)."""
        x = self.layout.edges[i]
        side = 1.0 if i % 2 == 0 else -1.0
        probe = x + side * 1e-9 * max(self.profile.scale, abs(x), 1e-300)
        k = int(self.profile.piece_index(np.array([probe]))[0])
        return self.profile.pieces[max(k, 0)]

    def wprime_integral(self, i: int, x_to: np.ndarray) -> np.ndarray:
        """``int_{edge_i}^{x_to} w'(t) dt`` for points ``x_to`` on the outer side of edge i."""
        x0 = float(self.layout.edges[i])
        x_to = np.atleast_1d(np.asarray(x_to, float))
        pc = self.edge_piece(i)
        direction = np.sign(x_to - x0)
        reach = pc.reach[1] if i % 2 == 1 else pc.reach[0]
        lim = 0.5 * abs(reach - x0) if np.isfinite(reach) else np.inf
        near_len = np.minimum(np.abs(x_to - x0), lim)
        total = self._near_edge(i, pc, near_len, direction)
        far = np.abs(x_to - x0) > near_len * (1 + 1e-14)
        if np.any(far):
            start = x0 + direction[far] * near_len[far]
            total[far] += self._plain_segment(start, x_to[far])
        return total

    def _near_edge(self, i: int, pc: Piece, length: np.ndarray, direction: np.ndarray):
        """``int`` of w' over ``[x0, x0 + dir*length]`` with the edge piece's continuation.

        All targets share one evaluation of B: their graded rules are concatenated and the
        weighted values summed per target.
        """
        x0 = float(self.layout.edges[i])
        eps_i = float(self.layout.eps[i])
        clearance = float(np.min(np.abs(np.delete(self.layout.edges, i) - x0)))
        out = np.zeros(length.shape)
        todo = np.flatnonzero(length > 0)
        if todo.size == 0:
            return out
        rules = [graded_rule(float(length[j]), clearance, eps_i) for j in todo]
        counts = np.array([r[0].size for r in rules])
        sgn = np.repeat(direction[todo], counts)
        x = x0 + sgn * np.concatenate([r[0] for r in rules])
        w = np.concatenate([r[1] for r in rules])
        skip = np.zeros(self.layout.edges.size, bool)
        skip[i] = True
        rest = (sign_from_d(sign_exponent(x, self.layout.edges, self.layout.pinned))
                * w_abs(x, self.layout.edges, self.layout.eps, skip))
        Bv = self.B(x - self.xc, pc.dh(x) - self.theta, pc.d2h(x))
        sums = np.add.reduceat(w * rest * Bv, np.concatenate([[0], np.cumsum(counts)[:-1]]))
        x_end = x0 + direction[todo] * length[todo]
        dh_int = pc.h(x_end) - pc.h(np.full_like(x_end, x0)) - self.theta * (x_end - x0)
        out[todo] = direction[todo] * sums / np.pi - dh_int
        return out

    def _plain_segment(self, x_from: np.ndarray, x_to: np.ndarray, n: int = 48) -> np.ndarray:
        """``int`` of w' over regular segments far from the edges (no subtraction needed)."""
        t, w = jacobi_rule(n, 0.0, 0.0)
        half = 0.5 * (x_to - x_from)[:, None]
        x = 0.5 * (x_to + x_from)[:, None] + half * t[None, :]
        Wv = self.W_real(x.ravel()).reshape(x.shape)
        zero = np.zeros(x.size)
        Bv = self.B(x.ravel() - self.xc, zero).reshape(x.shape)
        return np.sum(w[None, :] * half * Wv * Bv, axis=1) / np.pi

    def h_at_edge(self, i: int) -> float:
        x = float(self.layout.edges[i])
        return float(self.edge_piece(i).h(np.array([x]))[0]) - self.theta * x

    def interconnection(self, m: int) -> float:
        """Rigid interconnection residual between zones m and m+1 (paper Eq. 17)."""
        ib, ia = 2 * m + 1, 2 * m + 2
        b, a = self.layout.edges[ib], self.layout.edges[ia]
        mid = np.array([0.5 * (a + b)])
        right = self.wprime_integral(ib, mid)[0]
        left = self.wprime_integral(ia, mid)[0]
        return self.h_at_edge(ia) - self.h_at_edge(ib) + right - left
