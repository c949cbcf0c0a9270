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
A0 is block triangular in (active, open) ordering, ``[[A11, A12], [0, diag(c)]]``, so only
its active block A11 (the reference active system) is LU-factorised.  Cost per iteration:
two solves with the reference factors, products with the active columns of C
(``O(n n_active)``), one more solve per newly changed row (cached per reference) and
``O(r^2 N)`` for the capacitance matrix, instead of an ``O(N_active^3)`` factorisation; a
new reference is factorised only when the rank ``r = |J|`` exceeds
:data:`REFACTOR_FRACTION` of the active system's size.  A small pool of references
(:data:`POOL`) serves the two kinds of matrices of an increment: the elastic predictor
(previously active pairs stick) and the converged-type sets (with slip).  One step
of iterative refinement with the exact matrix follows every solve (as with the dense LU
before: the penalty terms 1/(w k) next to a stiff compliance need it).
"""

from __future__ import annotations

import warnings
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
#: work like r^2 N, so the larger fraction is meant for larger n: not measured beyond n = 583).
REFACTOR_FRACTION = 0.25
#: Below this rank an update is always used (tiny systems: factorising is cheap anyway).
REFACTOR_MIN_RANK = 8
#: Above this many (row run, column run) blocks a product with C gathers a copy instead.
MAX_BLOCKS = 64
#: Reference factorisations kept (predictor-type and converged-type sets of an increment).
POOL = 2


class NotConverged(Exception):
    """Internal: the active-set iteration of one (sub)increment failed."""


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
    c = np.abs(np.diag(prob.C))
    return np.where(c > 0, c, 1.0)


def rows(prob: InterfaceProblem, sets: Sets, idx: np.ndarray) -> np.ndarray:
    """Rows ``idx`` of the full matrix, dense ``(idx.size, N)``."""
    n = prob.n
    out = np.zeros((idx.size, 2 * n + prob.n_plate))
    at = np.arange(idx.size)
    on_pairs = idx < 2 * n
    i, j = at[on_pairs], idx[on_pairs]
    st, tang = sets.status[j % n], j < n
    comp = np.where(tang, st == STICK, st > OPEN)
    ic, jc = i[comp], j[comp]
    out[ic, : 2 * n] = prob.C[jc]
    out[ic, 2 * n :] = prob.plate_matrix()[jc]
    out[ic, jc] += 1.0 / (prob.w[jc % n] * np.where(jc < n, prob.k_t, prob.k_n))
    op = st == OPEN
    out[i[op], j[op]] = open_scale(prob)[j[op]]
    slip = tang & (st == SLIP)
    out[i[slip], j[slip]] = 1.0
    out[i[slip], j[slip] + n] = -prob.mu * sets.sign[j[slip]]
    for i, r in zip(at[~on_pairs], idx[~on_pairs] - 2 * n, strict=True):
        if r == 0 and sets.any_stick:
            out[i, :n] = 1.0
        elif r == 0:
            out[i, 2 * n] = 1.0
        elif r == 1:
            out[i, n : 2 * n] = 1.0
        else:
            out[i, n : 2 * n] = prob.x
    return out


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
        compliance_product(prob.C, lam, comp)
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
    return compliance_product(prob.C, x[: 2 * n]) + prob.plate_matrix() @ x[2 * n :]


def compliance_product(C: np.ndarray, lam: np.ndarray, rows: np.ndarray | None = None):
    """``(C @ lam)[rows]`` (all rows if None; ``rows`` sorted), reading only the columns of C
    where lam has non-zero rows (the active pairs of an iterate, a few changed rows of a
    reference solve).  Sets of pairs are a few runs of neighbours (contact and stick zones):
    the product is taken block by block on views of C, without gathering a copy."""
    nz = np.flatnonzero(np.any(lam != 0, axis=1) if lam.ndim == 2 else lam != 0)
    rows = np.arange(C.shape[0]) if rows is None else rows
    out = np.zeros((rows.size, *lam.shape[1:]))
    col_runs, row_runs = index_runs(nz), index_runs(rows)
    if len(col_runs) * len(row_runs) > MAX_BLOCKS:
        return C[np.ix_(rows, nz)] @ lam[nz]
    at = 0
    for r0, r1 in row_runs:
        for c0, c1 in col_runs:
            out[at : at + r1 - r0] += C[r0:r1, c0:c1] @ lam[c0:c1]
        at += r1 - r0
    return out


def index_runs(idx: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs ``[start, stop)`` of consecutive integers in the sorted array idx."""
    if idx.size == 0:
        return []
    cut = np.flatnonzero(np.diff(idx) != 1) + 1
    starts, ends = np.r_[idx[0], idx[cut]], np.r_[idx[cut - 1], idx[-1]] + 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


