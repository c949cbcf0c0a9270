"""Cauchy integrals ``F(w) = int f(s) / (s - w) ds`` and ``F'(w)`` of the tractions sampled on
panels (:mod:`analytic._traction_panels`), at any ``w`` with ``Im w >= 0``.

Far targets use the plain Gauss sums (a smooth sub-interval's one coarse block, the panels of
the others).  A target whose pole ``cos t = tau`` lies close to a panel (Bernstein radius below
``RHO_NEAR``) gets that panel's integral again on sub-panels graded geometrically (ratio
``GRADE``) towards the pole, with G interpolated from the panel's nodes (no further density
evaluations); it stays accurate to rounding at any depth.
"""

from __future__ import annotations

import numpy as np

from analytic._traction_panels import PANEL_NODES, RHO_NEAR, Quadrature, Rule, legendre

GRADE = 3.0
"""Ratio of consecutive refined sub-panels (a sub-panel's pole is >= its half-width away)."""
MIN_POLE = 1e-13
"""Smallest pole distance (panel units) resolved; closer targets use this distance."""
TARGET_CHUNK = 2048
"""Targets per block of the near-pair search."""
CHUNK_ENTRIES = 2**16
"""Target x node entries per block of the far-field sums (1 MB of complex: cache-sized; 2**21
took 64 MB at once and was ~25 % slower at 20k targets; the rows do not depend on the block)."""
NEAR_MARGIN = 1.05
"""Safety factor on the radius of the disc that pre-selects near targets (boundary sampling)."""
SNAP = 1e-3
"""A pole's foot within SNAP x its distance of a panel end is put on the end."""
REFINED_NODES = 2**15
"""Sub-panel nodes (pairs x 2 x levels x PANEL_NODES) per block of the refined sums: the Legendre
table is 16 x this many floats (4 MB; 256 pairs of any depth took up to 20 MB at the surface);
a pair's sums do not depend on its block."""


