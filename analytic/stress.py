"""Stresses in body 2 (the flat lower half-plane ``y <= 0``) under the analytic tractions.

Conventions (README, DESIGN.md), stated once here for the stresses:

* Body 2 occupies ``y <= 0``; its surface ``y = 0`` carries the pressure ``p >= 0`` (compressive,
  pushing body 2 down) and the shear ``q`` of the solution.  ``Q`` pushes body 1 along +x and
  body 1 drags body 2 with it: the tangential traction body 2 receives on its surface is ``+q``
  along +x (``int q dx = Q``; the FE model's ``sxy`` on body 2's contact row is ``+q``).  So the
  surface values are ``syy = -p`` and ``sxy = +q``.  Tension is positive.
* Plane strain: ``szz = nu (sxx + syy)``.  The solutions carry only ``A = 4 (1 - nu^2)/E``, and
  the in-plane stresses of a half-plane under given tractions do not depend on the material, so
  ``nu`` is a required keyword of :func:`stress` (it enters ``szz`` only).
* Body 1 (upper) feels the opposite tractions on the mirrored half-plane; for similar materials
  its field is the mirror image (``x, -y``, with the sign of ``sxy`` and of the shear part of
  ``sxx`` flipped) and is not computed here.

Flamant line-load kernels (Johnson, *Contact Mechanics*, Eq. 2.23, with depth ``z = -y``,
``u = x - s``, ``r^2 = u^2 + z^2``)::

    sxx = -(2/pi) int [ p z u^2 + q u^3 ] / r^4 ds
    syy = -(2/pi) int [ p z^3   + q z^2 u ] / r^4 ds
    sxy = +(2/pi) int [ p z^2 u + q z u^2 ] / r^4 ds

(``sxy = -tau_xz`` of Johnson's downward z).  Every kernel is a combination of the Cauchy
integrals ``F(w) = int f(s) / (s - w) ds`` and ``F'(w)``, ``w = x + i z``: with
``C = -F`` and ``D = F'``, ``z int f u^2/r^4 = (z Re D - Im C)/2``, ``z^3 int f/r^4 =
-(Im C + z Re D)/2``, ``z^2 int f u/r^4 = -z Im D / 2`` and ``int f u^3/r^4 = Re C + z Im D/2``.

Surface (``z -> 0``): ``syy -> -p``, ``sxy -> q`` and

    sxx(x, 0) = -p(x) - (2/pi) PV int q(s) / (x - s) ds                     (surface_stress)

(Johnson Eq. 2.25a; the sign follows from the kernels above: ahead of a shear q > 0 body 2 is
compressed, behind it -- the trailing edge -- stretched).

Quadrature.  Each zone is cut at its profile kinks and, for a stick solution, at every stick
edge of this and the earlier stage.  On a sub-interval ``[lo, hi]``, ``s = mid - half cos t``;
the density ``G(t) = f(s(t)) half sin t`` is smooth in t for the ``sqrt`` (nonsingular edge),
``1/sqrt`` (singular edge, treated exactly: the weight ``1/sqrt`` is absorbed by ``sin t``, the
Gauss-Jacobi substitution) and one-sided ``sqrt`` (stick edge) end behaviours, and only weakly
singular (``t log t``) at a kink, where the panels are graded.  Each sub-interval carries
``PANELS`` Gauss-Legendre panels in t.  A target whose pole ``cos t = tau`` lies close to a
panel (Bernstein radius below ``RHO_NEAR``) gets that panel's integral again on sub-panels graded
geometrically towards the pole, with G interpolated from the panel's nodes (no further density
evaluations); it stays accurate to rounding at any depth.  On the surface the principal value
is the limit ``Re F(x + i e) + e Im F'(x + i e)`` at a tiny lift ``e`` (error O(e^2)).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from analytic.errors import ConvergenceError, InputError
from analytic.normal import NormalSolution
from analytic.stick import StickSolution, _breakpoints, _split_at_kinks

PANELS = 4
"""Gauss-Legendre panels in the angle t per sub-interval (uniform in t)."""
PANEL_NODES = 16
"""Nodes per panel: far targets (Bernstein radius >= RHO_NEAR) err by ~RHO_NEAR**-32."""
RHO_NEAR = 3.0
"""Targets whose pole lies inside this Bernstein ellipse of a panel get the refined rule."""
GRADE = 3.0
"""Ratio of consecutive refined sub-panels (a sub-panel's pole is >= its half-width away)."""
KINK_LEVELS = 3
"""Extra panels graded by 1/4 towards a kink end (the density is ~ t log t there).  The nearest
node stays ~2e-9 sub-interval half-widths from the kink: the pressure's own kink rule divides
0/0 within ~1e-14 of a kink."""
MIN_POLE = 1e-13
"""Smallest pole distance (panel units) resolved; closer targets use this distance."""
TARGET_CHUNK = 2048
"""Targets per block of the near-pair search."""
CHUNK_ENTRIES = 2**21
"""Target x node entries per block of the far-field sums (32 MB of complex)."""
NEAR_MARGIN = 1.05
"""Safety factor on the radius of the disc that pre-selects near targets (boundary sampling)."""
TAIL_TOL = 1e-12
"""A panel is halved while the last two Legendre coefficients of a density exceed this fraction
of its largest value (a steep stick-zone pressure near a zone split needs it)."""
SPLIT_ROUNDS = 12
"""At most this many halvings of a panel."""
MAX_PANELS = 4000
"""Most panels of one solution (~1 ms of traction evaluations each)."""
MIN_PANEL = 1e-4
"""Narrowest panel in t (the pressure's kink rule fails within ~1e-14 of a kink)."""
COARSE_MOMENTS = 8
"""Moments compared before a sub-interval's far targets use its one coarse block."""
COARSE_TOL = 1e-12
"""Agreement of those moments with the panels', relative to int |G|."""
QUAD_MEMO = 8
"""Solutions whose sampled tractions are kept (by identity, while they are alive)."""
SURFACE_LIFT = 1e-6
"""Surface principal values are taken this fraction of the distance to the nearest sub-interval
end above the surface, with a first-order Taylor correction (see _principal_values)."""
SURFACE_LIFT_MIN = 1e-6
"""Floor of that distance, relative to the contact span: on a sub-interval end the lift is
1e-12 of the span (the error there is O(sqrt(e)) relative, ~1e-6, from the sqrt ends)."""
SNAP = 1e-3
"""A pole's foot within SNAP x its distance of a panel end is put on the end."""
PAIR_CHUNK = 256
"""Near (target, panel) pairs per block of the refined sums."""


# ---------------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StressField:
    """Plane-strain stress in body 2 (``y <= 0``) at the points ``(x, y)`` (broadcast shape).

    ``sxx, syy, sxy``: in-plane components (force per unit area, tension positive, body 2's
    axes: x along the interface, y up); ``szz = nu (sxx + syy)``; ``nu``: Poisson's ratio used.
    """

    x: np.ndarray
    y: np.ndarray
    sxx: np.ndarray
    syy: np.ndarray
    sxy: np.ndarray
    szz: np.ndarray
    nu: float

    @property
    def max_shear(self) -> np.ndarray:
        """In-plane maximum shear stress ``sqrt(((sxx - syy)/2)^2 + sxy^2)``."""
        return np.hypot(0.5 * (self.sxx - self.syy), self.sxy)

    @property
    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """In-plane principal stresses ``(s1 >= s2)``."""
        mean = 0.5 * (self.sxx + self.syy)
        return mean + self.max_shear, mean - self.max_shear

    @property
    def von_mises(self) -> np.ndarray:
        """Von Mises equivalent stress (with ``szz``)."""
        d = ((self.sxx - self.syy) ** 2 + (self.syy - self.szz) ** 2 + (self.szz - self.sxx) ** 2)
        return np.sqrt(0.5 * d + 3.0 * self.sxy**2)


@dataclass(frozen=True)
class RuizResult:
    """Ruiz fretting parameter along the surface at one stage-3 state.

    ``x``: surface points; ``value``: ``max(sxx, 0) |q| |slip|`` there (``sxx`` and ``q`` of the
    state, ``slip`` accumulated in stage 3); ``maximum`` and ``x_max``: its largest value and
    where; ``Q``: tangential load of the state.
    """

    x: np.ndarray
    value: np.ndarray
    maximum: float
    x_max: float
    Q: float


# ---------------------------------------------------------------------------------------------
# densities on panels
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Rule:
    """Tractions on Gauss-Legendre blocks in t (``s = mid - half cos t``) of the sub-intervals.

    Per block j (``PANEL_NODES`` consecutive nodes): ``mid, half`` of its sub-interval, its
    t-range ``(ta, tb)`` and ``parent`` (index of the sub-interval).  Per node: ``s``, ``wt``
    (Gauss weight in t) and ``G`` (n_nodes, 2) ``= (p, q)(s) half sin t``; ``coef`` (n_blocks,
    PANEL_NODES, 2): Legendre coefficients of G on each block.
    """

    lo: np.ndarray
    hi: np.ndarray
    ta: np.ndarray
    tb: np.ndarray
    parent: np.ndarray
    s: np.ndarray
    wt: np.ndarray
    G: np.ndarray
    coef: np.ndarray

    @property
    def mid(self) -> np.ndarray:
        return 0.5 * (self.lo + self.hi)

    @property
    def half(self) -> np.ndarray:
        return 0.5 * (self.hi - self.lo)

    def position(self, j: np.ndarray, t: np.ndarray) -> np.ndarray:
        """``s(t) - lo`` or ``s(t) - hi`` of block j, whichever end t is nearer: with
        ``s = lo + 2 half sin^2(t/2) = hi - 2 half cos^2(t/2)`` exact near both ends.
        Returns ``(offset, end)`` so that ``s = end + offset``."""
        near_lo = t < 0.5 * np.pi
        h = self.half[j]
        off = np.where(near_lo, 2 * h * np.sin(0.5 * t) ** 2, -2 * h * np.cos(0.5 * t) ** 2)
        return off, np.where(near_lo, self.lo[j], self.hi[j])

    def nodes(self, blocks: np.ndarray) -> np.ndarray:
        """Node indices (len(blocks), PANEL_NODES) of the blocks."""
        return blocks[:, None] * PANEL_NODES + np.arange(PANEL_NODES)[None, :]


@dataclass(frozen=True)
class _Quadrature:
    """Two levels: ``panels`` (PANELS per sub-interval, graded at kinks) and ``coarse`` (one
    block per sub-interval without a kink end, used for targets far from the whole of it).
    ``smooth``: per sub-interval, True where it has a coarse block."""

    panels: _Rule
    coarse: _Rule
    smooth: np.ndarray


@lru_cache(maxsize=4)
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes, weights and the inverse Legendre-Vandermonde matrix."""
    u, w = np.polynomial.legendre.leggauss(n)
    return u, w, np.linalg.inv(np.polynomial.legendre.legvander(u, n - 1))


def _t_breaks(left_kink: bool, right_kink: bool) -> np.ndarray:
    """Panel ends in t on [0, pi]: uniform, graded by 1/4 towards kink ends."""
    t = list(np.linspace(0.0, np.pi, PANELS + 1))
    step = np.pi / PANELS
    grade = step * 0.25 ** np.arange(1, KINK_LEVELS + 1)
    if left_kink:
        t += list(grade)
    if right_kink:
        t += list(np.pi - grade)
    return np.unique(t)


def _intervals(solution) -> list[tuple[float, float, bool, bool]]:
    """Sub-intervals ``(lo, hi, lo_is_kink, hi_is_kink)`` of all contact zones."""
    normal = _normal_of(solution)
    kinks = set(normal.profile.kinks)
    out = []
    for k, (a, b) in enumerate(normal.zones):
        pts = (_breakpoints(solution, k) if isinstance(solution, StickSolution)
               else _split_at_kinks(normal.profile, a, b))
        out += [(lo, hi, lo in kinks, hi in kinks)
                for lo, hi in zip(pts[:-1], pts[1:], strict=True) if hi > lo]
    return out


def _tractions(solution, x: np.ndarray) -> np.ndarray:
    """``(p, q)`` at x, shape (x.size, 2); q = 0 for a normal solution.

    Raises :class:`ConvergenceError` if a traction is not finite (the pressure is not
    evaluated closer than ~1e-9 of a sub-interval to a kink, see KINK_LEVELS).
    """
    if isinstance(solution, StickSolution):  # p evaluated once for both
        out = np.column_stack(solution._pressure_and_shear(x))
    else:
        out = np.column_stack([solution.pressure(x), np.zeros(x.size)])
    bad = ~np.all(np.isfinite(out), axis=1)
    if np.any(bad):
        raise ConvergenceError(f"the tractions are not finite at x = {x[bad][:5]!r}: the "
                               "stresses cannot be integrated", {"x": x[bad]})
    return out


def _rule(solution, blocks: list[tuple[float, float, float, float, int]]) -> _Rule:
    """Sample the tractions on blocks ``(lo, hi, ta, tb, parent)``."""
    u, w, vinv = _legendre(PANEL_NODES)
    lo, hi, ta, tb, parent = (np.asarray(v) for v in zip(*blocks, strict=True))
    half = 0.5 * (hi - lo)
    tm, th = 0.5 * (ta + tb), 0.5 * (tb - ta)
    t = tm[:, None] + th[:, None] * u
    rows = np.arange(lo.size)[:, None]
    rule = _Rule(lo=lo, hi=hi, ta=ta, tb=tb, parent=parent.astype(int), s=np.zeros(0),
                 wt=(th[:, None] * w).ravel(), G=np.zeros(0), coef=np.zeros(0))
    off, end = rule.position(rows, t)
    s = (end + off).ravel()
    dens = _tractions(solution, s).reshape(*t.shape, 2) * (half[:, None] * np.sin(t))[..., None]
    return replace(rule, s=s, G=dens.reshape(-1, 2), coef=np.einsum("ij,pjd->pid", vinv, dens))


def _quadrature(solution) -> _Quadrature:
    """The panels of a solution, remembered for the last QUAD_MEMO solutions (stress and
    surface_stress of one state sample the tractions once)."""
    key = id(solution)
    hit = _MEMO.get(key)
    if hit is not None and hit[0]() is solution:
        return hit[1]
    quad = _build_quadrature(solution)
    _MEMO[key] = (weakref.ref(solution), quad)
    while len(_MEMO) > QUAD_MEMO:
        _MEMO.pop(next(iter(_MEMO)))
    return quad


_MEMO: dict[int, tuple[weakref.ref, _Quadrature]] = {}


def _build_quadrature(solution) -> _Quadrature:
    subs = _intervals(solution)
    blocks = [(lo, hi, a, b, k) for k, (lo, hi, kl, kr) in enumerate(subs)
              for a, b in _pairs(_t_breaks(kl, kr))]
    kink_ends = {(k, end) for k, (_, _, kl, kr) in enumerate(subs)
                 for end, is_kink in ((0.0, kl), (np.pi, kr)) if is_kink}
    panels = _adapted(solution, blocks, kink_ends)
    coarse = _rule(solution, [(lo, hi, 0.0, np.pi, k) for k, (lo, hi, _, _) in enumerate(subs)])
    smooth = _coarse_agrees(coarse, panels) & np.array([not (kl or kr) for _, _, kl, kr in subs])
    return _Quadrature(panels, coarse, smooth)


def _coarse_agrees(coarse: _Rule, panels: _Rule) -> np.ndarray:
    """Per sub-interval: the coarse block integrates ``G T_k(cos t)``, ``k < COARSE_MOMENTS``,
    as its panels do, to COARSE_TOL of ``int |G|`` after weighting by ``RHO_NEAR^-k`` (a far
    target's kernel ``1/(s - w)`` expands in these with coefficients ~ ``rho^-k``)."""
    def moments(rule: _Rule) -> np.ndarray:
        u = _legendre(PANEL_NODES)[0]
        t = (0.5 * (rule.ta + rule.tb)[:, None] + 0.5 * (rule.tb - rule.ta)[:, None] * u).ravel()
        T = np.cos(np.arange(COARSE_MOMENTS)[None, :] * t[:, None])
        out = np.zeros((coarse.lo.size, COARSE_MOMENTS, 2))
        np.add.at(out, rule.parent.repeat(PANEL_NODES), (rule.wt[:, None] * T)[:, :, None]
                  * rule.G[:, None, :])
        return out

    size = np.zeros(coarse.lo.size)
    np.add.at(size, panels.parent.repeat(PANEL_NODES), panels.wt * np.max(np.abs(panels.G), 1))
    decay = RHO_NEAR ** -np.arange(COARSE_MOMENTS)[None, :, None]  # far kernels' weights
    diff = np.max(np.abs(moments(coarse) - moments(panels)) * decay, axis=1)
    return np.all(diff <= COARSE_TOL * np.where(size > 0, size, 1.0)[:, None], axis=1)


def _pairs(t: np.ndarray) -> list[tuple[float, float]]:
    return list(zip(t[:-1], t[1:], strict=True))


def _scales(rule: _Rule) -> float:
    """Largest |G| of both densities: q is resolved relative to p's scale (a shear that
    cancels to rounding noise, e.g. a flat punch at Q = 0 in stage 3, needs no panels)."""
    m = float(np.max(np.abs(rule.G)))
    return m if m > 0 else 1.0


def _unresolved(rule: _Rule, scale: np.ndarray) -> np.ndarray:
    """Blocks whose last two Legendre coefficients exceed TAIL_TOL of the density scale."""
    tail = np.max(np.abs(rule.coef[:, -2:, :]), axis=1) / scale
    return np.any(tail > TAIL_TOL, axis=1)


def _adapted(solution, blocks: list, kink_ends: set) -> _Rule:
    """Panels halved in t until every density is resolved (TAIL_TOL), at most SPLIT_ROUNDS
    times and not below MIN_PANEL; the graded panels at a kink end are kept (t log t there)."""
    done: list[_Rule] = []
    rule = _rule(solution, blocks)
    scale = _scales(rule)
    for _ in range(SPLIT_ROUNDS):
        bad = _unresolved(rule, scale) & (rule.tb - rule.ta > 2 * MIN_PANEL)
        bad &= ~np.array([(k, 0.0) in kink_ends and a == 0.0 or (k, np.pi) in kink_ends
                          and b == np.pi for k, a, b in zip(rule.parent, rule.ta, rule.tb,
                                                            strict=True)])
        done.append(_take(rule, np.flatnonzero(~bad)))
        if not bad.any():
            break
        if sum(r.lo.size for r in done) + 2 * bad.sum() > MAX_PANELS:
            raise ConvergenceError(
                f"the tractions need more than MAX_PANELS={MAX_PANELS} panels to reach a "
                f"Legendre tail of {TAIL_TOL:g}: they are not smooth between the breakpoints",
                {"unresolved_t": list(zip(rule.ta[bad], rule.tb[bad], strict=True))[:10]})
        j = np.flatnonzero(bad)
        mid = 0.5 * (rule.ta[j] + rule.tb[j])
        new = [(rule.lo[i], rule.hi[i], a, b, rule.parent[i]) for i, m in zip(j, mid, strict=True)
               for a, b in ((rule.ta[i], m), (m, rule.tb[i]))]
        rule = _rule(solution, new)
    else:
        done.append(rule)
    merged = _concat(done)
    return _take(merged, np.lexsort((merged.ta, merged.parent)))


def _take(rule: _Rule, blocks: np.ndarray) -> _Rule:
    """The rule restricted to (and ordered as) ``blocks``."""
    nodes = rule.nodes(blocks).ravel()
    return _Rule(lo=rule.lo[blocks], hi=rule.hi[blocks], ta=rule.ta[blocks], tb=rule.tb[blocks],
                 parent=rule.parent[blocks], s=rule.s[nodes], wt=rule.wt[nodes],
                 G=rule.G[nodes], coef=rule.coef[blocks])


def _concat(rules: list[_Rule]) -> _Rule:
    return _Rule(*(np.concatenate([getattr(r, f) for r in rules])
                   for f in ("lo", "hi", "ta", "tb", "parent", "s", "wt", "G", "coef")))


# ---------------------------------------------------------------------------------------------
# Cauchy integrals F(w) = int f / (s - w) ds and F'(w)
# ---------------------------------------------------------------------------------------------
def _far(s: np.ndarray, WG: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gauss sums of F and F' for every target over all nodes (n_targets, 2)."""
    WG = WG.astype(complex)  # complex @ complex runs in BLAS
    F = np.empty((w.size, WG.shape[1]), complex)
    dF = np.empty_like(F)
    rows = max(1, CHUNK_ENTRIES // max(s.size, 1))
    for i in range(0, w.size, rows):
        k1 = 1.0 / (s[None, :] - w[i:i + rows, None])
        F[i:i + rows] = k1 @ WG
        dF[i:i + rows] = (k1 * k1) @ WG
    return F, dF


def _poles(rule: _Rule, w: np.ndarray, jp: np.ndarray) -> np.ndarray:
    """Pole of ``1/(s(t) - w)`` nearest block ``jp`` (of t_w, -t_w, 2 pi - t_w), block units.

    ``t_w = 2 asin(sqrt((w - lo)/(hi - lo)))`` (or its mirror from hi), accurate near both
    ends where ``arccos`` of ``(mid - w)/half`` would lose half the digits."""
    lo, hi = rule.lo[jp], rule.hi[jp]
    near_lo = np.abs(w - lo) <= np.abs(w - hi)
    r = np.sqrt(np.where(near_lo, w - lo, hi - w).astype(complex) / (hi - lo))
    a = 2 * np.arcsin(r)
    tw = np.where(near_lo, a, np.pi - a)
    tm, th = 0.5 * (rule.ta[jp] + rule.tb[jp]), 0.5 * (rule.tb[jp] - rule.ta[jp])
    u = (np.stack([tw, -tw, 2 * np.pi - tw]) - tm) / th
    best = np.argmin(_bernstein(u), axis=0)
    return np.take_along_axis(u, best[None], axis=0)[0]


def _bernstein(u: np.ndarray) -> np.ndarray:
    """Bernstein-ellipse radius (>= 1) of the points u relative to [-1, 1]."""
    r = u + np.sqrt(u - 1) * np.sqrt(u + 1)
    return np.maximum(np.abs(r), 1.0 / np.maximum(np.abs(r), 1e-300))


def _near_discs(rule: _Rule) -> tuple[np.ndarray, np.ndarray]:
    """Centre and radius (in s) of a disc holding the image of each block's RHO_NEAR ellipse.

    ``s(t)`` is analytic, so the image of the ellipse lies within the largest distance of its
    boundary's image from the centre; targets outside the disc are far (no pole computed).
    """
    phi = np.linspace(0.0, 2 * np.pi, 128, endpoint=False)
    ell = 0.5 * (RHO_NEAR * np.exp(1j * phi) + np.exp(-1j * phi) / RHO_NEAR)
    tm, th = 0.5 * (rule.ta + rule.tb), 0.5 * (rule.tb - rule.ta)
    s = rule.mid[:, None] - rule.half[:, None] * np.cos(tm[:, None] + th[:, None] * ell)
    c = rule.mid - rule.half * np.cos(tm)
    return c, NEAR_MARGIN * np.max(np.abs(s - c[:, None]), axis=1)


def _near_pairs(rule: _Rule, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(target, block) pairs with the pole inside the block's RHO_NEAR ellipse, and the pole."""
    c, r = _near_discs(rule)
    it, jp = np.nonzero(np.abs(w[:, None] - c[None, :]) < r[None, :])
    up = _poles(rule, w[it], jp)
    near = _bernstein(up) < RHO_NEAR
    return it[near], jp[near], up[near]


def _levels(d: np.ndarray) -> np.ndarray:
    """Graded sub-panels per side needed to reach 2 (the panel width) from a central width d."""
    return np.ceil(np.log(4.0 / d) / np.log(GRADE)).astype(int) + 1


def _subpanels(lo: np.ndarray, hi: np.ndarray, d: np.ndarray, levels: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Sub-panel ends as offsets from the pole's foot (exact near it however small d is),
    graded by GRADE from a central width d and clipped to the panel's offsets ``[lo, hi]``."""
    r = 0.5 * d[:, None] * GRADE ** np.arange(levels)[None, :]
    ends = np.clip(np.concatenate([-r[:, ::-1], r], axis=1), lo[:, None], hi[:, None])
    return ends[:, :-1], ends[:, 1:]


def _refined(rule: _Rule, w: np.ndarray, jp: np.ndarray, up: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """F, F' contributions of blocks ``jp`` for targets ``w`` on graded sub-panels.

    In t: the pole's foot ``tc`` (its real part clipped to the panel) and ``d`` its distance in
    panel units.  A foot on a panel end is that end exactly, so neighbouring panels meet
    without gap or overlap and agree on ``s(tc) - x``.
    """
    ta, tb = rule.ta[jp], rule.tb[jp]
    th = 0.5 * (tb - ta)
    tp = 0.5 * (ta + tb) + th * up
    tc = np.clip(tp.real, ta, tb)
    d = np.maximum(np.abs(tp - tc) / th, MIN_POLE)
    for end in (ta, tb):  # a foot a rounding error from a panel end is that end
        tc = np.where(np.abs(tc - end) < SNAP * d * th, end, tc)
    lev = _levels(d)
    F = np.empty((w.size, rule.G.shape[1]), complex)
    dF = np.empty_like(F)
    for L in np.unique(lev):
        sel = np.flatnonzero(lev == L)
        for i in range(0, sel.size, PAIR_CHUNK):
            k = sel[i:i + PAIR_CHUNK]
            F[k], dF[k] = _graded_sums(rule, w[k], jp[k], tc[k], d[k], int(L))
    return F, dF


def _graded_sums(rule: _Rule, w: np.ndarray, jp: np.ndarray, tc: np.ndarray, d: np.ndarray,
                 levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss sums of F, F' on the graded sub-panels of one batch (same number of levels).

    ``s - x`` is formed as ``(s(t_c) - x) + half (cos t_c - cos t)`` with ``t - t_c`` from the
    sub-panel offsets, so it keeps its relative accuracy at depths far below the node spacing.
    """
    ta, tb = rule.ta[jp], rule.tb[jp]
    th = 0.5 * (tb - ta)
    lo, hi = _subpanels((ta - tc) / th, (tb - tc) / th, d, levels)
    u, wq, _ = _legendre(PANEL_NODES)
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    dt = th[:, None] * (c[:, :, None] + h[:, :, None] * u).reshape(len(jp), -1)
    wf = th[:, None] * (h[:, :, None] * wq).reshape(len(jp), -1)
    half, t0 = rule.half[jp, None], tc[:, None]
    off0, end = rule.position(jp[:, None], t0)
    e = ((end - w.real[:, None]) + off0
         + 2 * half * np.sin(t0 + 0.5 * dt) * np.sin(0.5 * dt))
    uf = (t0 + dt - 0.5 * (ta + tb)[:, None]) / th[:, None]
    G = np.polynomial.legendre.legvander(uf, PANEL_NODES - 1) @ rule.coef[jp]
    inv = 1.0 / (e - 1j * w.imag[:, None])
    k1 = wf * inv
    return _sums(k1, G), _sums(k1 * inv, G)


def _sums(k: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Per row n: ``sum_f k[n, f] G[n, f, :]``."""
    return (k[:, None, :] @ G.astype(complex))[:, 0, :]


def _block_sums(rule: _Rule, w: np.ndarray, jp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The plain Gauss sums of blocks ``jp`` for targets ``w`` (one block per target)."""
    idx = rule.nodes(jp)
    k1 = 1.0 / (rule.s[idx] - w[:, None])
    WG = rule.wt[idx][..., None] * rule.G[idx]
    return _sums(k1, WG), _sums(k1 * k1, WG)


def _correct(F: np.ndarray, dF: np.ndarray, it: np.ndarray, new, old) -> None:
    np.add.at(F, it, new[0] - old[0])
    np.add.at(dF, it, new[1] - old[1])


def _cauchy(quad: _Quadrature, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``F(w)`` and ``F'(w)`` for Im w >= 0 (the principal value on the contact surface).

    Far sums: the coarse block of every smooth sub-interval and the panels of the others.
    Targets near a coarse block get its panels instead; targets near a panel (whose sums they
    use: the panel ellipse lies inside its coarse block's) get graded sub-panels instead.
    """
    pan = quad.panels
    in_far = ~quad.smooth[pan.parent]
    nodes = pan.nodes(np.flatnonzero(in_far)).ravel()
    crs = quad.coarse.nodes(np.flatnonzero(quad.smooth[quad.coarse.parent]
                                           & (quad.coarse.half > 0))).ravel()
    s = np.concatenate([quad.coarse.s[crs], pan.s[nodes]])
    WG = np.concatenate([quad.coarse.wt[crs, None] * quad.coarse.G[crs],
                         pan.wt[nodes, None] * pan.G[nodes]])
    F, dF = _far(s, WG, w)
    for i in range(0, w.size, TARGET_CHUNK):
        part = w[i:i + TARGET_CHUNK]
        near_sub = _swap_coarse(quad, part, F[i:i + TARGET_CHUNK], dF[i:i + TARGET_CHUNK])
        it, jp, up = _near_pairs(pan, part)
        keep = in_far[jp] | near_sub[it, pan.parent[jp]]
        it, jp, up = it[keep], jp[keep], up[keep]
        if it.size:
            _correct(F, dF, i + it, _refined(pan, part[it], jp, up),
                     _block_sums(pan, part[it], jp))
    return F, dF


def _swap_coarse(quad: _Quadrature, w: np.ndarray, F: np.ndarray, dF: np.ndarray
                 ) -> np.ndarray:
    """Replace the coarse sums by panel sums for targets near a smooth sub-interval (in place);
    returns the (n_targets, n_sub) mask of those pairs."""
    near = np.zeros((w.size, quad.smooth.size), bool)
    if not quad.smooth.any():
        return near
    it, jc, _ = _near_pairs(quad.coarse, w)
    use = quad.smooth[quad.coarse.parent[jc]]  # the others are summed by panels anyway
    it, jc = it[use], jc[use]
    sub = quad.coarse.parent[jc]
    near[it, sub] = True
    _correct(F, dF, it, (0.0, 0.0), _block_sums(quad.coarse, w[it], jc))
    first = np.searchsorted(quad.panels.parent, sub)  # a sub-interval's panels are consecutive
    count = np.bincount(quad.panels.parent, minlength=quad.smooth.size)[sub]
    for j in range(int(count.max(initial=0))):
        m = j < count
        _correct(F, dF, it[m], _block_sums(quad.panels, w[it[m]], first[m] + j), (0.0, 0.0))
    return near


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------
def _normal_of(solution) -> NormalSolution:
    if isinstance(solution, StickSolution):
        return solution.normal
    if isinstance(solution, NormalSolution):
        return solution
    raise InputError(f"solution must be an analytic NormalSolution or StickSolution, "
                     f"got {type(solution)!r}")


def _check_nu(nu: float) -> float:
    nu = float(nu)
    if not (np.isfinite(nu) and -1.0 < nu <= 0.5):
        raise InputError(f"nu={nu!r} is not allowed: need Poisson's ratio -1 < nu <= 0.5")
    return nu


def _points(x, y) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise InputError("x and y must be finite")
    if np.any(y > 0):
        raise InputError(f"y={float(np.max(y))!r} is not allowed: body 2 is the half-plane "
                         "y <= 0")
    return x, y


def surface_stress(solution: NormalSolution | StickSolution, x: np.ndarray | float
                   ) -> np.ndarray:
    """``sxx`` on body 2's surface: ``-p(x) - (2/pi) PV int q(s) / (x - s) ds`` (vectorised).

    Tension positive; see the module docstring for the sign.  The principal value is accurate
    to ~1e-12 of ``max |q|`` (see :func:`_principal_values`), smooth enough to locate its peak.
    At a singular edge (where p and q are unbounded) the value is not meaningful.
    """
    _normal_of(solution)
    x = np.asarray(x, float)
    if not np.all(np.isfinite(x)):
        raise InputError("x must be finite")
    flat = np.atleast_1d(x).ravel()
    pv = _principal_values(solution, _quadrature(solution), flat)
    return (-_tractions(solution, flat)[:, 0] + (2.0 / np.pi) * pv[:, 1]).reshape(x.shape)


def _principal_values(solution, quad: _Quadrature, x: np.ndarray) -> np.ndarray:
    """``PV int f(s) / (s - x) ds`` for (p, q): ``Re F(x + i e) + e Im F'(x + i e) + O(e^2)``.

    The lift ``e`` is SURFACE_LIFT times the distance to the nearest sub-interval end (at least
    SURFACE_LIFT_MIN of the contact span), so the O(e^2) remainder stays ~1e-12 relative even
    next to a sqrt edge, and the off-surface rule, accurate to rounding at any depth, does the
    rest.
    """
    pan = quad.panels
    ends = np.unique(np.r_[pan.lo, pan.hi])
    zones = _normal_of(solution).zones
    floor = SURFACE_LIFT_MIN * (zones[-1][1] - zones[0][0])
    dist = np.min(np.abs(x[:, None] - ends[None, :]), axis=1)
    e = SURFACE_LIFT * np.maximum(dist, floor)
    F, dF = _cauchy(quad, x + 1j * e)
    return F.real + e[:, None] * dF.imag


def _field(F: np.ndarray, dF: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(sxx, syy, sxy)`` from the Cauchy integrals of p (column 0) and q (column 1)."""
    C, D = -F, dF
    zc = z[:, None]
    J1 = 0.5 * (zc * D.real - C.imag)          # z int f u^2 / r^4
    J2 = -0.5 * (C.imag + zc * D.real)         # z^3 int f / r^4
    J3 = -0.5 * zc * D.imag                    # z^2 int f u / r^4
    J4 = C.real + 0.5 * zc * D.imag            # int f u^3 / r^4
    k = 2.0 / np.pi
    sxx = -k * (J1[:, 0] + J4[:, 1])
    syy = -k * (J2[:, 0] + J3[:, 1])
    sxy = k * (J3[:, 0] + J1[:, 1])
    return sxx, syy, sxy


def stress(solution: NormalSolution | StickSolution, x: np.ndarray | float,
           y: np.ndarray | float, *, nu: float) -> StressField:
    """Plane-strain stress in body 2 at ``(x, y)``, ``y <= 0``, under the solution's p and q.

    ``solution``: a :class:`NormalSolution` (q = 0) or a :class:`StickSolution` of stage 2 or 3
    (its shear); ``x, y``: broadcastable arrays; ``nu``: Poisson's ratio (keyword, needed for
    ``szz = nu (sxx + syy)`` only -- the solutions carry just ``A``).  On ``y = 0`` the surface
    values ``(-p + (2/pi) PV..., -p, q)`` are returned (:func:`surface_stress`).  Conventions
    and the quadrature: module docstring.
    """
    _normal_of(solution)
    nu = _check_nu(nu)
    x, y = _points(x, y)
    xf, zf = x.ravel(), -y.ravel()
    quad = _quadrature(solution)
    F, dF = _cauchy(quad, xf + 1j * zf)
    sxx, syy, sxy = _field(F, dF, zf)
    top = zf == 0
    if np.any(top):
        pq = _tractions(solution, xf[top])
        sxx[top] = -pq[:, 0] + (2.0 / np.pi) * _principal_values(solution, quad, xf[top])[:, 1]
        syy[top], sxy[top] = -pq[:, 0], pq[:, 1]
    shape = x.shape
    return StressField(x=x, y=y, sxx=sxx.reshape(shape), syy=syy.reshape(shape),
                       sxy=sxy.reshape(shape), szz=(nu * (sxx + syy)).reshape(shape), nu=nu)


def ruiz(state: StickSolution, x: np.ndarray | float | None = None, n: int = 2001
         ) -> RuizResult:
    """Ruiz fretting parameter ``max(sxx, 0) |q| |slip|`` on body 2's surface (stage-3 state).

    Evaluated with ``sxx`` (:func:`surface_stress`) and ``q`` of ``state`` and the slip
    accumulated in stage 3 (for ``Q = -Q0`` the slip range of a steady cycle).  ``x`` defaults
    to ``n`` points across the contact span plus all stick edges.
    """
    if not isinstance(state, StickSolution) or state.stage != 3:
        raise InputError("ruiz needs a stage-3 analytic.StickSolution (solve_stick(normal, mu, "
                         "Q, Q0)), the end of a cycle being Q = -Q0")
    if x is None:
        zones = state.normal.zones
        x = np.linspace(zones[0][0], zones[-1][1], int(n))
    x = np.atleast_1d(np.asarray(x, float))
    value = np.maximum(surface_stress(state, x), 0.0) * np.abs(state.shear(x))
    value = value * np.abs(np.nan_to_num(state.slip(x)))
    i = int(np.argmax(value))
    return RuizResult(x=x, value=value, maximum=float(value[i]), x_max=float(x[i]), Q=state.Q)
