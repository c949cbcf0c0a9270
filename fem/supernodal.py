"""The trailing dense block of a CHOLMOD supernodal factor, read in place (issue 28).

scikit-sparse's ``Factor.L()`` copies the whole factor, converts the copy to a simplicial
factor and then to a sparse matrix: at level 6 that copy was the peak memory of the whole
history, only to read the trailing ``m x m`` block ``L22`` (the pair dofs, ordered last).
A supernodal factor (CHOLMOD's ``cholmod_factor``, fields as in ``cholmod_core.h`` of
CHOLMOD 3-5) stores each supernode's columns as one dense column-major block of
``nsrow x nscol`` numbers in ``x`` (from ``px[s]``), its row indices in ``s`` (from
``pi[s]``), the first ``nscol`` of them the supernode's own columns ``super[s] ..
super[s+1]-1``.  The trailing block is copied out of the supernodes that own the last m
columns: no copy of the rest of the factor.

scikit-sparse (0.4) does not expose the ``cholmod_factor *`` of a ``Factor``; it sits in the
extension object right after the ``_common`` reference (found by its address, not assumed).
Every field read is checked against what the caller knows (size, LL', supernodal, real double,
natural ordering, factorised) and the block's diagonal against the public ``Factor.D()`` to
the last bit; anything unexpected (another layout, a simplicial factor) returns None and the
caller falls back to ``Factor.L()``.
"""

from __future__ import annotations

import ctypes

import numpy as np

#: CHOLMOD constants (cholmod_core.h): itype, xtype, dtype codes.
CHOLMOD_INT, CHOLMOD_LONG, CHOLMOD_REAL, CHOLMOD_DOUBLE = 0, 2, 1, 0
#: Pointer-sized words of a ``Factor`` object searched for its ``_common`` reference
#: (object header 2 words, an optional vtable pointer, then ``_common``, ``_factor``).
SEARCH_WORDS = 8
#: Columns of a supernode's diagonal block copied at a time (a triangle needs a square's copy
#: only block by block).
COPY_BLOCK = 256


class CholmodFactor(ctypes.Structure):
    """``cholmod_factor`` (cholmod_core.h, CHOLMOD 3-5; ``super`` renamed ``super_``)."""

    _fields_ = [
        ("n", ctypes.c_size_t), ("minor", ctypes.c_size_t),
        ("Perm", ctypes.c_void_p), ("ColCount", ctypes.c_void_p), ("IPerm", ctypes.c_void_p),
        ("nzmax", ctypes.c_size_t),
        ("p", ctypes.c_void_p), ("i", ctypes.c_void_p), ("x", ctypes.c_void_p),
        ("z", ctypes.c_void_p), ("nz", ctypes.c_void_p),
        ("next", ctypes.c_void_p), ("prev", ctypes.c_void_p),
        ("nsuper", ctypes.c_size_t), ("ssize", ctypes.c_size_t), ("xsize", ctypes.c_size_t),
        ("maxcsize", ctypes.c_size_t), ("maxesize", ctypes.c_size_t),
        ("super_", ctypes.c_void_p), ("pi", ctypes.c_void_p), ("px", ctypes.c_void_p),
        ("s", ctypes.c_void_p),
        ("ordering", ctypes.c_int), ("is_ll", ctypes.c_int), ("is_super", ctypes.c_int),
        ("is_monotonic", ctypes.c_int), ("itype", ctypes.c_int), ("xtype", ctypes.c_int),
        ("dtype", ctypes.c_int), ("useGPU", ctypes.c_int),
    ]


def factor_struct(chol, n: int) -> CholmodFactor | None:
    """The ``cholmod_factor`` of scikit-sparse's Factor ``chol`` of an n x n matrix, if it
    is a numeric supernodal LL' factor of real doubles, else None."""
    common = getattr(chol, "_common", None)
    if common is None:
        return None
    base, word = id(chol), ctypes.sizeof(ctypes.c_void_p)
    for k in range(2, SEARCH_WORDS - 1):
        if ctypes.c_void_p.from_address(base + k * word).value == id(common):
            ptr = ctypes.c_void_p.from_address(base + (k + 1) * word).value
            break
    else:
        return None
    if not ptr:
        return None
    f = CholmodFactor.from_address(ptr)
    ok = (f.n == n and f.minor == n and f.is_super == 1 and f.is_ll == 1
          and f.xtype == CHOLMOD_REAL and f.dtype == CHOLMOD_DOUBLE
          and f.itype in (CHOLMOD_INT, CHOLMOD_LONG) and f.nsuper > 0
          and all((f.x, f.super_, f.pi, f.px, f.s, f.Perm)))
    return f if ok else None