def _far(s: np.ndarray, WG: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gauss sums of F and F' for every target over all nodes (n_targets, 2), in row blocks of
    about CHUNK_ENTRIES kernel entries formed in one reused buffer (k1, then k1^2 in place)."""
    WG = WG.astype(complex)  # complex @ complex runs in BLAS
    F = np.empty((w.size, WG.shape[1]), complex)
    dF = np.empty_like(F)
    ends = _row_blocks(w.size, max(2, CHUNK_ENTRIES // max(s.size, 1)))
    buf = np.empty((int(np.max(np.diff(ends), initial=0)), s.size), complex)
    for i, j in zip(ends[:-1], ends[1:], strict=True):
        k = buf[:j - i]
        np.subtract(s[None, :], w[i:j, None], out=k)
        np.divide(1.0, k, out=k)
        F[i:j] = k @ WG
        np.multiply(k, k, out=k)
        dF[i:j] = k @ WG
    return F, dF


def _row_blocks(n: int, rows: int) -> np.ndarray:
    """Ends ``[0, ..., n]`` of blocks of ``rows`` (>= 2) rows, a last single row joined to the
    block before: a one-row product is summed as a vector (BLAS gemv), with other rounding than
    the matrix kernel, so joined every row has the same bits whatever the block size (only a
    lone target, ``n = 1``, is summed as a vector)."""
    ends = list(range(0, n, rows)) + [n]
    if len(ends) > 2 and ends[-1] - ends[-2] == 1:
        del ends[-2]
    return np.asarray(ends)


def _poles(rule: Rule, w: np.ndarray, jp: np.ndarray) -> np.ndarray:
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


def _near_discs(rule: Rule) -> tuple[np.ndarray, np.ndarray]:
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


def _near_pairs(rule: Rule, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def _refined(rule: Rule, w: np.ndarray, jp: np.ndarray, up: np.ndarray
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
        pairs = max(1, REFINED_NODES // (2 * int(L) * PANEL_NODES))
        for i in range(0, sel.size, pairs):
            k = sel[i:i + pairs]
            F[k], dF[k] = _graded_sums(rule, w[k], jp[k], tc[k], d[k], int(L))
    return F, dF


def _graded_sums(rule: Rule, w: np.ndarray, jp: np.ndarray, tc: np.ndarray, d: np.ndarray,
                 levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss sums of F, F' on the graded sub-panels of one batch (same number of levels).

    ``s - x`` is formed as ``(s(t_c) - x) + half (cos t_c - cos t)`` with ``t - t_c`` from the
    sub-panel offsets, so it keeps its relative accuracy at depths far below the node spacing.
    """
    ta, tb = rule.ta[jp], rule.tb[jp]
    th = 0.5 * (tb - ta)
    lo, hi = _subpanels((ta - tc) / th, (tb - tc) / th, d, levels)
    u, wq, _ = legendre(PANEL_NODES)
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    dt = th[:, None] * (c[:, :, None] + h[:, :, None] * u).reshape(len(jp), -1)
    wf = th[:, None] * (h[:, :, None] * wq).reshape(len(jp), -1)
    half, t0 = rule.half[jp, None], tc[:, None]
    off0, end = rule.position(jp[:, None], t0)
    e = ((end - w.real[:, None]) + off0
         + 2 * half * np.sin(t0 + 0.5 * dt) * np.sin(0.5 * dt))
    uf = (t0 + dt - 0.5 * (ta + tb)[:, None]) / th[:, None]
    G = (_legvander(uf, PANEL_NODES - 1) @ rule.coef[jp]).astype(complex)
    inv = 1.0 / (e - 1j * w.imag[:, None])
    k1 = wf * inv
    return _sums(k1, G), _sums(k1 * inv, G)


def _legvander(x: np.ndarray, deg: int) -> np.ndarray:
    """``np.polynomial.legendre.legvander(x, deg)`` with the same operations in the same order
    (bit for bit the same array, same memory layout) but in place, without the temporaries of
    every degree (the refined sums spend most of their time here)."""
    v = np.empty((deg + 1, *x.shape))
    v[0] = x * 0 + 1
    if deg > 0:
        v[1] = x
        a, b = np.empty_like(x), np.empty_like(x)
        for i in range(2, deg + 1):
            np.multiply(v[i - 1], x, out=a)
            a *= 2 * i - 1
            np.multiply(v[i - 2], i - 1, out=b)
            np.subtract(a, b, out=a)
            np.divide(a, i, out=v[i])
    return np.moveaxis(v, 0, -1)


def _sums(k: np.ndarray, G: np.ndarray) -> np.ndarray:
    """Per row n: ``sum_f k[n, f] G[n, f, :]`` (G complex: complex @ complex runs in BLAS)."""
    return (k[:, None, :] @ G)[:, 0, :]


def _weighted(rule: Rule) -> np.ndarray:
    """``wt G`` of every node of a rule as complex (n_nodes, 2), formed once per evaluation."""
    return (rule.wt[:, None] * rule.G).astype(complex)


def _block_sums(rule: Rule, WG: np.ndarray, w: np.ndarray, jp: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The plain Gauss sums of blocks ``jp`` for targets ``w`` (one block per target); ``WG``:
    the rule's :func:`_weighted` nodal data."""
    idx = rule.nodes(jp)
    k1 = 1.0 / (rule.s[idx] - w[:, None])
    WG = WG[idx]
    return _sums(k1, WG), _sums(k1 * k1, WG)


def _correct(F: np.ndarray, dF: np.ndarray, it: np.ndarray, new, old) -> None:
    np.add.at(F, it, new[0] - old[0])
    np.add.at(dF, it, new[1] - old[1])


def cauchy(quad: Quadrature, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
    weighted = _weighted(quad.coarse), _weighted(pan)
    for i in range(0, w.size, TARGET_CHUNK):
        part = w[i:i + TARGET_CHUNK]
        near_sub = _swap_coarse(quad, weighted, part, F[i:i + TARGET_CHUNK],
                                dF[i:i + TARGET_CHUNK])
        it, jp, up = _near_pairs(pan, part)
        keep = in_far[jp] | near_sub[it, pan.parent[jp]]
        it, jp, up = it[keep], jp[keep], up[keep]
        if it.size:
            _correct(F, dF, i + it, _refined(pan, part[it], jp, up),
                     _block_sums(pan, weighted[1], part[it], jp))
    return F, dF


def _swap_coarse(quad: Quadrature, weighted: tuple[np.ndarray, np.ndarray], w: np.ndarray,
                 F: np.ndarray, dF: np.ndarray) -> np.ndarray:
    """Replace the coarse sums by panel sums for targets near a smooth sub-interval (in place);
    returns the (n_targets, n_sub) mask of those pairs.  ``weighted``: the coarse and panel
    rules' :func:`_weighted` nodal data."""
    near = np.zeros((w.size, quad.smooth.size), bool)
    if not quad.smooth.any():
        return near
    it, jc, _ = _near_pairs(quad.coarse, w)
    use = quad.smooth[quad.coarse.parent[jc]]  # the others are summed by panels anyway
    it, jc = it[use], jc[use]
    sub = quad.coarse.parent[jc]
    near[it, sub] = True
    _correct(F, dF, it, (0.0, 0.0), _block_sums(quad.coarse, weighted[0], w[it], jc))
    first = np.searchsorted(quad.panels.parent, sub)  # a sub-interval's panels are consecutive
    count = np.bincount(quad.panels.parent, minlength=quad.smooth.size)[sub]
    for j in range(int(count.max(initial=0))):
        m = j < count
        _correct(F, dF, it[m], _block_sums(quad.panels, weighted[1], w[it[m]], first[m] + j),
                 (0.0, 0.0))
    return near

