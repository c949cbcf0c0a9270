"""The trailing block of a CHOLMOD supernodal factor read in place equals the one read through
``Factor.L()`` to the last bit; factors it cannot read give None (the caller's fallback)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fem.linsolve import available_backends

pytestmark = pytest.mark.skipif("cholmod" not in available_backends(),
                                reason="reads scikit-sparse's CHOLMOD factor")


def elastic_like(m: int) -> sp.csc_matrix:
    """SPD matrix with two coupled dofs per node of an m x m grid (dense trailing fronts)."""
    T = sp.diags([-1.0, 2.5, -1.0], [-1, 0, 1], shape=(m, m))
    lap = sp.kron(T, sp.eye(m)) + sp.kron(sp.eye(m), T)
    return sp.kron(lap, np.array([[2.0, 0.5], [0.5, 2.0]])).tocsc()


def natural_factor(A: sp.csc_matrix, mode: str = "supernodal"):
    from sksparse.cholmod import cholesky

    return cholesky(A, ordering_method="natural", mode=mode)


@pytest.mark.parametrize("m", [1, 7, 60, 333, 2 * 30 * 30])
def test_trailing_block_equals_the_converted_factor_bit_for_bit(m):
    from fem.supernodal import trailing_block

    A = elastic_like(30)
    chol = natural_factor(A)
    got = trailing_block(chol, A.shape[0], m)
    ref = chol.L()[-m:, -m:].toarray()
    assert got is not None and got.flags.f_contiguous
    assert np.array_equal(got, ref)


def test_the_block_spans_several_supernodes_and_starts_inside_one():
    from fem.supernodal import factor_struct, int_array, trailing_block

    A = elastic_like(30)
    n, m = A.shape[0], 100
    chol = natural_factor(A)
    f = factor_struct(chol, n)
    first = int_array(f, f.super_, f.nsuper + 1)[:-1]  # first column of each supernode
    assert np.count_nonzero(first > n - m) >= 2  # the block spans several supernodes
    assert np.any((first < n - m) & (np.r_[first[1:], n] > n - m))  # one starts before it
    got = trailing_block(chol, n, m)
    assert np.array_equal(got, chol.L()[-m:, -m:].toarray())


@pytest.mark.parametrize("case", ["simplicial", "wrong size", "fill-reducing order", "no factor"])
def test_factors_it_cannot_read_give_none(case):
    from sksparse.cholmod import cholesky

    from fem.supernodal import trailing_block

    A = elastic_like(20)
    n = A.shape[0]
    if case == "simplicial":
        chol, size = natural_factor(A, "simplicial"), n
    elif case == "wrong size":
        chol, size = natural_factor(A), n + 1
    elif case == "fill-reducing order":
        chol, size = cholesky(A, ordering_method="amd", mode="supernodal"), n
    else:
        chol, size = object(), n
    assert trailing_block(chol, size, 10) is None


def test_trailing_compliance_reads_the_supernodal_factor_in_place(monkeypatch):
    import fem.condense as cd
    import fem.supernodal as sn

    A = elastic_like(30)
    n, m = A.shape[0], 120
    reads = []

    def spy(chol, size, k):
        out = sn.trailing_block(chol, size, k)
        reads.append(out is not None)
        return out

    monkeypatch.setattr(cd, "trailing_block", spy)
    chol = natural_factor(A)
    Cb, packed = cd.trailing_compliance(chol, n, m)
    assert reads == [True] and packed is None  # the recovery reads the factor again
    monkeypatch.setattr(cd, "trailing_block", lambda *a: None)  # the L() fallback
    Cb_ref, packed_ref = cd.trailing_compliance(chol, n, m)
    assert np.array_equal(Cb, Cb_ref) and packed_ref.size == m * (m + 1) // 2
    in_place, copied = cd.panel_reader(chol, n, m, None), cd.panel_reader(chol, n, m, packed_ref)
    for c0, c1 in ((0, m), (0, 1), (37, 38), (5, 90), (90, m)):
        assert np.array_equal(in_place(c0, c1), copied(c0, c1))
    S = np.linalg.inv(np.linalg.inv(A.toarray())[-m:, -m:])  # Schur complement on the tail
    Cfull = np.tril(Cb) + np.tril(Cb, -1).T
    assert np.allclose(Cfull @ S, np.eye(m), atol=1e-10)


@pytest.mark.parametrize("block", [1, 3, 64])
@pytest.mark.parametrize("m", [100, 2 * 30 * 30])
def test_the_block_copied_column_block_by_column_block_is_the_same(monkeypatch, block, m):
    """COPY_BLOCK cuts the supernodes' diagonal blocks into column blocks (several per
    supernode at these sizes): the same bits as the converted factor."""
    import fem.supernodal as sn

    monkeypatch.setattr(sn, "COPY_BLOCK", block)
    A = elastic_like(30)
    chol = natural_factor(A)
    got = sn.trailing_block(chol, A.shape[0], m)
    assert np.array_equal(got, chol.L()[-m:, -m:].toarray())


@pytest.mark.parametrize("block", [3, 256])
@pytest.mark.parametrize("window", [(0, 100), (0, 1), (99, 100), (13, 14), (10, 57), (57, 100)])
def test_a_panel_of_the_trailing_block_is_its_columns_from_the_diagonal_down(monkeypatch, block,
                                                                             window):
    """trailing_panel(c0, c1): rows c0.. of columns c0..c1-1 of L22 (a block spanning several
    supernodes and starting inside one), bit for bit, zeros above the diagonal."""
    import fem.supernodal as sn

    monkeypatch.setattr(sn, "COPY_BLOCK", block)
    A = elastic_like(30)
    n, m = A.shape[0], 100
    chol = natural_factor(A)
    c0, c1 = window
    got = sn.trailing_panel(chol, n, m, c0, c1)
    ref = chol.L()[-m:, -m:].toarray()[c0:, c0:c1]
    assert got.flags.f_contiguous and np.array_equal(got, ref)
    assert sn.trailing_panel(chol, n, m, c1, c1) is None  # an empty window
    assert sn.trailing_panel(natural_factor(A, "simplicial"), n, m, c0, c1) is None
