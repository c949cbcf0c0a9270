"""Linear systems of the active-set (semi-smooth Newton) iterations by low-rank updates.

For fixed sets (open / stick / slip with its sign) the contact laws and the plate
equilibrium are one linear system in ``x = [lam_t (n), lam_n (n), z (n_plate)]`` of the
fixed size ``N = 2n + n_plate``, row by row (``fem.contact``; d = C lam + B z):

- tangential row j: stick ``d_t,j + lam_t,j / (w_j k_t) = lam_old,j / (w_j k_t) + d_old,j``;
  slip ``lam_t,j - mu s_j lam_n,j = 0``; open ``c_j lam_t,j = 0``;
- normal row j: active ``d_n,j + lam_n,j / (w_j k_n) = pbar_j / k_n - h0_j``;
  open ``c_j lam_n,j = 0``;
- plate rows: ``sum lam_t = -Q`` (``z_0 = z_0,old`` if no pair sticks), ``sum lam_n = P``,
  ``sum x lam_n = M`` (rotation free only).

(``c_j``: the diagonal of C, so that an open row is scaled like the others.)  On the active
pairs this is the system of ``fem.contact.active_system``; the open rows only say
``lam = 0`` there.  A Newton step changes the rows of the few pairs whose status changed, so
the system of every iteration is a row update of a *reference* system factorised earlier:
``A = A0 + E_J (A[J] - A0[J])`` with ``J`` the rows that differ.  With ``W = A0^{-1} E_J``
(cached, column by column) the solution is

    x = x0 - W (A[J] W)^{-1} (A[J] x0 - b[J]),    x0 = A0^{-1} b

(Sherman-Morrison-Woodbury; ``A[J] W`` is the small capacitance matrix, ``A0[J] W = I``).
``x0`` may solve any ``b'`` equal to b outside J instead of b itself (``A0 x0`` then differs
from b only in J, which the update corrects): the reference's own right-hand side for the same
load and history is such a b', so one solve serves all Newton systems of an increment.
A0 is block triangular in (active, open) ordering, ``[[A11, A12], [0, diag(c)]]``, so only
its active block A11 (the reference active system) is LU-factorised.  Between mirror-image
bodies (elastically similar, mirrored meshes: the generated ones) C's tangential-normal blocks
are zero (``InterfaceProblem.split``; a tangential pair force opens no normal gap), so the
normal rows and the P, M rows involve only ``lam_n``, ``v_p`` and theta, and the tangential
rows read ``lam_n`` only through the slip rows: A11 is block triangular too, and its normal
block and the sticking pairs' tangential block (``lam_t``, ``u_p``) are factorised apart, the
slip rows ``lam_t = b + mu s lam_n`` solved between them (LUs of half the size or less: a
quarter of the work or less), and the products with C skip the zero blocks; a block's solve
skips the zero columns of its right-hand side (the columns ``A0^{-1} e_j`` of tangential rows
j have no normal part).  Cost per iteration:
one solve with the reference factors (the refinement's; the first is shared by the
increment), products with the active columns of C (``O(n n_active)``: the refinement's
residual and ``d``), products with W and the dense rows of ``A[J]`` (``O(r N)``), one more
solve per newly changed row (cached per reference), ``O(dr r N)`` for the capacitance matrix
S when dr rows of J change (:class:`Update` keeps J, W, ``A[J]`` and ``A[J] W`` between
systems) and solves with S: a bordered solve with the LU of an earlier S of the reference,
``O(k r^2)`` for the k rows that entered, left or changed kind since (:class:`Bordered`), or
a fresh LU, ``O(r^3)``, when k exceeds :data:`BORDER_FRACTION` of r; instead of an
``O(N_active^3)`` factorisation.  Cattaneo rings level 6 (n = 4389, 91 Newton systems,
r = 487 on average, at most ~1200), cProfile of the increments (8.0 s): the new W columns
1.6 s, the 9 reference LUs 1.1 s, the products with C 2.0 s (``d`` and the residuals), the
products with W and ``A[J]`` 1.6 s, S 0.5 s (43 fresh LUs, 48 bordered systems; 0.8 s with
a fresh LU every system); the bordered solves and the zero columns took the increments from
9.3 to 8.4 s CPU at level 6 (medians of 4, old and new alternating in one process; spreads
8.4-11.2 and 7.3-10.4 s), from 2.3 to 2.1 s at level 5 (medians of 5, within the noise),
0.41 to 0.40 s at level 4.  A new reference
is factorised only when the rank ``r = |J|`` exceeds :data:`REFACTOR_FRACTION` of the active
system's size.  A small pool of references (:data:`POOL`) serves the two kinds of matrices
of a history: the elastic predictor (previously active pairs stick; after a change of stage
or a reversal) and the converged-type sets (with slip; the secant predictor's guesses are
near them).
One step of iterative refinement with the exact matrix follows every solve (as with the dense LU
before: the penalty terms 1/(w k) next to a stiff compliance need it).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import LinAlgWarning, lu_factor, lu_solve

if TYPE_CHECKING:
    from .contact import InterfaceProblem, Load

#: Pair status (``fem.contact``).
OPEN, STICK, SLIP = 0, 1, 2

#: A new reference factorisation is made when more rows than this fraction of the current
#: active system's size (and more than REFACTOR_MIN_RANK) differ from every reference
#: (cattaneo level 3, n = 583, 204 Newton systems: 15 / 7 / 5 factorisations and 1.16 /
#: 1.39 / 1.71 s CPU at 1/8, 1/4, 1/2; the factorisations grow like N^3, the capacitance
#: work like r^2 N).  Re-measured with the decoupled references, the bordered capacitance
#: solves and the zero-column solves (cattaneo rings, CPU s of the increments, in one process
#: each level, median of 3 (level 6: mean of 2), the reference factorisations in brackets):
#:
#:   level (n)  run   1/16        1/8         1/4         3/8         1/2
#:   4 (1150)    a      -        0.55 (13)   0.49 (8)      -        1.00 (5)
#:   5 (2238)    a      -        1.72 (13)   1.55 (8)      -        2.85 (5)
#:   5 (2238)    b   2.22 (22)   2.00 (13)   1.81 (8)   2.05 (7)      -
#:   6 (4389)    a      -        8.29 (13)   8.52 (9)      -       16.2 (5)
#:   6 (4389)    b   10.5 (22)   8.23 (13)   7.66 (9)   9.36 (7)      -
#:
#: (runs a and b at different machine loads): a quarter stays the best or level with an
#: eighth; beyond it the updates' O(r N) products and new W columns outgrow the references
#: they save, below it the references cost more than they save.
REFACTOR_FRACTION = 0.25
#: Below this rank an update is always used (tiny systems: factorising is cheap anyway).
REFACTOR_MIN_RANK = 8
#: Above this many (row run, column run) blocks a product with C gathers a copy instead.
MAX_BLOCKS = 64
#: A row of J with at most this many entries (slip: lam_t and lam_n; open: lam) enters the
#: capacitance matrix through the entries of W it picks, not a product over all columns.
SPARSE_ROW = 2
#: Rows of C gathered at a time into a reference's active block (a 5600^2 block of cattaneo
#: rings level 6: 0.15 s in blocks of 256 rows, 0.4 s in one gather through a 250 MB copy).
GATHER_ROWS = 256
#: Reference factorisations kept (predictor-type and converged-type sets of an increment).
POOL = 2
#: The capacitance matrix S of a system is solved by a bordered solve with the LU of an
#: earlier S of the same reference (its base, :class:`Capacitance`) while the border (rows of J
#: that entered, left or changed kind since the base) is at most this fraction of |J|; beyond
#: it S is factorised afresh and becomes the base (cattaneo rings, CPU s in S's LUs and
#: solves over the increments, fresh LU every system / 1/8 / 1/4: level 6 (91 systems,
#: mean |J| 487) 0.86, 0.69 / 0.50, 0.59 / 0.62, 0.55 (two runs); level 5 0.15 / 0.14 /
#: 0.13 of ~2 s, 1/16 and 1/2 alike).
BORDER_FRACTION = 0.125
#: Below this |J| the capacitance is always factorised afresh (its LU costs less than the
#: bordered solve's bookkeeping).
BORDER_MIN_RANK = 128
#: Normwise backward error ``|S t - g| / (|S| |t| + |g|)`` (max-norms) of a bordered solve
#: above which it is redone with a fresh LU of S (a bordered solve is as accurate as the LU
#: unless the base is nearly singular: cattaneo rings levels 4 / 5, at most 7.4e-16 / 1.7e-15
#: against the LU's 7.4e-16 / 7.2e-16).
BORDER_BACKWARD_ERROR = 1e-12
#: A Schur complement pivot at most this fraction of its largest entry means a (numerically)
#: singular S: S is then factorised afresh, so that a singular system raises as it did
#: without bordered solves (:func:`checked_lu`; a backward error check cannot tell).
SCHUR_PIVOT = 1e-13


class NotConverged(Exception):
    """Internal: the active-set iteration of one (sub)increment failed (``iterations``: the
    Newton systems it solved before failing, 0 if not counted)."""

    def __init__(self, message: str, iterations: int = 0) -> None:
        super().__init__(message)
        self.iterations = iterations


@dataclass(frozen=True)
class Sets:
    """Row definition of the full system: pair status, slip sign, and whether any pair sticks."""

    status: np.ndarray
    sign: np.ndarray
    any_stick: bool

    def kinds(self, n_plate: int) -> np.ndarray:
        """Integer kind of every row: two rows are equal iff their kinds are equal."""
        t = self.status.astype(np.int64) * 4
        slip = self.status == SLIP
        t[slip] += (np.sign(self.sign[slip]) + 2).astype(np.int64)
        plate = np.zeros(n_plate, np.int64)
        plate[0] = int(self.any_stick)
        return np.r_[t, (self.status > OPEN).astype(np.int64), plate]


def make_sets(status: np.ndarray, sign: np.ndarray) -> Sets:
    """The row definition of the Newton system for these sets."""
    return Sets(status=status.copy(), sign=sign.copy(), any_stick=bool(np.any(status == STICK)))


def rhs(prob: InterfaceProblem, sets: Sets, old, load: Load, pbar: np.ndarray) -> np.ndarray:
    """Right-hand side b of the full system (``old``: the last converged state)."""
    n = prob.n
    b = np.zeros(2 * n + prob.n_plate)
    stick = sets.status == STICK
    b[:n][stick] = old.lam[:n][stick] / (prob.w[stick] * prob.k_t) + old.d[:n][stick]
    act = sets.status > OPEN
    b[n : 2 * n][act] = pbar[act] / prob.k_n - prob.h0[act]
    b[2 * n] = -load.Q if sets.any_stick else old.z[0]
    b[2 * n + 1] = load.P
    if not prob.lock_theta:
        b[2 * n + 2] = load.M
    return b


def open_scale(prob: InterfaceProblem) -> np.ndarray:
    """``c``: the coefficient of an open row, ``|C_jj|`` (1 where it is zero), so that open
    rows are scaled like the compliance rows (C is SPD up to the far-field's low-rank term)."""
    return prob.compliance_scale


def rows(prob: InterfaceProblem, sets: Sets, idx: np.ndarray,
         cols: np.ndarray | None = None) -> np.ndarray:
    """Rows ``idx`` of the full matrix, dense ``(idx.size, N)``, or only its columns ``cols``
    (sorted; ``(idx.size, cols.size)``: the active block of a reference is gathered from C
    directly, not from its full rows)."""
    n, N = prob.n, 2 * prob.n + prob.n_plate
    cols = np.arange(N) if cols is None else cols
    pos = np.full(N, -1, np.int64)
    pos[cols] = np.arange(cols.size)
    n_c = np.count_nonzero(cols < 2 * n)  # cols is sorted: pair columns first
    out = np.zeros((idx.size, cols.size))
    at = np.arange(idx.size)
    on_pairs = idx < 2 * n
    i, j = at[on_pairs], idx[on_pairs]
    st, tang = sets.status[j % n], j < n
    comp = np.where(tang, st == STICK, st > OPEN)
    ic, jc = i[comp], j[comp]
    if n_c == 2 * n:
        out[ic, : 2 * n] = prob.C[jc]
    else:  # in blocks of rows: no temporary as large as the result
        for s in range(0, jc.size, GATHER_ROWS):
            out[ic[s : s + GATHER_ROWS], :n_c] = prob.C[np.ix_(jc[s : s + GATHER_ROWS], cols[:n_c])]
    out[ic, n_c:] = prob.plate_matrix()[np.ix_(jc, cols[n_c:] - 2 * n)]
    on = pos[jc] >= 0
    ic, jc = ic[on], jc[on]
    out[ic, pos[jc]] += 1.0 / (prob.w[jc % n] * np.where(jc < n, prob.k_t, prob.k_n))
    op = (st == OPEN) & (pos[j] >= 0)
    out[i[op], pos[j[op]]] = open_scale(prob)[j[op]]
    slip = tang & (st == SLIP)
    si, sj = i[slip], j[slip]
    on, on_n = pos[sj] >= 0, pos[sj + n] >= 0
    out[si[on], pos[sj[on]]] = 1.0
    out[si[on_n], pos[sj[on_n] + n]] = -prob.mu * sets.sign[sj[on_n]]
    tcols, ncols = np.flatnonzero(cols < n), np.flatnonzero((cols >= n) & (cols < 2 * n))
    for i, r in zip(at[~on_pairs], idx[~on_pairs] - 2 * n, strict=True):
        if r == 0 and sets.any_stick:
            out[i, tcols] = 1.0
        elif r == 0:
            out[i, pos[2 * n : 2 * n + 1][pos[2 * n] >= 0]] = 1.0
        elif r == 1:
            out[i, ncols] = 1.0
        else:
            out[i, ncols] = prob.x[cols[ncols] - n]
    return out


def sparse_entries(
    prob: InterfaceProblem, sets: Sets, idx: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which rows idx have at most SPARSE_ROW entries (open rows: ``c_j`` at j; slip rows:
    1 at j and ``-mu s_j`` at j + n; as in :func:`rows`), and those entries' columns and
    values ((idx.size, SPARSE_ROW); unused ones 0)."""
    n = prob.n
    pair = idx < 2 * n
    st = sets.status[idx % n]
    opn = pair & (st == OPEN)
    slip = (idx < n) & (st == SLIP)
    cols = np.zeros((idx.size, SPARSE_ROW), np.int64)
    vals = np.zeros((idx.size, SPARSE_ROW))
    cols[opn, 0], vals[opn, 0] = idx[opn], open_scale(prob)[idx[opn]]
    cols[slip, 0], vals[slip, 0] = idx[slip], 1.0
    cols[slip, 1], vals[slip, 1] = idx[slip] + n, -prob.mu * sets.sign[idx[slip]]
    return opn | slip, cols, vals


def matvec(prob: InterfaceProblem, sets: Sets, X: np.ndarray) -> np.ndarray:
    """``A X`` for the full matrix of ``sets`` (X: (N,) or (N, k)).  Only the compliance rows
    (stick tangential, active normal) read C, and only its columns where lam is non-zero:
    ``O(n_active^2)`` for an iterate, less for the open part of a reference solve."""
    n = prob.n
    lam, z = X[: 2 * n], X[2 * n :]
    st = sets.status
    col = (slice(None),) + (None,) * (X.ndim - 1)
    diag = open_scale(prob)
    out = np.empty_like(X)
    out[: 2 * n] = diag[col] * lam
    slip = np.flatnonzero(st == SLIP)
    out[slip] = lam[slip] - (prob.mu * sets.sign[slip])[col] * lam[slip + n]
    comp = np.r_[np.flatnonzero(st == STICK), np.flatnonzero(st > OPEN) + n]
    k = np.where(comp < n, prob.k_t, prob.k_n)
    out[comp] = (
        compliance_product(prob.C, lam, comp, prob.split)
        + prob.plate_matrix()[comp] @ z
        + lam[comp] / (prob.w[comp % n] * k)[col]
    )
    out[2 * n] = lam[:n].sum(axis=0) if sets.any_stick else z[0]
    out[2 * n + 1] = lam[n:].sum(axis=0)
    if not prob.lock_theta:
        out[2 * n + 2] = prob.x @ lam[n:]
    return out


def relative_displacement(prob: InterfaceProblem, x: np.ndarray) -> np.ndarray:
    """``d = C lam + B z`` at every pair for the solution x."""
    n = prob.n
    lam, z = x[: 2 * n], x[2 * n :]
    return compliance_product(prob.C, lam, None, prob.split) + prob.plate_matrix() @ z


def compliance_product(C: np.ndarray, lam: np.ndarray, rows: np.ndarray | None = None,
                       split: int | None = None):
    """``(C @ lam)[rows]`` (all rows if None; ``rows`` sorted), reading only the columns of C
    where lam has non-zero rows (the active pairs of an iterate, a few changed rows of a
    reference solve).  Sets of pairs are a few runs of neighbours (contact and stick zones):
    the product is taken block by block on views of C, without gathering a copy.  ``split``
    (``InterfaceProblem.split``): C's blocks across the tangential and normal halves are zero
    and skipped (the runs are cut there)."""
    nz = np.flatnonzero(np.any(lam != 0, axis=1) if lam.ndim == 2 else lam != 0)
    rows = np.arange(C.shape[0]) if rows is None else rows
    out = np.zeros((rows.size, *lam.shape[1:]))
    col_runs, row_runs = index_runs(nz, split), index_runs(rows, split)
    if len(col_runs) * len(row_runs) > MAX_BLOCKS:
        if split is None:
            return C[np.ix_(rows, nz)] @ lam[nz]
        for lower in (True, False):  # the blocks across the halves are zero
            r, c = (rows < split) == lower, nz[(nz < split) == lower]
            if r.any() and c.size:
                out[r] = C[np.ix_(rows[r], c)] @ lam[c]
        return out
    at = 0
    for r0, r1 in row_runs:
        for c0, c1 in col_runs:
            if split is None or (r0 < split) == (c0 < split):
                out[at : at + r1 - r0] += C[r0:r1, c0:c1] @ lam[c0:c1]
        at += r1 - r0
    return out


def index_runs(idx: np.ndarray, split: int | None = None) -> list[tuple[int, int]]:
    """Maximal runs ``[start, stop)`` of consecutive integers in the sorted array idx (cut
    at ``split`` too if given)."""
    if idx.size == 0:
        return []
    gap = np.diff(idx) != 1
    if split is not None:
        gap |= idx[1:] == split
    cut = np.flatnonzero(gap) + 1
    starts, ends = np.r_[idx[0], idx[cut]], np.r_[idx[cut - 1], idx[-1]] + 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


@dataclass(eq=False)
class Update:
    """The rows J of a reference's low-rank update, kept in slot order (not sorted) across the
    Newton systems that share the reference: ``W^T`` (rows ``A0^{-1} e_j``), ``A[J]`` and the
    capacitance ``S = A[J] W``.  A new system recomputes only the rows that enter J or change
    kind and the columns that enter (``O(dr r N)``, not ``O(r^2 N)``), and nothing is
    gathered into new arrays (cattaneo level 6, cProfile of the increments before: the gathers
    took 10 of 84 s, the capacitance 15 s, building ``A[J]`` 6 s).  The order of the slots
    does not matter to the update formula: J, ``W``, ``A[J]`` and ``S`` are permuted
    together.  Most rows of J are slip or open rows with at most :data:`SPARSE_ROW` entries
    (cattaneo level 5: 82 %); their entries of S are taken from the entries of W they pick
    (``spc``, ``spv``: columns and values), not from products over all N columns."""

    size: int
    Wt: np.ndarray = field(init=False)
    AJ: np.ndarray = field(init=False)
    S: np.ndarray = field(init=False)
    idx: np.ndarray = field(init=False)  # row index of each slot
    kinds: np.ndarray = field(init=False)  # row kind of each slot
    sparse: np.ndarray = field(init=False)  # the slot's row has <= SPARSE_ROW entries
    spc: np.ndarray = field(init=False)  # (slots, SPARSE_ROW) their columns (value 0: unused)
    spv: np.ndarray = field(init=False)  # (slots, SPARSE_ROW) their values
    slot_of: np.ndarray = field(init=False)  # slot of each row, -1 if not in J
    m: int = 0
    computed: int = 0  # rows plus columns of S computed so far (for tests and benchmarks)
    base: Capacitance | None = None  # the LU of an earlier S (bordered solves)
    factored: int = 0  # LUs of S made so far (for tests and benchmarks)
    bordered: int = 0  # systems that began with a bordered solve (for tests and benchmarks)

    def __post_init__(self) -> None:
        self.Wt, self.AJ = np.zeros((0, self.size)), np.zeros((0, self.size))
        self.S = np.zeros((0, 0))
        self.idx, self.kinds = np.zeros(0, np.int64), np.zeros(0, np.int64)
        self.sparse = np.zeros(0, bool)
        self.spc, self.spv = np.zeros((0, SPARSE_ROW), np.int64), np.zeros((0, SPARSE_ROW))
        self.slot_of = np.full(self.size, -1, np.int64)

    def _per_slot(self) -> tuple[str, ...]:
        return ("Wt", "AJ", "idx", "kinds", "sparse", "spc", "spv")

    def reserve(self, m: int) -> None:
        """Room for m slots (capacity doubled, at most N)."""
        cap = self.idx.size
        if m <= cap:
            return
        cap = min(self.size, max(m, 2 * cap, 16))
        old = self.m
        for name in self._per_slot():
            arr = getattr(self, name)
            grown = np.zeros((cap, *arr.shape[1:]), arr.dtype)
            grown[:old] = arr[:old]
            setattr(self, name, grown)
        S = np.zeros((cap, cap))
        S[:old, :old] = self.S[:old, :old]
        self.S = S

    def drop(self, J: np.ndarray) -> None:
        """Remove the slots whose rows are not in J, moving the last slots into the holes."""
        m = self.m
        leave = np.flatnonzero(~np.isin(self.idx[:m], J))
        if not leave.size:
            return
        new_m = m - leave.size
        holes = leave[leave < new_m]
        movers = np.setdiff1d(np.arange(new_m, m), leave)
        self.slot_of[self.idx[leave]] = -1
        if holes.size:
            for name in self._per_slot():
                arr = getattr(self, name)
                arr[holes] = arr[movers]
            self.S[holes, :m] = self.S[movers, :m]
            self.S[:new_m, holes] = self.S[:new_m, movers]
            self.slot_of[self.idx[holes]] = holes
        self.m = new_m

    def set_rows(self, prob: InterfaceProblem, sets: Sets, slots: np.ndarray) -> None:
        """Store the rows of A (of ``sets``) at these slots: the entries of the sparse ones,
        the dense ones whole (a sparse slot's row of ``AJ`` is never read)."""
        sparse, cols, vals = sparse_entries(prob, sets, self.idx[slots])
        self.sparse[slots], self.spc[slots], self.spv[slots] = sparse, cols, vals
        dense = slots[~sparse]
        if dense.size:
            self.AJ[dense] = rows(prob, sets, self.idx[dense])

    def products(self, slots: np.ndarray, Wt: np.ndarray) -> np.ndarray:
        """``A[J][slots] @ Wt.T``: sparse rows from the entries of Wt they pick, the others
        by one product."""
        out = np.empty((slots.size, Wt.shape[0]))
        sp = self.sparse[slots]
        if sp.any():
            at = slots[sp]
            out[sp] = sum(self.spv[at, k, None] * Wt[:, self.spc[at, k]].T
                          for k in range(SPARSE_ROW))
        if not sp.all():
            out[~sp] = self.dense_rows(slots[~sp]) @ Wt.T
        return out

    def times(self, x: np.ndarray, part: tuple | None = None) -> np.ndarray:
        """``A[J] x`` in slot order (sparse rows from their entries; ``part``: the
        :meth:`dense_part` of the current J, gathered once for the solves of a system)."""
        m = self.m
        out = (self.spv[:m] * x[self.spc[:m]]).sum(axis=1)
        dense, rows_ = part or self.dense_part()
        if dense.size:
            out[dense] = rows_ @ x
        return out

    def dense_part(self) -> tuple[np.ndarray, np.ndarray]:
        """The slots of the dense rows of J and those rows of ``A[J]`` (:meth:`dense_rows`)."""
        dense = np.flatnonzero(~self.sparse[: self.m])
        return dense, (self.dense_rows(dense) if dense.size else self.AJ[:0])

    def dense_rows(self, slots: np.ndarray) -> np.ndarray:
        """``AJ[slots]``: a view if the slots are consecutive and ascending (the dense rows
        enter J together and keep their slots: cattaneo rings level 6, 1240 rows of 70 KB
        each), else a gathered copy.  A product with the view equals the one with the copy."""
        if np.all(np.diff(slots) == 1):
            return self.AJ[slots[0] : slots[-1] + 1]
        return self.AJ[slots]


def update(ref: Reference, prob: InterfaceProblem, sets: Sets, J: np.ndarray,
           kinds: np.ndarray) -> Update:
    """The reference's update brought to the rows J (row kinds ``kinds``) of ``sets``."""
    u = ref.work
    u.drop(J)
    m0 = u.m
    slot = u.slot_of[J]
    enter = J[slot < 0]
    kept = slot >= 0
    changed = slot[kept][u.kinds[slot[kept]] != kinds[kept]]
    m = m0 + enter.size
    u.reserve(m)
    new = np.arange(m0, m)
    u.idx[new] = enter
    u.slot_of[enter] = new
    if enter.size:
        u.Wt[new] = ref.block(prob, enter, J)
    redo = np.r_[changed, new]
    u.kinds[u.slot_of[J]] = kinds
    if redo.size:
        u.set_rows(prob, sets, redo)
        if new.size:
            u.S[:m0, new] = u.products(np.arange(m0), u.Wt[new])
        u.S[redo, :m] = u.products(redo, u.Wt[:m])
        u.computed += redo.size + new.size
    u.m = m
    return u


@dataclass(frozen=True, eq=False)
class Capacitance:
    """LU factors of the capacitance matrix S of one system and the row index and kind of
    each of its slots (``slot_of``: the slot of each row of the full system, -1 if none)."""

    lu: tuple
    idx: np.ndarray
    kinds: np.ndarray
    slot_of: np.ndarray


def factor_capacitance(u: Update, what: str) -> Capacitance:
    """LU of the current S of u (NotConverged(what) if singular), with its slots' rows."""
    m = u.m
    slot_of = np.full(u.size, -1, np.int64)
    slot_of[u.idx[:m]] = np.arange(m)
    return Capacitance(lu=checked_lu(u.S[:m, :m], what), idx=u.idx[:m].copy(),
                       kinds=u.kinds[:m].copy(), slot_of=slot_of)


@dataclass(frozen=True, eq=False)
class Bordered:
    """Solves with the current S (slots of :class:`Update`) by the LU of a base S_b
    (:class:`Capacitance`).  Entries of S depend only on the row and kind of their row's slot
    and on the row of their column's slot (``A[j] A0^{-1} e_i``), so S and S_b share the
    block of the slots whose rows kept their kind (U).  With y over the base's slots, the
    unknowns t of the new slots and multipliers of the base's rows that left (L) or changed
    kind (C), the bordered system

        [[S_b, V, E_LC], [H, Z, 0], [E_L^T, 0, 0]]

    (V: the columns of the new slots on U, 0 elsewhere; H, Z: the rows of C (new kind) and of
    the new slots; the multipliers absorb the rows L and C of S_b, the last block row sets
    ``y_L = 0``) is equivalent to S t = g (same solution, singular iff S is), and is solved
    by the Schur complement ``Z - H S_b^{-1} [V, E_LC]`` of order k = |new| + |L| + |C|:
    ``O(k |J|^2)`` per system instead of an ``O(|J|^3)`` LU."""

    lu: tuple  # the base's LU
    size: int  # slots of the base
    cur: np.ndarray  # current slots that hold a row of the base
    at: np.ndarray  # their base slots
    same: np.ndarray  # positions in cur of those whose row kept its kind (U)
    new: np.ndarray  # current slots whose row is not in the base
    border: np.ndarray  # current slots of the border rows (C, then the new ones)
    left: np.ndarray  # base slots whose row left J
    H: np.ndarray  # S[border][:, cur]
    X: np.ndarray  # S_b^{-1} [V, E_LC]
    schur: tuple | None  # LU of the Schur complement (None if k = 0)

    def solve(self, g: np.ndarray) -> np.ndarray:
        """``S^{-1} g`` (slot order)."""
        gb = np.zeros(self.size)
        gb[self.at[self.same]] = g[self.cur[self.same]]
        y = lu_solve(self.lu, gb, check_finite=False)
        z = np.zeros(0)
        if self.schur is not None:
            r = np.r_[g[self.border] - self.H @ y[self.at], -y[self.left]]
            z = lu_solve(self.schur, r, check_finite=False)
            y -= self.X @ z
        t = np.empty(g.size)
        t[self.cur] = y[self.at]
        t[self.new] = z[: self.new.size]
        return t


def bordered(base: Capacitance, u: Update, what: str) -> Bordered | None:
    """The bordered solver of u's current S by the base's LU, or None if |J| is below
    :data:`BORDER_MIN_RANK`, the border exceeds :data:`BORDER_FRACTION` of |J|, or its Schur
    complement is singular to working precision (:data:`SCHUR_PIVOT`)."""
    m = u.m
    S = u.S[:m, :m]
    idx, kinds = u.idx[:m], u.kinds[:m]
    old = base.slot_of[idx]
    cur = np.flatnonzero(old >= 0)
    at = old[cur]
    same = base.kinds[at] == kinds[cur]
    new = np.flatnonzero(old < 0)
    present = np.zeros(base.idx.size, bool)
    present[at] = True
    left = np.flatnonzero(~present)
    changed = cur[~same]
    k = new.size + left.size + changed.size
    if m < BORDER_MIN_RANK or k > BORDER_FRACTION * m:
        return None
    V = np.zeros((base.idx.size, k))
    V[at[same], : new.size] = S[np.ix_(cur[same], new)]
    V[np.r_[left, at[~same]], np.arange(new.size, k)] = 1.0
    X = lu_solve(base.lu, V, check_finite=False)
    border = np.r_[changed, new]
    H = S[np.ix_(border, cur)]
    schur = None
    if k:
        Z = np.zeros((k, k))
        Z[: border.size, : new.size] = S[np.ix_(border, new)]
        Z[: border.size] -= H @ X[at]
        Z[border.size :] = -X[left]
        try:
            schur = checked_lu(Z, what)
        except NotConverged:
            return None
        if np.abs(np.diag(schur[0])).min() <= SCHUR_PIVOT * np.abs(Z).max():
            return None  # S is singular to working precision: its own LU decides
    return Bordered(lu=base.lu, size=base.idx.size, cur=cur, at=at, same=np.flatnonzero(same),
                    new=new, border=border, left=left, H=H, X=X, schur=schur)


def capacitance_solver(u: Update, what: str) -> Callable[[np.ndarray], np.ndarray]:
    """``g -> S^{-1} g`` for u's current capacitance S: a bordered solve with the base's LU
    (:func:`bordered`) while it applies, else (or if a bordered solve's backward error
    exceeds :data:`BORDER_BACKWARD_ERROR`) a fresh LU of S (NotConverged(what) if S is
    singular), which becomes the base."""
    S = u.S[: u.m, : u.m]
    border = None if u.base is None else bordered(u.base, u, what)
    if border is None:
        u.base = factor_capacitance(u, what)
        u.factored += 1
    else:
        u.bordered += 1
    norm = []

    def solve(g: np.ndarray) -> np.ndarray:
        nonlocal border
        if border is not None:
            t = border.solve(g)
            if not norm:
                norm.append(np.abs(S).sum(axis=1).max())
            res = np.abs(S @ t - g).max()
            if res <= BORDER_BACKWARD_ERROR * (norm[0] * np.abs(t).max() + np.abs(g).max()):
                return t
            border = None
            u.base = factor_capacitance(u, what)
            u.factored += 1
        return lu_solve(u.base.lu, g, check_finite=False)

    return solve


@dataclass(eq=False)
class Reference:
    """A factorised reference system: its sets, row kinds, the diagonal blocks of its active
    rows (``blocks``: index arrays, ``lus``: their LU factors; one block, or with a decoupled
    compliance the normal block and then the tangential one), the open rows ``opn``, the
    cached columns of ``A0^{-1} E_J``, the current update (rows J) and the last solution
    ``A0^{-1} b'`` for the reference's own right-hand side."""

    sets: Sets
    kinds: np.ndarray
    blocks: tuple
    lus: tuple
    opn: np.ndarray
    slip: np.ndarray
    columns: dict = field(default_factory=dict)
    work: Update = field(init=False)
    base: tuple | None = None  # (b', A0^{-1} b') of the last base solve

    def __post_init__(self) -> None:
        self.work = Update(self.kinds.size)

    def solve(self, prob: InterfaceProblem, B: np.ndarray) -> np.ndarray:
        """``A0^{-1} B`` by block substitution (B: (N,) or (N, k)): the open rows, then the
        active block; with a decoupled compliance the normal block, the slip rows
        ``lam_t = B + mu s lam_n`` and the tangential block of the sticking pairs."""
        col = (slice(None),) + (None,) * (B.ndim - 1)
        X = np.zeros_like(B)
        X[self.opn] = B[self.opn] / open_scale(prob)[self.opn][col]
        F = B - matvec(prob, self.sets, X) if self.opn.size else B.copy()
        X[self.blocks[0]] = nonzero_solve(self.lus[0], F[self.blocks[0]])
        if len(self.blocks) == 1:
            return X
        s, tb = self.slip, self.blocks[1]
        if s.size:
            Xs = np.zeros_like(B)
            Xs[s] = F[s] + (prob.mu * self.sets.sign[s])[col] * X[s + prob.n]
            X[s] = Xs[s]
            F[tb] -= matvec(prob, self.sets, Xs)[tb]
        X[tb] = nonzero_solve(self.lus[1], F[tb])
        return X

    def base_solution(self, prob: InterfaceProblem, b: np.ndarray, b_ref: np.ndarray,
                      J: np.ndarray) -> np.ndarray:
        """``y = A0^{-1} b'`` for a b' equal to b outside the rows J: then the update formula
        ``x = y - W S^{-1} (A[J] y - b[J])`` solves ``A x = b`` (A0 y and b differ only in
        J).  b' is the right-hand side of the reference's own sets for the same load and
        history (``b_ref``), which the Newton systems of one increment share, so y is
        solved once per increment and reference, not once per system (cattaneo level 5: 284
        systems, 2 solves each, ~3 ms each).  If b and b_ref differ outside J, y solves b."""
        out = np.ones(b.size, bool)
        out[J] = False
        if not np.array_equal(b[out], b_ref[out]):
            return self.solve(prob, b)
        if self.base is None or not np.array_equal(self.base[0], b_ref):
            self.base = (b_ref, self.solve(prob, b_ref))
        return self.base[1]

    def block(self, prob: InterfaceProblem, J: np.ndarray, keep: np.ndarray) -> np.ndarray:
        """Rows ``A0^{-1} e_j`` (|J|, N) for j in J, new ones solved in one blocked solve
        (the cache is cut back to the rows ``keep`` once it holds half the rows)."""
        if len(self.columns) > self.kinds.size // 2:  # rows that differed once: forget them
            self.columns = {int(j): self.columns[int(j)] for j in keep if int(j) in self.columns}
        new = np.array([j for j in J if int(j) not in self.columns], dtype=np.int64)
        if new.size:
            E = np.zeros((self.kinds.size, new.size))
            E[new, np.arange(new.size)] = 1.0
            for j, col in zip(new, np.ascontiguousarray(self.solve(prob, E).T), strict=True):
                self.columns[int(j)] = col
        return np.array([self.columns[int(j)] for j in J])


def nonzero_solve(lu: tuple, F: np.ndarray) -> np.ndarray:
    """``lu_solve(lu, F)``, solving only the non-zero columns of F (a zero column solves to
    zero): with a decoupled compliance the columns ``A0^{-1} e_j`` of tangential rows j have
    no normal part, and those of normal rows none of the sticking block's if no pair slips."""
    if F.ndim == 1:
        return lu_solve(lu, F, check_finite=False)
    nz = np.flatnonzero(np.any(F != 0, axis=0))
    if nz.size == F.shape[1]:
        return lu_solve(lu, F, check_finite=False)
    out = np.zeros_like(F)
    if nz.size:
        out[:, nz] = lu_solve(lu, F[:, nz], check_finite=False)
    return out


def factor_reference(prob: InterfaceProblem, sets: Sets) -> Reference:
    """LU of the active rows of the full system of ``sets`` (NotConverged if singular): one
    block, or, with a decoupled compliance (``prob.split``: C's tangential-normal blocks are
    zero), the normal block (``lam_n``, ``v_p``, theta: the normal rows and the P and M rows)
    and the tangential block of the sticking pairs (``lam_t``, ``u_p``), the slip rows
    ``lam_t = mu s lam_n`` solved between them: LUs of half the size or less."""
    n = prob.n
    a = np.flatnonzero(sets.status > OPEN)
    plate = 2 * n + np.arange(prob.n_plate)
    slip = np.zeros(0, np.int64)
    if prob.split is None:
        blocks = (np.r_[a, a + n, plate],)
    else:
        slip = np.flatnonzero(sets.status == SLIP)
        blocks = (np.r_[a + n, plate[1:]], np.r_[np.flatnonzero(sets.status == STICK), plate[0]])
    what = f"singular active-set system ({a.size} active pairs)"
    lus = tuple(checked_lu(rows(prob, sets, b, b), what) for b in blocks)
    opn = np.setdiff1d(np.arange(2 * n + prob.n_plate), np.concatenate([*blocks, slip]))
    return Reference(sets=sets, kinds=sets.kinds(prob.n_plate), blocks=blocks, lus=lus, opn=opn,
                     slip=slip)


def checked_lu(A: np.ndarray, what: str) -> tuple:
    """LU factors of A; NotConverged(what) if A is singular or not finite (the singularity is
    this error, not a LinAlgWarning besides it)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LinAlgWarning)
            lu = lu_factor(A, check_finite=False)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise NotConverged(what) from exc
    if not np.all(np.isfinite(lu[0])) or np.any(np.diag(lu[0]) == 0):
        raise NotConverged(what)
    return lu


@dataclass(eq=False)
class ActiveSetSolver:
    """Solves the Newton systems of one load history with a pool of reference factorisations
    (see the module docstring). ``factorisations``, ``updates``: counters for benchmarks."""

    prob: InterfaceProblem
    pool: list = field(default_factory=list)
    factorisations: int = 0
    updates: int = 0

    def solve(
        self, sets: Sets, rhs_of: Callable[[Sets], np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Solution x of the full system of ``sets`` with right-hand side ``rhs_of(sets)`` and
        d = C lam + B z (open lam set to 0).  ``rhs_of`` gives the right-hand side of any sets
        for the same load and history (:func:`rhs`): the reference's own one is solved once
        and shared by the systems of an increment (:meth:`Reference.base_solution`)."""
        prob = self.prob
        kinds = sets.kinds(prob.n_plate)
        ref, J = self.reference(sets, kinds)
        b = rhs_of(sets)
        y = ref.base_solution(prob, b, b if not J.size else rhs_of(ref.sets), J)
        cap, u = None, None
        if J.size:
            u = update(ref, prob, sets, J, kinds[J])
            cap = capacitance_solver(
                u, f"singular active-set system ({np.count_nonzero(sets.status)} active pairs)"
            )

        part = None if cap is None else u.dense_part()  # one gather for both solves

        def apply(x0: np.ndarray, r: np.ndarray) -> np.ndarray:
            if cap is None:
                return x0
            m = u.m
            t = cap(u.times(x0, part) - r[u.idx[:m]])
            return x0 - u.Wt[:m].T @ t

        x = apply(y, b)
        r = b - matvec(prob, sets, x)
        x += apply(ref.solve(prob, r), r)
        n = prob.n
        open_ = np.flatnonzero(sets.status == OPEN)
        x[open_], x[open_ + n] = 0.0, 0.0
        if not np.all(np.isfinite(x)):
            raise NotConverged("active-set system: non-finite solution")
        self.updates += int(cap is not None)
        return x, relative_displacement(prob, x)

    def reference(self, sets: Sets, kinds: np.ndarray) -> tuple[Reference, np.ndarray]:
        """The pool reference nearest to ``sets`` (row kinds ``kinds``) and the rows J that
        differ; a new reference (replacing the least recently used) if the rank would exceed the
        refactor limit."""
        best, J = None, None
        for ref in self.pool:
            diff = np.flatnonzero(ref.kinds != kinds)
            if J is None or diff.size < J.size:
                best, J = ref, diff
        size = 2 * np.count_nonzero(sets.status) + self.prob.n_plate
        if best is None or J.size > max(REFACTOR_MIN_RANK, REFACTOR_FRACTION * size):
            best, J = factor_reference(self.prob, sets), np.zeros(0, np.int64)
            self.factorisations += 1
            self.pool.append(best)
            if len(self.pool) > POOL:
                self.pool.pop(0)
            return best, J
        self.pool.remove(best)
        self.pool.append(best)
        return best, J
