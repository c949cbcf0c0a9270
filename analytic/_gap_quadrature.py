"""Quadrature of the deformed-gap slope ``g' = W B / pi`` in the gaps, from an edge outwards.

The rigid interconnection (paper Eq. 17) and the deformed gap integrate ``g'`` from a zone edge
towards a target.  Next to the edge ``g'`` carries the edge factor ``t^eps`` of W and varies on
the scale of the edge's clearance (to the nearest other edge, kink or corner), so each integral
is a Gauss-Jacobi sub-interval on that clearance followed by Gauss-Legendre sub-intervals growing
geometrically (ratio GRADING), up to half-way to the end of the edge piece's continuation; plain
Gauss-Legendre beyond.  :func:`plan_gaps` builds the structure (:class:`GapPlan`) once for a
layout; its nodes are affine in a few per-integral lengths, so one plan serves a whole batch of
nearby edge sets (:meth:`analytic._sie.Batch.gap_sums`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from analytic._layout import Layout, sign_from_d
from analytic._rules import GRADING, jacobi_rule, nodes_for
from analytic.profiles import Piece, Profile

FAR_NODES = 48
SUBTRACT_REACH = 2.0
"""Interconnection integrals subtract the edge piece's slope in B (near-singular at the edge)
only up to this many widths of the edge's zone: farther, the zone rule (sized for points a
clearance away) resolves ``B`` without it."""
GAP_SUBTRACT_REACH = 0.0
"""The deformed gap subtracts the edge piece's slope only on the first (Gauss-Jacobi) sub-interval,
one clearance from the edge: beyond, ``H int_L omega/(s - x)`` carries the zone rule's error in
the moments of omega (1e-8 when two zones are 2.7e-5 apart) times ``|W| ~ |x|^(e-n)``, and without
H the zone rule already resolves B (audit seed 103644 vertically, g' vs the Cauchy integral of p,
in A P: 3.6e-8 with H and 7.7e-10 without at one clearance; 2.8e-6 and 7.3e-10 at 18)."""
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
    ``f GRADING^switch`` on (see :func:`plan_gaps`), so its sum there is ``int w'``.
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

    def graded_lengths(self, edges: np.ndarray, x_to: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per integral ``(K, parts)`` for edges ``(K, 2n)``: its edge ``x0``,
        ``D = |x_to - x0|`` and the graded length ``L = min(D, half-way to the end of the edge
        piece's continuation)``."""
        x0 = edges[:, self.edge]
        D = np.abs(x_to - x0)
        return x0, D, np.minimum(D, 0.5 * np.abs(self.reach - x0))

    def first_lengths(self, clearances: np.ndarray, L: np.ndarray) -> np.ndarray:
        """Length ``f`` of the first (Gauss-Jacobi) sub-interval of each graded part, from the
        edges' clearances ``(K, 2n)`` (:func:`edge_clearances`)."""
        return np.minimum(L, clearances[:, self.edge])

    def graded_ends(self, edges: np.ndarray, clearances: np.ndarray, x_to: np.ndarray
                    ) -> np.ndarray:
        """The end of the subtraction in each part ``(K, parts)``: its switch (see
        :func:`plan_gaps`), else the end of the graded part: the target, or the limit half-way
        to the end of the edge piece's continuation."""
        x0, D, L = self.graded_lengths(edges, x_to)
        switched = x0 + self.direction * self.first_lengths(clearances, L) \
            * GRADING ** np.maximum(self.switch, 0)
        return np.where(self.switch >= 0, switched,
                        np.where(L == D, x_to, x0 + self.direction * L))


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

def plan_gaps(layout: Layout, edges: Sequence[float], clearance: Sequence[float],
              pieces: Sequence[Piece], idx: Sequence[int], x_to: Sequence[float],
              subtract_reach: float = math.inf) -> GapPlan:
    """The structure of the integrals from edges ``idx`` to ``x_to``, sized on ``edges`` (with
    their clearances and :func:`edge_pieces`); each target lies in the gap (or the outer region)
    on the outer side of its edge.  The edge piece's slope is subtracted in B (sum ``int g'``)
    up to the first graded boundary at least ``subtract_reach`` widths of the edge's zone away,
    not beyond (sum ``int w'``)."""
    eps = layout.eps.tolist()
    el = list(edges)
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
    return _gap_plan(tuple(structure), tuple(layout.pinned.tolist()))


def edge_pieces(layout: Layout, profile: Profile) -> list[Piece]:
    """Profile piece on the zone side of each edge (its continuation is used near the edge)."""
    el = layout.edges.tolist()
    if profile.global_piece is not None:
        return [profile.global_piece] * len(el)
    width = layout.edge_widths()
    # never past the zone's middle: a zone narrower than the probe step, pinned at a corner,
    # took the piece beyond the corner (g off by the step of h0 there, 0.0585 accepted)
    probes = np.array([x + (1.0 if i % 2 == 0 else -1.0)
                       * min(1e-9 * max(profile.scale, abs(x), 1e-300), 0.5 * w)
                       for i, (x, w) in enumerate(zip(el, width.tolist(), strict=True))])
    ks = profile.piece_index(probes).tolist()
    # a spline's own continuation is only C^2 across its knots (g' integrated over them
    # converged algebraically: gap(x) 6e-9 A P off on audit seed 9); its edge interval's cubic
    # is analytic
    return [profile.pieces[max(k, 0)].analytic_at(x)
            for k, x in zip(ks, probes.tolist(), strict=True)]


def edge_clearances(edges: np.ndarray, profile: Profile) -> np.ndarray:
    """Distance from each edge to the nearest other edge or kink or corner of the profile
    ``(K, 2n)`` for edges ``(K, 2n)`` (sorted; floored at 1e-300; a mark the edge sits on is
    not one): g' varies on that scale next to the edge (a parabolic corner's kink 2e-4 inside
    the zone, its edge's gap integrals sized on the 0.95 to the next edge: gap(x) 1e-3 A P off
    a distance 1 away, audit seed 6)."""
    d = np.maximum(np.diff(edges, axis=1), 1e-300)
    pad = np.full((edges.shape[0], 1), np.inf)
    out = np.minimum(np.concatenate([pad, d], 1), np.concatenate([d, pad], 1))
    marks = np.array([*profile.kinks, *profile.corners], float)
    if marks.size:
        dm = np.abs(edges[:, :, None] - marks[None, None, :])
        out = np.minimum(out, np.min(np.where(dm > 0, dm, np.inf), axis=2))
    return out
