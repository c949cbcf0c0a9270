"""Cauchy integrals ``F(w) = int f(s) / (s - w) ds`` and ``F'(w)`` of the tractions sampled on
panels (:mod:`analytic._traction_panels`), at any ``w`` with ``Im w >= 0``.

Plain Gauss sums, sub-interval by sub-interval: a smooth sub-interval's one coarse block for
the targets outside a disc around it; for the others (and always for a sub-interval with a kink
end) per two neighbouring panels their pair block for the targets outside its disc, where it
reproduces the panels' moments, else the two panels.  A target whose pole ``cos t = tau`` lies
close to a panel whose sums it took (Bernstein radius below ``RHO_NEAR``) gets that panel's
integral again on sub-panels graded geometrically (ratio ``GRADE``) towards the pole on each
side, as many as reach that side's panel end, with G interpolated from the panel's nodes (no
further density evaluations); it stays accurate to rounding at any depth.  Every target's
value has the same bits in any set of targets and any block size.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from analytic._traction_panels import PANEL_NODES, RHO_NEAR, Quadrature, Rule, legendre

GRADE = 4.0
"""Ratio of consecutive refined sub-panels: the pole's Bernstein radius about every sub-panel is
then >= 3 = RHO_NEAR, the panels' own far-target standard (3 gave the same Hertz / Cattaneo
fields to 1.4e-12 of p0 against McEwen and Smith-Liu at depths 1e-12..2 half-widths, with 21 %
more sub-panels)."""
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
UPSAMPLE = 4
"""Equal sub-panels of a panel's upsampled rule (G at its fixed nodes interpolated once per
panel): a near target whose pole lies outside the RHO_NEAR ellipse of every one of them takes
it instead of sub-panels graded towards its pole (no per-target interpolation)."""
ELLIPSE_DISC = 1.01 * 0.5 * (RHO_NEAR + 1.0 / RHO_NEAR)
"""Radius (half-widths) of a disc about a sub-panel's centre holding its RHO_NEAR Bernstein
ellipse (semi-major axis (RHO_NEAR + 1/RHO_NEAR)/2, 1 % margin for rounding): a pole outside it
lies outside the ellipse, decided without its Bernstein radius."""
REFINED_NODES = 2**15
"""Sub-panel nodes (pairs x sub-panels x PANEL_NODES) per block of the refined sums: the Legendre
table is 16 x this many floats (4 MB; 256 pairs of any depth took up to 20 MB at the surface);
a pair's sums do not depend on its block."""


