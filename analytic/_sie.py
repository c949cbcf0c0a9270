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

The real values of W are in :mod:`analytic._layout`; the quadratures are planned in
:mod:`analytic._zone_quadrature` (over L) and :mod:`analytic._gap_quadrature` (in the gaps),
from the rules of :mod:`analytic._rules`.

All coordinates here are shifted by the centre ``xc`` (powers stay well scaled).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property, lru_cache

import numpy as np

from analytic._gap_quadrature import (
    GAP_CHUNK,
    GAP_SUBTRACT_REACH,
    SUBTRACT_REACH,
    GapPlan,
    edge_clearances,
    edge_pieces,
    plan_gaps,
)
from analytic._layout import Layout, sign_exponent, sign_from_d, w_abs
from analytic._zone_quadrature import (
    SQuad,
    kink_rule,
    near_kinks,
    near_vertical_ends,
    squad_nodes,
    squad_plan,
    vertical_end_rule,
)
from analytic.profiles import Piece, Profile


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
        return edge_pieces(self.layout, self.profile)

    @cached_property
    def edge_clearances(self) -> np.ndarray:
        """Distance from each edge to the nearest other edge, kink or corner ``(K, 2n)`` (see
        :func:`analytic._gap_quadrature.edge_clearances`)."""
        return edge_clearances(self.edges, self.profile)

    def gap_plan(self, idx: Sequence[int], x_to: Sequence[float],
                 subtract_reach: float = math.inf) -> GapPlan:
        """The structure of the integrals from edges ``idx`` to ``x_to``, sized on member 0 (see
        :func:`analytic._gap_quadrature.plan_gaps`)."""
        return plan_gaps(self.layout, self.edges[0].tolist(), self.edge_clearances[0].tolist(),
                         self.edge_pieces, idx, x_to, subtract_reach)

    def residual_growth(self, x: np.ndarray) -> np.ndarray:
        """``int_0^x`` of the polynomial part at infinity of ``W B/pi`` ``(K, M)`` at shifted
        points ``(K, M)`` (zero when e <= n).  With the consistency residuals ``mu_j`` (``j < e -
        n``, solved to ~1e-10, not 0) ``W B/pi`` gains ``-(1/pi) sum c_k mu_j x^(e-n-1-k-j)``
        (``W = x^(e-n) sum c_k x^-k``) that no pressure produces: w' of the returned pressure
        is ``W B/pi`` less it (audit seed 103644 vertically: g(x) 1.1e-7 A P off the log-kernel
        gap 2 spans out without it, 5.8e-9 with it)."""
        q = self.layout.e - self.layout.n
        out = np.zeros(x.shape)
        if q <= 0:
            return out
        for k, coef in enumerate(self._growth_coefs):
            for i, a in enumerate(coef):
                out[k] += a * x[k] ** (q - i) / (q - i)
        return -out / np.pi

    @cached_property
    def _growth_coefs(self) -> list[np.ndarray]:
        """Per member, the coefficient of ``x^(e-n-1-i)`` in the residuals' part of ``W B/pi``
        (``i = k + j < e - n``, see :meth:`residual_growth`): computed once per batch, as the
        deformed gap is evaluated point by point (a walk over an overlap, ~50 calls)."""
        q = self.layout.e - self.layout.n
        mu = self.moments(q - 1)
        return [np.convolve(series_coeffs(e, self.layout.eps, 1.0, q - 1), m)[:q]
                for e, m in zip(self.edges - self.xc, mu, strict=True)]

    def gap_sums(self, plan: GapPlan, x_to: np.ndarray) -> np.ndarray:
        """``int g'`` ``(K, parts)`` from each planned edge to ``x_to (K, parts)`` (the graded
        parts as ``S - [h]``, see :class:`GapPlan` and :meth:`GapPlan.graded_ends`).  All
        points share one evaluation of B."""
        if plan.part.size == 0:
            return np.zeros(x_to.shape)
        _, D, L = plan.graded_lengths(self.edges, x_to)
        f = plan.first_lengths(self.edge_clearances, L)
        x, w = plan.nodes(self.edges, np.concatenate([f, L, D], axis=1))
        H = np.zeros(x.shape)
        for pc, nodes in plan.groups:
            H[:, nodes] = pc.dh(x[:, nodes]) - self.theta[:, None]
        with np.errstate(divide="ignore"):  # a target within an ulp of its edge: x == edge
            logs = np.log(np.abs(x[:, :, None] - self.edges[:, None, :]))
        logs[(slice(None), *plan.graded)] = 0.0  # the edge's own factor is in the graded weight
        vals = w * np.exp(logs @ self.layout.eps) * self.B(x - self.xc, H, off_nodes=True)
        return (vals @ plan.sums) / np.pi

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
                ends = plan.graded_ends(e, self.edge_clearances, x_to) if ends is None else ends
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
        for j, kink, cuts, beyond in near_kinks(self.layout, self.profile, x_in):
            Bv[j] = self._B_graded(x[j], H[j], kink, cuts, beyond)
        for j, end, cut in near_vertical_ends(self.layout, self.profile, x_in):
            Bv[j] = self._B_vertical(x[j], H[j], end, cut)
        WB = self.W_real(x) * Bv / np.pi
        return WB[:x_in.size] / self.A, WB[x_in.size:]

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

    def _B_vertical(self, x: np.ndarray, H: np.ndarray, end: float, cut: float) -> np.ndarray:
        """B at points x near a pinned vertical end (the zone rule refined by
        :func:`analytic._zone_quadrature.vertical_end_rule`)."""
        return self._divided_sums(x, H, *vertical_end_rule(self.layout, self.sq, self.xc, x,
                                                            end, cut))

    def _B_graded(self, x: np.ndarray, H: np.ndarray, kink: float, cuts: tuple,
                  beyond: tuple) -> np.ndarray:
        """B at points x near ``kink``: the zone rule graded towards it on its two pieces
        (:func:`analytic._zone_quadrature.kink_rule`) plus the part within ``tau`` of it."""
        s_all, O_all, tau = kink_rule(self.layout, self.profile, self.sq, self.xc, x, cuts,
                                      beyond)
        return self._divided_sums(x, H, s_all, O_all) + self._kink_core(x, H, kink, tau)

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
        plan = self.batch.gap_plan(idx.tolist(), x_to.tolist(), GAP_SUBTRACT_REACH)
        S = self.batch.gap_sums(plan, x_to[None, :])
        ends = plan.graded_ends(self.batch.edges, self.batch.edge_clearances, x_to[None, :])
        grow = self.batch.residual_growth(
            np.concatenate([x_to, self.batch.edges[0][idx]])[None, :] - self.xc)[0]
        return (h_to - self.batch.h_at(ends, plan.pieces)[0] + S[0]
                - (grow[:x_to.size] - grow[x_to.size:]))