def int_array(f: CholmodFactor, address: int, size: int) -> np.ndarray:
    """The factor's integer array at ``address`` (``size`` entries, its itype), in place."""
    ctype = ctypes.c_int32 if f.itype == CHOLMOD_INT else ctypes.c_int64
    return np.ctypeslib.as_array(ctypes.cast(address, ctypes.POINTER(ctype)), shape=(size,))


def trailing_block(chol, n: int, m: int) -> np.ndarray | None:
    """``L22 = L[n-m:, n-m:]`` (lower triangular, Fortran order) of the n x n supernodal
    factor ``chol`` (natural ordering: its columns are the matrix's), read in place; None
    if ``chol`` is not a factor this module can read (the caller then uses ``chol.L()``).
    Its diagonal is checked against the public ``Factor.D()`` to the last bit."""
    L22 = trailing_panel(chol, n, m, 0, m)
    if L22 is None:
        return None
    d = chol.D()[n - m:]  # the public reading of the same supernodes' diagonals
    return L22 if np.array_equal(np.diag(L22) ** 2, d) else None


def trailing_panel(chol, n: int, m: int, c0: int, c1: int) -> np.ndarray | None:
    """Rows ``c0 .. m-1`` of columns ``c0 .. c1-1`` of :func:`trailing_block`'s ``L22``
    (zeros above the diagonal, Fortran order), read in place from the supernodes that own
    those columns; None if ``chol`` is not a factor this module can read.  The recovery's
    triangular solves read L22 a panel at a time (``fem.condense.trailing_solve``): no copy
    of the whole triangle is kept beside the factor (issue 28)."""
    f = factor_struct(chol, n)
    if f is None or not 0 < m <= n or not 0 <= c0 < c1 <= m:
        return None
    nsuper = f.nsuper
    super_ = int_array(f, f.super_, nsuper + 1)
    pi, px = int_array(f, f.pi, nsuper + 1), int_array(f, f.px, nsuper + 1)
    perm = int_array(f, f.Perm, n)
    if super_[-1] != n or not np.array_equal(perm[n - m:], np.arange(n - m, n)):
        return None
    rows_all = int_array(f, f.s, f.ssize)
    x = np.ctypeslib.as_array(ctypes.cast(f.x, ctypes.POINTER(ctypes.c_double)),
                              shape=(f.xsize,))
    lo, hi = n - m + c0, n - m + c1
    panel = np.zeros((m - c0, c1 - c0), order="F")
    s = int(np.searchsorted(super_, hi, side="left")) - 1  # the supernode of column hi - 1
    while s >= 0 and super_[s + 1] > lo:
        copy_supernode(panel, lo, hi, int(super_[s]), int(super_[s + 1]),
                       rows_all[pi[s]:pi[s + 1]], x, int(px[s]))
        s -= 1
    return panel


def copy_supernode(panel: np.ndarray, lo: int, hi: int, k1: int, k2: int, rows: np.ndarray,
                   x: np.ndarray, px: int) -> None:
    """Copy the columns ``lo .. hi-1`` of supernode ``k1 .. k2-1`` (row indices ``rows``,
    values ``x[px:]`` column-major, ``len(rows)`` per column) into ``panel`` (the factor's
    rows from ``lo`` and columns ``lo .. hi-1``; its entries above the diagonal left as they
    are, zero).  The diagonal block's lower triangle goes over by column blocks of COPY_BLOCK
    and the rows below it by slices where they are consecutive (the pair dofs' own
    supernode: all of them), without a dense triangle copy or an index grid of the whole
    block (issue 28: 1.9 s at level 6)."""
    nsrow, nscol = rows.size, k2 - k1
    c0, c1 = max(lo - k1, 0), min(hi, k2) - k1  # the supernode's columns inside the panel
    slab = x[px:px + nsrow * nscol].reshape(nscol, nsrow)[c0:c1, c0:].T  # rows x columns
    j = k1 + c0 - lo  # the first column (and row) in the panel
    r = rows[c0:] - lo
    top, width = nscol - c0, c1 - c0
    for b0 in range(0, width, COPY_BLOCK):
        b1 = min(b0 + COPY_BLOCK, width)
        panel[j + b0:j + top, j + b0:j + b1] = slab[b0:top, b0:b1]
        d = panel[j + b0:j + b1, j + b0:j + b1]
        d[np.triu_indices(b1 - b0, 1)] = 0.0  # the slab's entries above the diagonal
    below = r[top:]
    if below.size and np.array_equal(below, np.arange(below[0], below[0] + below.size)):
        panel[below[0]:below[0] + below.size, j:j + width] = slab[top:]
    elif below.size:
        panel[below, j:j + width] = slab[top:]