def _far(s: np.ndarray, WG: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gauss sums of F and F' for every target over all nodes (n_targets, 2), in row blocks of
    about CHUNK_ENTRIES kernel entries formed in one reused buffer (k1, then k1^2 in place)."""
    if w.size == 1:  # a one-row product runs as a vector: summed as a row of two instead
        F, dF = _far(s, WG, np.repeat(w, 2))
        return F[:1], dF[:1]
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


def _kernel_squares(a: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``(Re k, Im k, Re k^2, Im k^2)`` of ``k = 1/(a - i z)`` (``a`` real offsets, ``z`` the
    heights) stacked on a new first axis, formed in place."""
    K = np.empty((4, *a.shape))
    r = a * a
    r += z * z
    np.divide(1.0, r, out=r)
    np.multiply(a, r, out=K[0])
    np.multiply(z, r, out=K[1])
    np.subtract(K[0], K[1], out=K[2])
    np.add(K[0], K[1], out=K[3])
    K[2] *= K[3]
    np.multiply(K[0], K[1], out=K[3])
    K[3] *= 2.0
    return K


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


def _near_pairs(rule: Rule, w: np.ndarray, discs: tuple | None = None,
                allowed: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(target, block) pairs with the pole inside the block's RHO_NEAR ellipse, and the pole.

    ``discs``: the blocks' :func:`_near_discs` (computed here if None); ``allowed(it, jp)``: a
    mask of the candidate pairs (target in a block's disc) to consider at all, applied before
    their poles are computed (each pole is computed alone: the same bits either way)."""
    c, r = _near_discs(rule) if discs is None else discs
    it, jp = np.nonzero(np.abs(w[:, None] - c[None, :]) < r[None, :])
    if allowed is not None:
        ok = allowed(it, jp)
        it, jp = it[ok], jp[ok]
    up = _poles(rule, w[it], jp)
    near = _bernstein(up) < RHO_NEAR
    return it[near], jp[near], up[near]


def _side_levels(extent: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Graded sub-panels on one side of the foot needed to reach ``extent`` (the offset of the
    panel end on that side, panel units) from a central width d (at least 1: the central
    half)."""
    with np.errstate(divide="ignore"):
        k = np.ceil(np.log(2.0 * extent / d) / np.log(GRADE)) + 1
    return np.maximum(k, 1).astype(int)


def _subpanels(lo: np.ndarray, hi: np.ndarray, d: np.ndarray, left: np.ndarray, total: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Sub-panel ends as offsets from the pole's foot (exact near it however small d is),
    graded by GRADE from a central width d: ``left`` ends before the foot (per pair) and
    ``total - left`` after it, clipped to the panel's offsets ``[lo, hi]``, whose ends close
    the outer sub-panels."""
    j = np.arange(total)[None, :]
    before = j < left[:, None]
    k = np.where(before, left[:, None] - 1 - j, j - left[:, None])
    ends = np.where(before, -0.5, 0.5) * d[:, None] * GRADE ** k
    ends = np.clip(ends, lo[:, None], hi[:, None])
    ends[:, 0], ends[:, -1] = lo, hi
    return ends[:, :-1], ends[:, 1:]


def _refined(rule: Rule, upsampled: tuple, w: np.ndarray, jp: np.ndarray, up: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """F, F' contributions of blocks ``jp`` for targets ``w`` with poles ``up``: on the block's
    upsampled rule (:func:`upsample`) where that suffices, else on graded sub-panels."""
    F = np.empty((w.size, rule.G.shape[1]), complex)
    dF = np.empty_like(F)
    ok = _upsampled_suffices(up)
    for sel, sums in ((np.flatnonzero(ok), lambda k: _upsampled_sums(upsampled, w[k], jp[k])),
                      (np.flatnonzero(~ok), lambda k: _graded(rule, w[k], jp[k], up[k]))):
        if sel.size:
            F[sel], dF[sel] = sums(sel)
    return F, dF


def _upsampled_suffices(up: np.ndarray) -> np.ndarray:
    """True where the pole ``up`` (panel units) lies outside the RHO_NEAR ellipse of every
    sub-panel of the upsampled rule."""
    c, h = _quarters()
    u = (up[:, None] - c[None, :]) / h
    ok = np.ones(u.shape, bool)
    maybe = np.abs(u) <= ELLIPSE_DISC  # elsewhere outside the ellipse: no radius computed
    ok[maybe] = _bernstein(u[maybe]) >= RHO_NEAR
    return np.all(ok, axis=1)


def _quarters() -> tuple[np.ndarray, float]:
    """Centres and half-width of the UPSAMPLE equal sub-panels of [-1, 1]."""
    edges = np.linspace(-1.0, 1.0, UPSAMPLE + 1)
    return 0.5 * (edges[:-1] + edges[1:]), 1.0 / UPSAMPLE


def upsample(rule: Rule) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(s, wt, G)`` of every block on UPSAMPLE equal sub-panels of PANEL_NODES Gauss nodes,
    shapes (n_blocks, M) and (n_blocks, M, 2), G from the block's Legendre coefficients."""
    u, wq, _ = legendre(PANEL_NODES)
    c, h = _quarters()
    uu, ww = (c[:, None] + h * u).ravel(), np.tile(h * wq, UPSAMPLE)
    th = 0.5 * (rule.tb - rule.ta)
    t = 0.5 * (rule.ta + rule.tb)[:, None] + th[:, None] * uu
    off, end = rule.position(np.arange(rule.ta.size)[:, None], t)
    return end + off, th[:, None] * ww, _legvander(uu, PANEL_NODES - 1) @ rule.coef


def _upsampled_sums(upsampled: tuple, w: np.ndarray, jp: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The sums of blocks ``jp`` on their upsampled rules for targets ``w`` (one per target)."""
    s, wt, G = upsampled
    return _pair_sums(wt[jp], s[jp] - w.real[:, None], w.imag[:, None], G[jp])


def _graded(rule: Rule, w: np.ndarray, jp: np.ndarray, up: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """F, F' of blocks ``jp`` for targets ``w`` on sub-panels graded towards the pole ``up``.

    In t: the pole's foot ``tc`` (its real part clipped to the panel) and ``d`` its distance in
    panel units.  A foot on a panel end is that end exactly, so neighbouring panels meet
    without gap or overlap and agree on ``s(tc) - x``.  Each side of the foot gets the levels
    that reach its panel end (pairs are batched by the number of sub-panels).

    A target on the surface (``Im w = 0``) whose foot lies inside the panel is the pole itself:
    the central sub-panel is then the widest one symmetric about it (to the nearer panel end),
    on which the Gauss rule, symmetric about the pole, gives the principal value (exactly for
    polynomial densities, ``G (t - t_c) / (s - x)`` being analytic there: its nearest other
    pole, the mirror ``-t_c`` or ``2 pi - t_c``, lies >= 2 half-widths from the centre, Bernstein
    radius >= 2 + sqrt 3 > RHO_NEAR); ``Re F`` is the principal value, ``F'`` is meaningless.
    """
    ta, tb = rule.ta[jp], rule.tb[jp]
    th = 0.5 * (tb - ta)
    tp = 0.5 * (ta + tb) + th * up
    tc = np.clip(tp.real, ta, tb)
    gap = np.abs(tp - tc) / th
    axis = (gap == 0) & (w.imag == 0) & (tc > ta) & (tc < tb)
    d = np.where(axis, 2 * np.minimum(tc - ta, tb - tc) / th, np.maximum(gap, MIN_POLE))
    for end in (ta, tb):  # a foot a rounding error from a panel end is that end
        tc = np.where(np.abs(tc - end) < SNAP * d * th, end, tc)
    left = _side_levels((tc - ta) / th, d)
    total = left + _side_levels((tb - tc) / th, d)
    F = np.empty((w.size, rule.G.shape[1]), complex)
    dF = np.empty_like(F)
    for n in np.unique(total):
        sel = np.flatnonzero(total == n)
        pairs = max(1, REFINED_NODES // (int(n) * PANEL_NODES))
        for i in range(0, sel.size, pairs):
            k = sel[i:i + pairs]
            F[k], dF[k] = _graded_sums(rule, w[k], jp[k], tc[k], d[k], left[k], int(n),
                                       axis[k])
    return F, dF


def _graded_sums(rule: Rule, w: np.ndarray, jp: np.ndarray, tc: np.ndarray, d: np.ndarray,
                 left: np.ndarray, total: int, axis: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Gauss sums of F, F' on the graded sub-panels of one batch (``total`` sub-panel ends,
    ``left`` of them before the foot).

    ``s - x`` is formed as ``(s(t_c) - x) + half (cos t_c - cos t)`` with ``t - t_c`` from the
    sub-panel offsets, so it keeps its relative accuracy at depths far below the node spacing.
    ``axis``: pairs whose target is the foot itself (on the surface, see :func:`_graded`):
    ``s(t_c) - x`` is taken as exactly 0, so the central sub-panel is symmetric about the pole.
    """
    ta, tb = rule.ta[jp], rule.tb[jp]
    th = 0.5 * (tb - ta)
    lo, hi = _subpanels((ta - tc) / th, (tb - tc) / th, d, left, total)
    u, wq, _ = legendre(PANEL_NODES)
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    dt = th[:, None] * (c[:, :, None] + h[:, :, None] * u).reshape(len(jp), -1)
    wf = th[:, None] * (h[:, :, None] * wq).reshape(len(jp), -1)
    half, t0 = rule.half[jp, None], tc[:, None]
    off0, end = rule.position(jp[:, None], t0)
    base = (end - w.real[:, None]) + off0
    if axis is not None:
        base[axis] = 0.0
    mid_dt = 0.5 * dt
    e = base + 2 * half * np.sin(t0 + mid_dt) * np.sin(mid_dt)
    uf = (t0 + dt - 0.5 * (ta + tb)[:, None]) / th[:, None]
    G = _legvander(uf, PANEL_NODES - 1) @ rule.coef[jp]
    return _pair_sums(wf, e, w.imag[:, None], G)


def _legvander(x: np.ndarray, deg: int) -> np.ndarray:
    """``np.polynomial.legendre.legvander(x, deg)`` in place, without the temporaries of every
    degree: ``P_i = a_i x P_(i-1) - b_i P_(i-2)``, ``a_i = (2i - 1)/i``, ``b_i = (i - 1)/i``
    (the refined sums spend much of their time here)."""
    v = np.empty((deg + 1, *x.shape))
    v[0] = 1.0
    if deg > 0:
        v[1] = x
        b = np.empty_like(x)
        for i in range(2, deg + 1):
            np.multiply(v[i - 1], x, out=v[i])
            v[i] *= (2 * i - 1) / i
            np.multiply(v[i - 2], (i - 1) / i, out=b)
            v[i] -= b
    return np.moveaxis(v, 0, -1)


def _pair_sums(wt: np.ndarray, a: np.ndarray, z: np.ndarray, G: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Per row n: ``F = sum_f wt k G`` and ``F' = sum_f wt k^2 G`` (``k = 1/(a - i z)`` at the
    row's nodes f, G (n, f, 2) real): one real (4, f) x (f, 2) product per row."""
    K = _kernel_squares(a, z)
    K *= wt[None]
    S = np.moveaxis(K, 0, 1) @ G
    return S[:, 0] + 1j * S[:, 1], S[:, 2] + 1j * S[:, 3]


def _block_sums(rule: Rule, w: np.ndarray, jp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The plain Gauss sums of blocks ``jp`` for targets ``w`` (one block per target)."""
    idx = rule.nodes(jp)
    return _pair_sums(rule.wt[idx], rule.s[idx] - w.real[:, None], w.imag[:, None], rule.G[idx])


def _scatter(F: np.ndarray, it: np.ndarray, values: np.ndarray) -> None:
    """``F[it] += values`` with repeated indices summed (per column and part: bincount)."""
    for c in range(F.shape[1]):
        F[:, c].real += np.bincount(it, values[:, c].real, minlength=F.shape[0])
        F[:, c].imag += np.bincount(it, values[:, c].imag, minlength=F.shape[0])


def _add_far(F: np.ndarray, dF: np.ndarray, parts: list[tuple[Rule, np.ndarray]],
             w: np.ndarray, sel: np.ndarray) -> None:
    """Add the plain Gauss sums of the blocks ``parts`` (``(rule, blocks)`` pairs, summed
    together) for the targets ``sel``."""
    if sel.size:
        idx = [(rule, rule.nodes(blocks).ravel()) for rule, blocks in parts]
        f, df = _far(np.concatenate([rule.s[i] for rule, i in idx]),
                     np.concatenate([rule.wt[i, None] * rule.G[i] for rule, i in idx]), w[sel])
        F[sel] += f
        dF[sel] += df


def _patterns(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct rows of a boolean (n, m) mask and each row's index among them."""
    if mask.shape[1] > 62:  # beyond an int64 code: sort the rows themselves
        keys, group = np.unique(mask, axis=0, return_inverse=True)
        return keys, group.ravel()
    code = np.zeros(mask.shape[0], np.int64)
    for i in range(mask.shape[1]):  # column by column: no (n, m) integer temporary
        code |= mask[:, i].astype(np.int64) << i
    codes, group = np.unique(code, return_inverse=True)
    return (codes[:, None] >> np.arange(mask.shape[1])) & 1 == 1, group.ravel()


def _sub_sums(quad: Quadrature, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Plain Gauss sums, sub-interval by sub-interval: its one coarse block for the targets
    outside the disc that holds its RHO_NEAR ellipse (a smooth sub-interval); for the others,
    per two neighbouring panels their pair block for the targets outside its disc (where it
    agrees with them, ``quad.paired``), else the two panels; the targets that take the same
    blocks are summed together.  Returns F, F' and the (n_targets, n_panels) mask of the
    panels each target took: the RHO_NEAR ellipses of a block's panels lie inside the
    block's, so a pole in a panel's ellipse is in a taken one.
    """
    pan, pairs = quad.panels, quad.pairs
    F = np.zeros((w.size, 2), complex)
    dF = np.zeros_like(F)
    panels_used = np.zeros((w.size, pan.ta.size), bool)
    c, r = _near_discs(quad.coarse)  # the disc holding each coarse block's RHO_NEAR ellipse
    pc, pr = _near_discs(pairs)
    for k in range(quad.smooth.size):
        near = np.abs(w - c[k]) < r[k] if quad.smooth[k] else np.ones(w.size, bool)
        _add_far(F, dF, [(quad.coarse, np.array([k]))], w, np.flatnonzero(~near))
        sel = np.flatnonzero(near)
        js = np.flatnonzero(pan.parent == k)
        ms = np.unique(quad.pair_of[js])
        ms = ms[ms >= 0]
        ms = ms[quad.paired[ms]]
        ws = w[sel]
        far = np.empty((sel.size, ms.size), bool)  # (targets, usable pairs), column by column
        for i, m in enumerate(ms):
            far[:, i] = np.abs(ws - pc[m]) >= pr[m]
        del ws
        keys, group = _patterns(far)
        for g, key in enumerate(keys):
            rows = sel[group == g]
            blocks = js[~np.isin(quad.pair_of[js], ms[key])]
            _add_far(F, dF, [(pairs, ms[key]), (pan, blocks)], w, rows)
            panels_used[rows[:, None], blocks[None, :]] = True
    return F, dF, panels_used


def cauchy(quad: Quadrature, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``F(w)`` and ``F'(w)`` for Im w >= 0 (on the contact surface Re F is the principal
    value, see :func:`principal_values` for an accurate one).

    Plain sums: per sub-interval its coarse block (smooth sub-intervals, targets far from it)
    or, per two neighbouring panels, their pair block or the panels (:func:`_sub_sums`).
    Targets near a panel whose sums they took get that panel's integral on graded sub-panels
    instead.  Every target's value is the same bits in any set of targets.
    """
    return _cauchy(quad, w, np.zeros(w.shape, bool))


def principal_values(quad: Quadrature, x: np.ndarray, e: np.ndarray,
                     axis: np.ndarray) -> np.ndarray:
    """``PV int f(s) / (s - x) ds`` (n, 2) at surface points x: ``Re F + e Im F'`` at the
    lifted ``x + i e`` (``e > 0``, error O(e^2)), but for the targets ``axis`` the panels near
    them integrated on the surface itself (:func:`_graded`, no lift error; the far sums keep
    the lift: they are smooth there).  Every target's value is the same bits in any set of
    targets."""
    F, dF = _cauchy(quad, x + 1j * e, axis)
    return F.real + e[:, None] * dF.imag


def _cauchy(quad: Quadrature, w: np.ndarray, axis: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cauchy`, the near panels of the targets ``axis`` integrated at ``Re w``
    (their F' parts left out)."""
    pan = quad.panels
    F, dF, panels_used = _sub_sums(quad, w)
    upsampled, discs = upsample(pan), _near_discs(pan)
    for i in range(0, w.size, TARGET_CHUNK):
        part = w[i:i + TARGET_CHUNK]
        it, jp, up = _near_pairs(pan, part, discs, lambda it, jp, i=i: panels_used[i + it, jp])
        if it.size:
            new = _near_sums(pan, upsampled, part[it], jp, up, axis[i + it])
            old = _block_sums(pan, part[it], jp)
            _scatter(F[i:i + TARGET_CHUNK], it, new[0] - old[0])
            _scatter(dF[i:i + TARGET_CHUNK], it, new[1] - old[1])
    return F, dF


def _near_sums(rule: Rule, upsampled: tuple, w: np.ndarray, jp: np.ndarray, up: np.ndarray,
               axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_refined` at ``w``, but at ``Re w`` (pole recomputed there) for the pairs
    ``axis``, whose F' is set to 0."""
    if not axis.any():
        return _refined(rule, upsampled, w, jp, up)
    F = np.empty((w.size, rule.G.shape[1]), complex)
    dF = np.zeros_like(F)
    lift = np.flatnonzero(~axis)
    if lift.size:
        F[lift], dF[lift] = _refined(rule, upsampled, w[lift], jp[lift], up[lift])
    on = np.flatnonzero(axis)
    x = w[on].real.astype(complex)
    F[on] = _refined(rule, upsampled, x, jp[on], _poles(rule, x, jp[on]))[0]
    return F, dF