@dataclass(eq=False)
class Reference:
    """A factorised reference system: its sets, row kinds, active/open index split, the LU of
    the active block and the cached columns of ``A0^{-1} E_J``."""

    sets: Sets
    kinds: np.ndarray
    act: np.ndarray
    opn: np.ndarray
    lu: tuple
    columns: dict = field(default_factory=dict)
    last: tuple | None = None  # (J, row kinds of J, A[J] W) of the last update

    def capacitance(self, AJ: np.ndarray, W: np.ndarray, J: np.ndarray,
                    kinds: np.ndarray) -> np.ndarray:
        """``A[J] W``, reusing the entries of the last update whose row (index and kind) and
        column are both in it: successive Newton systems change a few rows of J, so the
        ``O(r^2 N)`` product shrinks to ``O(dr r N)`` (cattaneo level 6: 40 of 105 s)."""
        S = None
        if self.last is not None:
            lJ, lk, lS = self.last
            at = np.searchsorted(lJ, J).clip(max=lJ.size - 1)
            col = np.where(lJ[at] == J, at, -1)
            row = np.where((col >= 0) & (lk[col] == kinds), col, -1)
            rr, cc = row >= 0, col >= 0
            if rr.any() and cc.any():
                S = np.empty((J.size, J.size))
                S[np.ix_(rr, cc)] = lS[np.ix_(row[rr], col[cc])]
                S[~rr] = AJ[~rr] @ W
                S[np.ix_(rr, ~cc)] = AJ[rr] @ W[:, ~cc]
        if S is None:
            S = AJ @ W
        self.last = (J, kinds, S)
        return S

    def solve(self, prob: InterfaceProblem, B: np.ndarray) -> np.ndarray:
        """``A0^{-1} B`` by block back-substitution (B: (N,) or (N, k))."""
        diag = open_scale(prob)
        X = np.zeros_like(B)
        X[self.opn] = B[self.opn] / (diag[self.opn] if B.ndim == 1 else diag[self.opn, None])
        a12x = matvec(prob, self.sets, X)[self.act] if self.opn.size else 0.0
        X[self.act] = lu_solve(self.lu, B[self.act] - a12x, check_finite=False)
        return X

    def block(self, prob: InterfaceProblem, J: np.ndarray) -> np.ndarray:
        """``W = A0^{-1} E_J`` (N, |J|), new columns solved in one blocked solve."""
        if len(self.columns) > self.kinds.size // 2:  # rows that differed once: forget them
            self.columns = {int(j): self.columns[int(j)] for j in J if int(j) in self.columns}
        new = np.array([j for j in J if j not in self.columns], dtype=np.int64)
        if new.size:
            E = np.zeros((self.kinds.size, new.size))
            E[new, np.arange(new.size)] = 1.0
            for j, col in zip(new, self.solve(prob, E).T, strict=True):
                self.columns[int(j)] = col
        return np.array([self.columns[int(j)] for j in J]).T


def factor_reference(prob: InterfaceProblem, sets: Sets) -> Reference:
    """LU of the active block of the full system of ``sets`` (NotConverged if singular)."""
    n = prob.n
    a = np.flatnonzero(sets.status > OPEN)
    act = np.r_[a, a + n, 2 * n + np.arange(prob.n_plate)]
    opn = np.setdiff1d(np.arange(2 * n + prob.n_plate), act)
    A11 = rows(prob, sets, act)[:, act]
    lu = checked_lu(A11, f"singular active-set system ({a.size} active pairs)")
    return Reference(sets=sets, kinds=sets.kinds(prob.n_plate), act=act, opn=opn, lu=lu)


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

    def solve(self, sets: Sets, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Solution x of the full system of ``sets`` and d = C lam + B z (open lam set to 0)."""
        prob = self.prob
        kinds = sets.kinds(prob.n_plate)
        ref, J = self.reference(sets, kinds)
        W = ref.block(prob, J)
        AJ = rows(prob, sets, J)
        cap = (
            checked_lu(
                ref.capacitance(AJ, W, J, kinds[J]),
                f"singular active-set system ({np.count_nonzero(sets.status)} active pairs)",
            )
            if J.size
            else None
        )

        def apply(r: np.ndarray) -> np.ndarray:
            x0 = ref.solve(prob, r)
            if cap is None:
                return x0
            return x0 - W @ lu_solve(cap, AJ @ x0 - r[J], check_finite=False)

        x = apply(b)
        x += apply(b - matvec(prob, sets, x))
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
