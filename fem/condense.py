"""Condensation of the linear bulk onto the interface (compliance matrix).

With the top of body 1 clamped (its rigid motion is carried by the plate DOFs, a
rigid motion being stress free) and the bottom of body 2 clamped, a pair force
``lam`` (on body 1; ``-lam`` on body 2) produces the relative displacement
``d = u1 - u2 = C lam`` at the candidate pairs, ``C = E^T K^{-1} E`` with
``E = [+I on body-1 pair dofs; -I on body-2 pair dofs]``.

Two ways to get C from ONE factorisation per body:
- CHOLMOD: the bodies are uncoupled in K (block diagonal), so ``C = C1 + C2`` with
  ``C_b = (K_b^{-1})`` on body b's pair dofs. Per body, order the pair dofs last
  (fill-reducing ordering of the rest), factorise ``K_b = L L^T``; the trailing block
  ``L22`` (2n x 2n) of the factor is the Cholesky factor of the Schur complement
  ``S_b = L22 L22^T`` and ``C_b = S_b^{-1}`` is formed in place from it (LAPACK
  ``potri``, no extra sparse solves, no dense block larger than 2n x 2n; ``L22`` is read in
  place from the supernodal factor, ``fem.supernodal``).  A body that is the mirror image of
  the other (``K_2 = D K_1 D``) shares its factor, and ``C = C_1 + D C_1 D`` is block diagonal
  (tangential / normal), its two blocks formed without potri's off-diagonal one
  (:func:`mirror_compliance`).  ``condense_bodies`` hands the bodies' stiffnesses over one by
  one, without the block-diagonal K;
- other backends (or bodies coupled in K): blocked multi-RHS solves ``K^{-1} E``.
All contact iterations then work with the small dense C.

Full-field recovery (``Factor.pair_solve``): a pair load ``f`` is zero off the pair dofs, which
the per-body factor orders last, so the forward solve ``L y = [0; f]`` is ``y = [0; L22^{-1} f]``
(a dense triangular solve with the kept trailing block) and the displacement needs only the
backward sweep ``L^T x = y`` through the sparse factor: half the work of a general solve, one
dense triangular solve for all increments at once, the sweeps by blocks of increments
(multi-RHS, ``RECOVERY_BLOCK``).  ``L22`` is read from the factor in place a panel at a time
(a packed copy, ``2n (2n + 1) / 2`` numbers per body, is kept only for a factor
``fem.supernodal`` cannot read).

Ordering of pair quantities: ``[t_0 .. t_{n-1}, n_0 .. n_{n-1}]`` (tangential x
components first, then normal y components).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import partial

import numpy as np
import scipy.sparse as sp
from scipy.linalg import solve_triangular
from scipy.linalg.blas import dsyrk, dtrmm
from scipy.linalg.lapack import dlauum, dpotri, dtrtri, dtrttp
from scipy.sparse.csgraph import connected_components

from ._heap import return_freed_memory
from .bulk import Discretisation
from .errors import ConvergenceError
from .linsolve import Factor, available_backends, factorize
from .supernodal import trailing_block, trailing_panel

#: Right-hand sides per blocked solve (memory vs BLAS-3 efficiency).
RHS_BLOCK = 256
#: Increments per backward sweep of the recovery (issue 28): the sweep's dense right-hand side
#: and solution, (body dofs x columns) each, are held for one block of increments, not for all
#: (cattaneo rings level 6, 42 increments: 2 x 0.17 GB instead of 2 x 0.45 GB; with blocks of
#: 8 the recovery's peak RSS measured 4.2 GB, below the contact iterations' 5.1 GB).  Narrower
#: blocks cost more sweeps through the factor (level 5 sweep CPU s: all 42 at once 2.3, blocks
#: of 16 2.9, of 8 3.5).  A multiple of 4: CHOLMOD's BLAS takes the columns in groups (of 4 on
#: this project's machine, with OpenBLAS's Prescott and SkylakeX kernels alike), a sweep's
#: last, narrower group with other kernels whose sums differ in the last bits (1e-15 relative);
#: blocks starting at multiples of the group width keep every column in the group it has in
#: the all-at-once sweep, hence its numbers bit for bit (cattaneo rings level 2, 42 increments:
#: blocks of 4, 8, 12, 16, 24, 32, 40 identical; 1, 2, 3, 5, 6, 41 not;
#: tests/unit/test_fem_condense.py).  At level 6 a sweep's cost is proportional to its
#: columns, so wider blocks buy little: CPU ms per column of one sweep of body 1 (1.35M dofs,
#: two runs) 72-74 / 60-61 / 58 / 50-56 / 60-62 with 8 / 16 / 32 / 48 / 84 columns.  At
#: cattaneo ring level 3 (growth 1.35) the sweep's arrays (y and CHOLMOD's two copies of it,
#: body dofs x columns each, handed back after every block) set the process's peak beside the
#: fields: peak RSS 185-188 / 186-191 / 191-196 MB with 8 / 12 / 16 columns (three runs each,
#: alternating); the recovery's CPU 0.24 / 0.21 s (8 / 12, best of four in one process): 8, for
#: issue 28's 4x less memory than the tensor mesh, at 0.03 s of the history's ~0.9 s.
RECOVERY_BLOCK = 8
#: Columns of a body's trailing factor block L22 unpacked at a time by the recovery's
#: triangular solve (:func:`trailing_solve`): a panel of (m x TRIANGLE_PANEL) numbers, not
#: the whole m x m triangle; wide enough for BLAS-3 speed.
TRIANGLE_PANEL = 256
#: Fill-reducing ordering of a body's inner dofs (its pair dofs then go last), of their node
#: graph (:func:`body_order`).  CHOLMOD's orderings on the node graph, cattaneo rings body 1,
#: CPU s of the ordering (Python and CHOLMOD's analysis) + numeric factorisation, two runs each
#: on the shared machine (SkylakeX kernels), factorisation flops (sum of squared column counts):
#:   level (dofs)  nesdis                  metis                   amd
#:   3 (77k)       .27-.39 + .25-.45 2.2G  .23-.25 + .27-.29 2.2G  .06-.10 + .31-.36 3.8G
#:   4 (200k)      .69-.91 + .80-.85 11.5G .67-.77 + .84-1.27 11.6G .18-.28 + 1.00-1.45 18.6G
#:   5 (513k)      2.09-2.23 + 2.8-3.1 65G 1.85-1.87 + 3.0-3.1 67G .52-.65 + 4.0-4.1 111G
#:   6 (1.35M)     7.0-7.6 + 12.2-12.3 411G 6.1-6.6 + 13.4-14.3 424G 1.8-2.3 + 17.2-24.2 643G
#: (the trailing block's potri, 0.05 / 0.20 / 1.11 / 7.7 s at levels 3-6, does not depend on
#: it).  No other ordering saves the >= 2 s at level 6 that would pay for moving every FE
#: number in its last bits: AMD orders 5 s faster but its factor costs 1.6x the flops (5-12 s
#: more; in total 19.0-26.4 s against nesdis' 19.2-19.8) and holds 1.27x the entries (323M
#: against 255M: the memory and the recovery's sweeps), METIS orders 0.6-0.9 s faster and
#: factorises 1-2 s slower.  AMD (CHOLMOD's default)
#: below NESDIS_MIN_DOFS free dofs of the body (level 2: 32k dofs; at level 3 AMD would save
#: 0.1-0.3 s, nesdis is kept there for the same reason).
INNER_ORDERING, NESDIS_MIN_DOFS = "nesdis", 50_000
#: Body 2's stiffness is taken as the mirror image of body 1's (one factorisation for both,
#: issue 28) when they agree to this relative to the largest entry, a backward error of the
#: size of the factorisation's own: the generated meshes' (both layouts, fem.mesh.mirror_body)
#: mirrored assembly differs by a few ulps (measured on the rings: 5.4e-16 / 4.3e-16 / 1.9e-15
#: of max |K| at cattaneo levels 0 / 1 / 4).
MIRROR_RTOL = 1e-13
#: Couplings below this (relative to max |K|) are zero up to rounding (x-y couplings that
#: cancel by symmetry: +-4e-16 of max |K|): their signs are not read.
MIRROR_SIGNIFICANT = 1e-8


def pair_dofs(
    disc: Discretisation, index: np.ndarray, cand: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Free-dof indices of body-1 and body-2 pair dofs, ordered [t..., n...]."""
    n1 = disc.bases[0].N
    s1, s2 = disc.interface.dof1[cand], disc.interface.dof2[cand]
    g1 = np.r_[2 * s1, 2 * s1 + 1]
    g2 = np.r_[2 * s2, 2 * s2 + 1] + n1
    return index[g1], index[g2]


