"""The tractions of a solution sampled on Gauss-Legendre panels in an angle: the density of
the stress integrals of :mod:`analytic.stress`.

Each zone is cut at its profile kinks and, for a stick solution, at every stick edge of this and
the earlier stage (:mod:`analytic._breakpoints`).  On a sub-interval ``[lo, hi]``,
``s = mid - half cos t``; the density ``G(t) = f(s(t)) half sin t`` is smooth in t for the
``sqrt`` (nonsingular edge), ``1/sqrt`` (singular edge, treated exactly: the weight ``1/sqrt``
is absorbed by ``sin t``, the Gauss-Jacobi substitution) and one-sided ``sqrt`` (stick edge) end
behaviours, and only weakly singular (``t log t``) at a kink, where the panels are graded.  Each
sub-interval carries ``PANELS`` Gauss-Legendre panels in t, halved until the densities'
Legendre tails are resolved, and one coarse block where that agrees (for far targets).  The
Cauchy integrals over these panels are :mod:`analytic._cauchy_integrals`.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from analytic._breakpoints import breakpoints, split_at_kinks
from analytic.errors import ConvergenceError, InputError
from analytic.normal import NormalSolution
from analytic.stick import StickSolution

PANELS = 4
"""Gauss-Legendre panels in the angle t per sub-interval (uniform in t)."""
PANEL_NODES = 16
"""Nodes per panel: far targets (Bernstein radius >= RHO_NEAR) err by ~RHO_NEAR**-32."""
RHO_NEAR = 3.0
"""Targets whose pole lies inside this Bernstein ellipse of a panel get the refined rule."""
KINK_LEVELS = 3
"""Extra panels graded by 1/4 towards a kink end (the density is ~ t log t there).  The nearest
node stays ~2e-9 sub-interval half-widths from the kink: the pressure's own kink rule divides
0/0 within ~1e-14 of a kink."""
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


@dataclass(frozen=True)
class Rule:
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
class Quadrature:
    """Two levels: ``panels`` (PANELS per sub-interval, graded at kinks) and ``coarse`` (one
    block per sub-interval without a kink end, used for targets far from the whole of it).
    ``smooth``: per sub-interval, True where it has a coarse block.  Between them ``pairs``:
    one block on each two neighbouring panels of a sub-interval (``pair_of``: per panel the
    index of its pair block, -1 for the last of an odd number), used for targets near the
    sub-interval but far from the two panels where ``paired`` (per pair block: it reproduces
    its panels' moments, :func:`_blocks_agree`)."""

    panels: Rule
    coarse: Rule
    smooth: np.ndarray
    pairs: Rule
    paired: np.ndarray
    pair_of: np.ndarray


@lru_cache(maxsize=4)
def legendre(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    normal = normal_of(solution)
    kinks = set(normal.profile.kinks)
    out = []
    for k, (a, b) in enumerate(normal.zones):
        pts = (breakpoints(solution, k) if isinstance(solution, StickSolution)
               else split_at_kinks(normal.profile, a, b))
        out += [(lo, hi, lo in kinks, hi in kinks)
                for lo, hi in zip(pts[:-1], pts[1:], strict=True) if hi > lo]
    return out


def tractions(solution, x: np.ndarray) -> np.ndarray:
    """``(p, q)`` at x, shape (x.size, 2); q = 0 for a normal solution.

    Raises :class:`ConvergenceError` if a traction is not finite (the pressure is not
    evaluated closer than ~1e-9 of a sub-interval to a kink, see KINK_LEVELS).
    """
    if isinstance(solution, StickSolution):  # p evaluated once for both
        out = np.column_stack(solution.pressure_and_shear(x))
    else:
        out = np.column_stack([solution.pressure(x), np.zeros(x.size)])
    bad = ~np.all(np.isfinite(out), axis=1)
    if np.any(bad):
        raise ConvergenceError(f"the tractions are not finite at x = {x[bad][:5]!r}: the "
                               "stresses cannot be integrated", {"x": x[bad]})
    return out


def _rule(solution, blocks: list[tuple[float, float, float, float, int]]) -> Rule:
    """Sample the tractions on blocks ``(lo, hi, ta, tb, parent)``."""
    u, w, vinv = legendre(PANEL_NODES)
    lo, hi, ta, tb, parent = (np.asarray(v) for v in zip(*blocks, strict=True))
    half = 0.5 * (hi - lo)
    tm, th = 0.5 * (ta + tb), 0.5 * (tb - ta)
    t = tm[:, None] + th[:, None] * u
    rows = np.arange(lo.size)[:, None]
    rule = Rule(lo=lo, hi=hi, ta=ta, tb=tb, parent=parent.astype(int), s=np.zeros(0),
                wt=(th[:, None] * w).ravel(), G=np.zeros(0), coef=np.zeros(0))
    off, end = rule.position(rows, t)
    s = (end + off).ravel()
    dens = tractions(solution, s).reshape(*t.shape, 2) * (half[:, None] * np.sin(t))[..., None]
    return replace(rule, s=s, G=dens.reshape(-1, 2), coef=np.einsum("ij,pjd->pid", vinv, dens))


def quadrature(solution) -> Quadrature:
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


_MEMO: dict[int, tuple[weakref.ref, Quadrature]] = {}


def _build_quadrature(solution) -> Quadrature:
    subs = _intervals(solution)
    blocks = [(lo, hi, a, b, k) for k, (lo, hi, kl, kr) in enumerate(subs)
              for a, b in _pairs(_t_breaks(kl, kr))]
    kink_ends = {(k, end) for k, (_, _, kl, kr) in enumerate(subs)
                 for end, is_kink in ((0.0, kl), (np.pi, kr)) if is_kink}
    panels = _adapted(solution, blocks, kink_ends)
    coarse = _rule(solution, [(lo, hi, 0.0, np.pi, k) for k, (lo, hi, _, _) in enumerate(subs)])
    smooth = _coarse_agrees(coarse, panels) & np.array([not (kl or kr) for _, _, kl, kr in subs])
    pair_of, pair_blocks = _pair_up(panels)
    pairs = _rule(solution, pair_blocks)
    return Quadrature(panels, coarse, smooth, pairs, _blocks_agree(pairs, panels, pair_of),
                      pair_of)


def _pair_up(panels: Rule) -> tuple[np.ndarray, list]:
    """Per panel the index of its pair block (-1: none) and the pair blocks ``(lo, hi, ta, tb,
    parent)``: panels 0-1, 2-3, ... of each sub-interval in t order (they are contiguous)."""
    pair_of = np.full(panels.ta.size, -1)
    blocks = []
    for k in np.unique(panels.parent):
        js = np.flatnonzero(panels.parent == k)  # in t order (_adapted sorts them)
        for a, b in zip(js[0:-1:2], js[1::2], strict=True):
            pair_of[[a, b]] = len(blocks)
            blocks.append((panels.lo[a], panels.hi[a], panels.ta[a], panels.tb[b], int(k)))
    return pair_of, blocks


def _blocks_agree(big: Rule, small: Rule, owner: np.ndarray) -> np.ndarray:
    """Per block of ``big``: it integrates ``G T_k(u)``, ``k < COARSE_MOMENTS`` (u its own
    variable in t, -1..1), as the blocks of ``small`` it covers do (``owner``: per small block
    the big block, -1 for none), to COARSE_TOL of their ``int |G|`` after weighting by
    ``RHO_NEAR^-k`` (the kernel ``1/(s - w)`` of a target whose pole lies outside the big
    block's RHO_NEAR ellipse expands in these with coefficients ~ ``RHO_NEAR^-k``): the
    standard of :func:`_coarse_agrees` on the block's own variable."""
    def moments(rule: Rule, own: np.ndarray) -> np.ndarray:
        u = legendre(PANEL_NODES)[0]
        t = 0.5 * (rule.ta + rule.tb)[:, None] + 0.5 * (rule.tb - rule.ta)[:, None] * u
        v = (t - 0.5 * (big.ta + big.tb)[own, None]) / (0.5 * (big.tb - big.ta)[own, None])
        T = np.cos(np.arange(COARSE_MOMENTS) * np.arccos(np.clip(v, -1.0, 1.0))[..., None])
        out = np.zeros((big.ta.size, COARSE_MOMENTS, 2))
        np.add.at(out, own.repeat(PANEL_NODES), (rule.wt[:, None] * T.reshape(-1, COARSE_MOMENTS))
                  [:, :, None] * rule.G[:, None, :])
        return out

    mine = np.flatnonzero(owner >= 0)
    small = _take(small, mine)
    own = owner[mine]
    size = np.zeros(big.ta.size)
    np.add.at(size, own.repeat(PANEL_NODES), small.wt * np.max(np.abs(small.G), 1))
    decay = RHO_NEAR ** -np.arange(COARSE_MOMENTS)[None, :, None]
    diff = np.max(np.abs(moments(big, np.arange(big.ta.size)) - moments(small, own)) * decay,
                  axis=1)
    return np.all(diff <= COARSE_TOL * np.where(size > 0, size, 1.0)[:, None], axis=1)


def _coarse_agrees(coarse: Rule, panels: Rule) -> np.ndarray:
    """Per sub-interval: the coarse block integrates ``G T_k(cos t)``, ``k < COARSE_MOMENTS``,
    as its panels do, to COARSE_TOL of ``int |G|`` after weighting by ``RHO_NEAR^-k`` (a far
    target's kernel ``1/(s - w)`` expands in these with coefficients ~ ``rho^-k``)."""
    def moments(rule: Rule) -> np.ndarray:
        u = legendre(PANEL_NODES)[0]
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


def _scales(rule: Rule) -> float:
    """Largest |G| of both densities: q is resolved relative to p's scale (a shear that
    cancels to rounding noise, e.g. a flat punch at Q = 0 in stage 3, needs no panels)."""
    m = float(np.max(np.abs(rule.G)))
    return m if m > 0 else 1.0


def _unresolved(rule: Rule, scale: np.ndarray) -> np.ndarray:
    """Blocks whose last two Legendre coefficients exceed TAIL_TOL of the density scale."""
    tail = np.max(np.abs(rule.coef[:, -2:, :]), axis=1) / scale
    return np.any(tail > TAIL_TOL, axis=1)


def _adapted(solution, blocks: list, kink_ends: set) -> Rule:
    """Panels halved in t until every density is resolved (TAIL_TOL), at most SPLIT_ROUNDS
    times and not below MIN_PANEL; the graded panels at a kink end are kept (t log t there)."""
    done: list[Rule] = []
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


def _take(rule: Rule, blocks: np.ndarray) -> Rule:
    """The rule restricted to (and ordered as) ``blocks``."""
    nodes = rule.nodes(blocks).ravel()
    return Rule(lo=rule.lo[blocks], hi=rule.hi[blocks], ta=rule.ta[blocks], tb=rule.tb[blocks],
                parent=rule.parent[blocks], s=rule.s[nodes], wt=rule.wt[nodes],
                G=rule.G[nodes], coef=rule.coef[blocks])


def _concat(rules: list[Rule]) -> Rule:
    return Rule(*(np.concatenate([getattr(r, f) for r in rules])
                  for f in ("lo", "hi", "ta", "tb", "parent", "s", "wt", "G", "coef")))


def normal_of(solution) -> NormalSolution:
    """The normal solution of a normal or stick solution (InputError for anything else)."""
    if isinstance(solution, StickSolution):
        return solution.normal
    if isinstance(solution, NormalSolution):
        return solution
    raise InputError(f"solution must be an analytic NormalSolution or StickSolution, "
                     f"got {type(solution)!r}")