def pair_loads(n_free: int, f1: np.ndarray, f2: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Free-dof load vectors (columns) of pair forces lam (+lam on body 1, -lam on body 2)."""
    lam = np.atleast_2d(lam.T).T
    F = np.zeros((n_free, lam.shape[1]))
    F[f1] += lam
    F[f2] -= lam
    return F


def condense(
    K: sp.csc_matrix, f1: np.ndarray, f2: np.ndarray, backend: str = "auto"
) -> tuple[Factor, np.ndarray]:
    """Factorise K once and return the factor and the pair compliance C.  With CHOLMOD and
    uncoupled bodies K is cut into its body blocks and dropped before the factorisations (a
    caller that passes a temporary K does not keep it beside the factors: issue 28)."""
    if backend == "auto":
        backend = available_backends()[0]
    if backend == "cholmod":
        blocks = body_blocks(K, f1, f2)
        if blocks is not None:
            n = K.shape[0]
            bodies = [(K[idx][:, idx].tocsc(), idx, np.searchsorted(idx, pairs))
                      for idx, pairs in zip(blocks, (f1, f2), strict=True)]
            del K
            return schur_cholmod(bodies, n)
    factor = factorize(K, backend)
    return with_pair_loads(factor, f1, f2), compliance(factor, f1, f2)


def condense_bodies(bodies: list, f1: np.ndarray, f2: np.ndarray, backend: str = "auto"
                    ) -> tuple[Factor, np.ndarray]:
    """``condense(K, f1, f2, backend)`` of the block-diagonal K of ``bodies`` (each body's
    stiffness on its own free dofs, body 1's first: ``fem.bulk.reduced_bodies``), the same
    numbers, without the whole K when CHOLMOD takes the bodies one by one (issue 28: at level
    6 the block-diagonal K and a second round of index copies had cost about 15 s and a
    K-sized copy beside the bodies').  ``bodies`` is emptied: the factorisation owns the
    matrices and drops each once it is factorised."""
    if backend == "auto":
        backend = available_backends()[0]
    K1, K2 = bodies
    bodies.clear()
    n1 = K1.shape[0]
    if (backend == "cholmod" and f1.max() < n1 <= f2.min()
            and connected_components(K1, directed=False, return_labels=False) == 1):
        idx1, idx2 = np.arange(n1), np.arange(n1, n1 + K2.shape[0])
        parts = [(K1, idx1, f1), (K2, idx2, f2 - n1)]
        del K1, K2
        return schur_cholmod(parts, n1 + idx2.size)
    K = sp.block_diag((K1, K2), format="csc")
    del K1, K2
    return condense(K, f1, f2, backend)


def with_pair_loads(factor: Factor, f1: np.ndarray, f2: np.ndarray) -> Factor:
    """The factor with ``pair_solve`` as a general solve of the pair loads."""

    def pair_solve(lam: np.ndarray, out: np.ndarray | None = None,
                   rows: np.ndarray | None = None, add: bool = False) -> np.ndarray:
        x = factor.solve(pair_loads(factor.n, f1, f2, lam))
        if out is None:
            return x
        place(out, np.arange(factor.n) if rows is None else rows, x, add)
        return out

    return replace(factor, pair_solve=pair_solve)


def place(out: np.ndarray, index, x: np.ndarray, add: bool) -> None:
    """``out[index] = x``, or ``+= x`` with ``add`` (a pair solve onto fields that hold the far
    field already; ``index`` selects each entry once)."""
    if add:
        out[index] += x
    else:
        out[index] = x


def pair_target(n: int, lam: np.ndarray, out: np.ndarray | None, rows: np.ndarray | None):
    """``(out, rows)`` of a pair solve: the solution's dof i goes to ``out[rows[i]]``
    (default: a new (n, k) array, ``rows`` the identity)."""
    if out is None:
        out = np.empty((n, lam.shape[1]))
    return out, np.arange(n) if rows is None else rows


def compliance(factor: Factor, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Relative-displacement compliance C (symmetric) by blocked multi-RHS solves."""
    m = f1.size
    C = np.empty((m, m))
    for start in range(0, m, RHS_BLOCK):
        cols = np.arange(start, min(start + RHS_BLOCK, m))
        E = np.zeros((m, cols.size))
        E[cols, np.arange(cols.size)] = 1.0
        U = factor.solve(pair_loads(factor.n, f1, f2, E))
        C[:, cols] = U[f1] - U[f2]
    return 0.5 * (C + C.T)


def body_blocks(K: sp.csc_matrix, f1: np.ndarray, f2: np.ndarray):
    """Free dofs of body 1 (the connected blocks of K holding f1) and of the rest, or None if
    some block holds pair dofs of both sides (the bodies are coupled in K)."""
    _, labels = connected_components(K, directed=False)
    l1 = np.unique(labels[f1])
    if np.isin(labels[f2], l1).any():
        return None
    in1 = np.isin(labels, l1)
    return np.flatnonzero(in1), np.flatnonzero(~in1)


def schur_cholmod(bodies: list, n: int) -> tuple[Factor, np.ndarray]:
    """CHOLMOD factor per body with its pair dofs ordered last; C from the trailing blocks.
    ``bodies``: ``[(Kb, idx, local), ...]`` for body 1 and the rest (the body's stiffness, its
    free dofs in K of size n, the local indices of its pair dofs); emptied as it is used: a
    mirror body's stiffness is dropped once checked, a body's own once factorised (before its
    trailing block is read, issue 28)."""
    (K1, idx1, local1), (K2, idx2, local2) = bodies
    signs = mirror_signs(K1, K2, local1, local2)
    split = None
    if signs is not None:  # the mirror image of body 1: its factor, C_2 = D C_1 D
        bodies[1] = (None, idx2, local2)
        split = sign_split(signs[local1])
    del K1, K2
    parts, C = [], None
    for b in range(len(bodies)):
        Kb, idx, local = bodies[b]
        bodies[b] = None
        if Kb is None:
            parts.append((idx, *parts[0][1:4], signs))
            if split is None:  # else C holds C_1 + D C_1 D already
                flip_add(C, signs[local])
            continue
        perm = body_order(Kb, local)
        Kb = Kb[perm][:, perm].tocsc()  # the permuted copy replaces the body's own (issue 28)
        return_freed_memory()  # the body's own and the ordering's temporaries
        chol = natural_cholesky(Kb)
        del Kb
        Cb, packed = trailing_compliance(chol, idx.size, local.size, split if b == 0 else None)
        parts.append((idx, perm, chol, panel_reader(chol, idx.size, local.size, packed), None))
        C = Cb if C is None else np.add(C, Cb, out=C)
        del Cb
    mirror_lower(C)

    def solve(b: np.ndarray) -> np.ndarray:
        return body_solves(parts, np.asarray(b, dtype=float))

    def pair_solve(lam: np.ndarray, out: np.ndarray | None = None,
                   rows: np.ndarray | None = None, add: bool = False) -> np.ndarray:
        lam = np.atleast_2d(np.asarray(lam, dtype=float).T).T
        out, rows = pair_target(n, lam, out, rows)
        for (idx, perm, chol, panels, signs), sign in zip(parts, (1.0, -1.0), strict=True):
            d = None if signs is None else signs[perm][:, None]  # a mirror: K_2^-1 = D K_1^-1 D
            return_freed_memory()  # what the caller freed (the far field's basis), beneath
            z = trailing_solve(panels, sign * lam if d is None else sign * d[-lam.shape[0]:] * lam)
            target = rows[idx[perm]]
            return_freed_memory()  # the panels: y's array comes fresh (untouched above z)
            work = np.zeros((idx.size, min(RECOVERY_BLOCK, lam.shape[1])), order="F")
            for cols in column_blocks(lam.shape[1], RECOVERY_BLOCK):
                x = backward_solve(chol, z[:, cols], idx.size, work)
                if d is not None:
                    x *= d
                place(out, (target, cols), x, add)
                del x
                return_freed_memory()  # CHOLMOD's two copies: one block's at a time
            del work
        return out

    return Factor(backend="cholmod", solve=solve, n=n, pair_solve=pair_solve), C


def body_solves(parts: list, b: np.ndarray) -> np.ndarray:
    """``K^{-1} b`` body by body (``parts`` as :func:`schur_cholmod` builds them).  A mirror
    body's right-hand sides (``D b``, D = diag of its signs) join its original's in one
    multi-RHS solve with the shared factor: one pass through the factor instead of two
    (issue 28: the far-field lift's solves at level 6), the right-hand sides gathered straight
    into one array in CHOLMOD's (column-major) layout."""
    cols = b.reshape(b.shape[0], -1)
    out = np.empty_like(cols)
    k = cols.shape[1]
    if parts[-1][4] is not None:  # body 2 the mirror image of body 1: one factor, one pass
        (idx1, perm, chol, _, _), (idx2, _, _, _, signs) = parts
        d = signs[perm][:, None]
        rhs = np.empty((perm.size, 2 * k), order="F")
        rhs[:, :k] = cols[idx1[perm]]
        rhs[:, k:] = cols[idx2[perm]] * d
        x = chol(rhs)
        del rhs
        out[idx1[perm]] = x[:, :k]
        out[idx2[perm]] = x[:, k:] * d
        return out.reshape(b.shape)
    for idx, perm, chol, _, _ in parts:
        out[idx[perm]] = chol(cols[idx[perm]])
    return out.reshape(b.shape)


def column_blocks(k: int, width: int) -> list[slice]:
    """k columns cut into consecutive slices of ``width`` columns from column 0 (the last one
    shorter when width does not divide k)."""
    return [slice(j, min(j + width, k)) for j in range(0, k, width)]


def trailing_solve(panels: Callable[[int, int], np.ndarray], f: np.ndarray) -> np.ndarray:
    """``L22^{-1} f`` for loads f (columns) on a body's m trailing dofs, ``L22`` (m x m lower
    triangular) read one panel of TRIANGLE_PANEL columns at a time (``panels(c0, c1)``: rows
    c0.. of columns c0..c1-1, :func:`panel_reader`): the panel's diagonal block solved, the
    rows below updated (a right-looking forward substitution, dtrsm's own scheme with
    another blocking).  No m x m copy (issue 28: 9.8 MB beside the recovered fields at
    cattaneo ring level 3, 0.6 GB at level 6); the numbers are dtrsm's on the whole L22 to
    rounding."""
    m = f.shape[0]
    z = np.array(f, dtype=float, order="F")
    for c0 in range(0, m, TRIANGLE_PANEL):
        c1 = min(c0 + TRIANGLE_PANEL, m)
        panel = panels(c0, c1)
        z[c0:c1] = solve_triangular(panel[:c1 - c0], z[c0:c1], lower=True, check_finite=False)
        if c1 < m:
            z[c1:] -= panel[c1 - c0:] @ z[c0:c1]
    return z


def panel_reader(chol, n: int, m: int, packed: np.ndarray | None
                 ) -> Callable[[int, int], np.ndarray]:
    """The panels of a body's L22 for :func:`trailing_solve`: read in place from its factor
    ``chol`` (n x n, m pair dofs last; ``fem.supernodal.trailing_panel``), or from ``packed``
    (LAPACK's packed lower storage, :func:`packed_panel`) for a factor that module cannot
    read (:func:`trailing_compliance` keeps a copy only then)."""
    if packed is not None:
        return partial(packed_panel, packed, m)

    def read(c0: int, c1: int) -> np.ndarray:
        panel = trailing_panel(chol, n, m, c0, c1)
        if panel is None:
            raise ConvergenceError("recovery: the factor's trailing block, read in place when "
                                   "the compliance was formed, can no longer be read")
        return panel

    return read


def packed_panel(packed: np.ndarray, m: int, c0: int, c1: int) -> np.ndarray:
    """Rows c0..m-1 of columns c0..c1-1 of the lower triangular m x m matrix stored in
    ``packed`` (LAPACK's packed lower storage: column j's entries j..m-1 after those of the
    columns before it, from ``j m - j (j - 1) / 2``), zeros above the diagonal, Fortran order."""
    panel = np.zeros((m - c0, c1 - c0), order="F")
    for j in range(c0, c1):
        start = j * m - j * (j - 1) // 2
        panel[j - c0:, j - c0] = packed[start:start + m - j]
    return panel


def backward_solve(chol, z: np.ndarray, n: int, work: np.ndarray | None = None) -> np.ndarray:
    """``x = K_b^{-1} [0; f]`` (the body's permuted order, n dofs) from ``z = L22^{-1} f``
    (:func:`trailing_solve`) of loads f (columns) on the m trailing dofs: ``L^T x = y`` with
    ``y = [0; z]`` (no forward sweep).  ``work``: y's array for the blocks of a sweep (n rows,
    at least as many columns as z, Fortran order, zero above its last m rows, which are
    overwritten; CHOLMOD reads it and copies it), None: a new one."""
    k = z.shape[1]
    y = np.zeros((n, k), order="F") if work is None else work[:, :k]  # CHOLMOD's layout
    y[-z.shape[0]:] = z
    return chol.solve_Lt(y, use_LDLt_decomposition=False)


def mirror_signs(K1: sp.csc_matrix, K2: sp.csc_matrix, g1: np.ndarray, g2: np.ndarray
                 ) -> np.ndarray | None:
    """Signs d (+-1 per dof) with ``K2 = D K1 D`` (D = diag d) to MIRROR_RTOL, the pair dofs in
    the same places (``g1 == g2``), or None.  A body meshed as the mirror image of the other
    (y -> -y, same numbering) is one: d flips its y dofs.  d is read off the signs of
    ``K2 / K1`` (``d_i d_j``) where K1 is not zero up to rounding (MIRROR_SIGNIFICANT): the
    dofs joined by same-sign couplings form at most two classes (the x and the y dofs), +1 on
    the class of dof 0."""
    if K1.shape != K2.shape or not np.array_equal(g1, g2) or not (
            np.array_equal(K1.indptr, K2.indptr) and np.array_equal(K1.indices, K2.indices)):
        return None
    a1, a2 = K1.data, K2.data
    mag = np.abs(a1)
    scale = np.max(mag, initial=0.0)
    same = mag > MIRROR_SIGNIFICANT * scale  # couplings zero up to rounding: no sign
    del mag
    same &= ((a1 > 0) & (a2 > 0)) | ((a1 < 0) & (a2 < 0))  # d_i d_j = +1
    graph = sp.csc_matrix((same.view(np.int8), K1.indices, K1.indptr), shape=K1.shape,
                          copy=True)
    del same
    graph.eliminate_zeros()  # csgraph takes stored zeros as edges
    count, labels = connected_components(graph, directed=False)
    del graph
    if count > 2:
        return None
    d = np.where(labels == labels[0], 1.0, -1.0)
    err = np.repeat(d, np.diff(K1.indptr))  # d_j d_i K1_ij, exact (d = +-1), then the error
    err *= d[K1.indices]
    err *= a1
    np.subtract(a2, err, out=err)
    np.abs(err, out=err)
    return d if np.all(err <= MIRROR_RTOL * scale) else None


def flip_add(C: np.ndarray, d: np.ndarray) -> None:
    """``C += D C D`` in place (D = diag d, d = +-1) on the lower triangle, by row blocks: the
    compliance of a mirror body added to its original's (the lower triangle potri left; the
    strict upper one, left as it is, is :func:`mirror_lower`'s to fill)."""
    m = C.shape[0]
    for r0 in range(0, m, RHS_BLOCK):
        r1 = min(r0 + RHS_BLOCK, m)
        C[r0:r1, :r1] *= 1.0 + d[r0:r1, None] * d[None, :r1]


def body_order(Kb: sp.csc_matrix, gamma: np.ndarray) -> np.ndarray:
    """The elimination order of one body: INNER_ORDERING (CHOLMOD's fill-reducing ordering)
    of its dofs off ``gamma``, then the pair dofs ``gamma`` last.  The ordering is of the
    graph of :func:`dof_groups` (a node's x and y dofs together: half the vertices, a quarter
    of the edges), each group's dofs kept together in their own order; only the ordering is
    computed (CHOLMOD's simplicial analysis, no supernodal symbolic factorisation).
    (Measured on cattaneo rings body 1, numeric factorisation CPU s / supernodal entries at
    levels 4 / 5, on OpenBLAS's Prescott fallback kernels (before ``fem.linsolve``'s
    import_cholmod): this order 1.3 / 6.4 s, 27M / 80M; CHOLMOD's constrained minimum degree
    (camd, gamma last) 1.7 / 9.7 s, 32M / 93M; nested dissection of the whole body with gamma
    moved last 1.9 / 6.8 s, 27M / 81M; METIS of the whole body so 1.5 / 6.6 s, 27M / 81M.
    The node graph instead of the dof graph: the same supernodal entries 26.7M / 80.0M / 255M
    and factorisation flops 11.7G / 65.3G / 412G at levels 4 / 5 / 6; ordering CPU s
    0.90 / 2.7 / 9.0 -> 0.69 / 2.2 / 6.9.  The orderings of the node graph compared at levels
    3-6 with the CPU's kernels: beside INNER_ORDERING.)"""
    from sksparse.cholmod import analyze

    if not Kb.has_sorted_indices:
        Kb = Kb.sorted_indices()
    gid = dof_groups(Kb, gamma)
    first = np.flatnonzero(np.r_[True, gid[1:] != gid[:-1]])
    inner = np.setdiff1d(np.arange(first.size), gid[gamma])
    graph = group_graph(Kb, gid, first)[inner][:, inner].tocsc()
    method = INNER_ORDERING if Kb.shape[0] >= NESDIS_MIN_DOFS else "default"
    order = inner[analyze(graph, mode="simplicial", ordering_method=method).P()]
    size = np.diff(np.r_[first, Kb.shape[0]])[order]
    return np.r_[concat_ranges(first[order], size), gamma]


def dof_groups(Kb: sp.csc_matrix, gamma: np.ndarray) -> np.ndarray:
    """Group number of each dof (non-decreasing): runs of consecutive dofs with the same
    sparsity pattern in ``Kb`` (sorted indices) and on the same side of ``gamma`` — a node's
    x and y dofs when both are free (an elastic node couples both to the same nodes)."""
    n = Kb.shape[0]
    ptr, ind = Kb.indptr, Kb.indices
    count = np.diff(ptr)
    on_gamma = np.zeros(n, dtype=bool)
    on_gamma[gamma] = True
    same = (count[:-1] == count[1:]) & (on_gamma[:-1] == on_gamma[1:])  # dof i + 1 joins i
    if n > 1 and same.any():
        m = int(ptr[n - 1])  # the entries of columns 0 .. n-2, each against the entry
        wide = np.int32 if 2 * ind.size < np.iinfo(np.int32).max else np.int64
        ahead = np.repeat(count[:-1].astype(wide), count[:-1])  # count[i] further on
        ahead += np.arange(m, dtype=wide)  # (column i + 1's entry when the counts agree)
        np.minimum(ahead, ind.size - 1, out=ahead)  # past the end only where counts differ
        eq = ind[:m] == ind[ahead]
        del ahead
        full = np.flatnonzero(count[:-1])  # reduceat takes no empty segment
        same[full] &= np.logical_and.reduceat(eq, ptr[full])
    return np.r_[0, np.cumsum(~same)]


def group_graph(Kb: sp.csc_matrix, gid: np.ndarray, first: np.ndarray) -> sp.csc_matrix:
    """The pattern of ``Kb`` between the groups of :func:`dof_groups` (group g's column: its
    first dof's column, rows mapped to their groups; every dof of a group has that pattern)."""
    ptr = Kb.indptr
    lens = np.diff(ptr)[first]
    at = concat_ranges(ptr[first], lens)
    rows, cols = gid[Kb.indices[at]], np.repeat(np.arange(first.size), lens)
    keep = np.r_[True, (rows[1:] != rows[:-1]) | (cols[1:] != cols[:-1])]
    indptr = np.r_[0, np.cumsum(np.bincount(cols[keep], minlength=first.size))]
    return sp.csc_matrix((np.ones(keep.sum()), rows[keep], indptr), shape=(first.size,) * 2)


def concat_ranges(starts: np.ndarray, lens: np.ndarray) -> np.ndarray:
    """The integer ranges ``[starts_i, starts_i + lens_i)`` one after the other (the entries
    of chosen CSC columns, the dofs of ordered groups)."""
    return np.repeat(starts - (np.cumsum(lens) - lens), lens) + np.arange(lens.sum())


def natural_cholesky(Kp: sp.csc_matrix):
    """CHOLMOD factor of ``Kp`` in its own order (already permuted by :func:`body_order`)."""
    from sksparse.cholmod import cholesky

    return cholesky(Kp, ordering_method="natural")


def trailing_compliance(chol, n: int, m: int, split: int | None = None
                        ) -> tuple[np.ndarray, np.ndarray | None]:
    """``(C_b, packed)`` from a body's factor (n x n) with its m pair dofs last: ``C_b =
    (Kb^{-1})[gamma][:, gamma] = S^{-1}`` from the trailing factor block ``L22``
    (``S = L22 L22^T``, the Schur complement on gamma) by LAPACK potri.  With ``split``
    (:func:`sign_split` of a mirror body's signs) ``C_b + D C_b D`` instead, by
    :func:`mirror_compliance`.  Lower triangles only.  ``L22`` is read in place from the
    supernodal factor (``fem.supernodal``), where the recovery reads it again panel by panel
    (``packed`` None: no copy of it is kept, issue 28: 4.9 MB at cattaneo ring level 3, 0.3 GB
    at level 6); only a factor that module cannot read goes through ``chol.L()``, a converted
    copy of the whole factor (level 6's peak memory before issue 28), and ``packed`` is then
    ``L22`` packed (lower, LAPACK ``trttp``) for the recovery."""
    L22, packed = trailing_block(chol, n, m), None
    if L22 is None:
        L22 = np.asfortranarray(chol.L()[-m:, -m:].toarray())
        packed, info = dtrttp(L22, uplo="L")
        if info != 0:
            raise ConvergenceError(f"compliance of a body: LAPACK trttp failed (info={info})")
    if split is not None:
        return mirror_compliance(L22, split), packed
    Cb, info = dpotri(L22, lower=1, overwrite_c=1)
    if info != 0:
        raise ConvergenceError(f"compliance of a body: LAPACK potri failed (info={info})")
    return Cb, packed


def sign_split(d: np.ndarray) -> int | None:
    """k if the signs d (+-1) are one sign on their first k entries and the other on the rest
    (0 < k < d.size), else None: a mirror body's pair dofs ``[t..., n...]`` (y -> -y flips
    the n dofs), on which ``C_1 + D C_1 D`` is block diagonal (``1 + d_i d_j = 0`` between the
    blocks)."""
    k = int(np.argmax(d != d[0])) if d.size else 0
    return k if k > 0 and np.all(d[k:] == -d[0]) else None


def mirror_compliance(L22: np.ndarray, k: int) -> np.ndarray:
    """``C_b + D C_b D = 2 diag(X_11, X_22)`` on its lower triangle, in place of ``L22``
    (Fortran order, as potri; D = +1 on the first k pair dofs, -1 on the rest or the reverse;
    ``X = S^{-1}``, ``S = L22 L22^T``), without the off-diagonal block of X that potri would
    compute only for it to cancel (issue 28: 5.3 -> 4.3 n^3 flops for m = 2n; m = 8778, the
    cattaneo rings level 6, one BLAS thread: 7.4-7.6 s CPU -> 5.6-6.2 s).  With ``L22 =
    [[L11, 0], [L21, L22']]``, ``A = L11^{-1}``, ``E = L22'^{-1}``: ``X_22 = E^T E`` and
    ``X_11 = A^T A + B^T B``, ``B = -E L21 A`` (LAPACK trtri, lauum, BLAS trmm, syrk; the
    strict upper triangle is left to :func:`mirror_lower`).  Besides ``L22`` it holds three
    blocks of a quarter of its size (A, E, B) at a time."""
    A, info_a = dtrtri(L22[:k, :k], lower=1, overwrite_c=1)
    E, info_e = dtrtri(L22[k:, k:], lower=1, overwrite_c=1)
    if info_a != 0 or info_e != 0:
        raise ConvergenceError(f"compliance of a body: LAPACK trtri failed "
                               f"(info={info_a}, {info_e})")
    B = dtrmm(1.0, A, L22[k:, :k], side=1, lower=1)  # L21 A
    B = dtrmm(-1.0, E, B, side=0, lower=1, overwrite_b=1)  # -E L21 A
    C = L22  # its blocks are copied out: the result goes in its place
    C[k:, :k] = 0.0
    X, info = dlauum(E, lower=1, overwrite_c=1)  # E^T E
    if info != 0:
        raise ConvergenceError(f"compliance of a body: LAPACK lauum failed (info={info})")
    np.multiply(X, 2.0, out=C[k:, k:])
    del E, X
    X, info = dlauum(A, lower=1, overwrite_c=1)  # A^T A
    if info != 0:
        raise ConvergenceError(f"compliance of a body: LAPACK lauum failed (info={info})")
    X = dsyrk(1.0, B, beta=1.0, c=X, trans=1, lower=1, overwrite_c=1)  # + B^T B
    np.multiply(X, 2.0, out=C[:k, :k])
    return C


def mirror_lower(A: np.ndarray) -> None:
    """Copy the strict lower triangle of the square A onto its upper one, in place, by row
    blocks (potri fills the lower triangle only; the upper one of L22 is zero)."""
    m = A.shape[0]
    for r0 in range(0, m, RHS_BLOCK):
        r1 = min(r0 + RHS_BLOCK, m)
        A[r0:r1, r1:] = A[r1:, r0:r1].T
        d = A[r0:r1, r0:r1]
        d[np.triu_indices(r1 - r0, 1)] = d.T[np.triu_indices(r1 - r0, 1)]
