"""The low-rank-updated active-set solves (fem.activeset) equal direct dense solves."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from fem.activeset import (
    OPEN,
    SLIP,
    STICK,
    ActiveSetSolver,
    compliance_product,
    factor_reference,
    make_sets,
    matvec,
    rhs,
    rows,
)
from fem.contact import InterfaceProblem, Load

#: Relative residual of an updated solve: one refinement step brings it to rounding
#: (measured 1e-15 .. 4e-14 on these problems).
RESIDUAL_TOL = 1e-12


def problem(n: int, lock_theta: bool, coupling: float = 0.0) -> InterfaceProblem:
    """A half-plane-like interface: SPD log-kernel compliance, t and n blocks uncoupled (as
    between mirror-image bodies: ``fem.activeset`` then factorises them apart) or coupled by
    ``coupling`` times the kernel (as between bodies of another mesh or material)."""
    x = np.linspace(-1.0, 1.0, n)
    w = np.full(n, x[1] - x[0])
    r = np.abs(x[:, None] - x[None, :]) + 0.3 * w[0]
    block = np.log(8.0 / r) * w[None, :] / np.pi
    C = np.zeros((2 * n, 2 * n))
    C[:n, :n] = block
    C[n:, n:] = block
    C[:n, n:] = C[n:, :n] = coupling * block
    C += 0.05 * np.eye(2 * n) * w[0]
    assert np.all(np.linalg.eigvalsh(0.5 * (C + C.T)) > 0)
    return InterfaceProblem(C=C, x=x, w=w, h0=0.5 * x**2, mu=0.4, k_n=50.0 / w[0],
                            k_t=50.0 / w[0], lock_theta=lock_theta)


def status_walk(n: int, steps: int, rng) -> list[tuple[np.ndarray, np.ndarray]]:
    """A contact zone that grows then slips from its edges: a few pairs change per step."""
    out = []
    for k in range(steps):
        half = 2 + (k * (n // 2 - 3)) // steps
        status = np.full(n, OPEN, np.int8)
        status[n // 2 - half : n // 2 + half] = STICK
        slip = min(k // 2, half - 1)
        status[n // 2 - half : n // 2 - half + slip] = SLIP
        status[n // 2 + half - slip : n // 2 + half] = SLIP
        flip = rng.integers(0, n, 2)  # a stray change or two, as in a Newton step
        status[flip] = np.where(status[flip] == OPEN, STICK, status[flip])
        sign = np.ones(n)
        sign[: n // 2 - half + slip // 2] = -1.0
        out.append((status, sign))
    return out


@pytest.mark.parametrize("coupling", [0.0, 0.2])
@pytest.mark.parametrize("lock_theta", [True, False])
def test_updated_solves_equal_direct_solves(lock_theta, coupling):
    n = 60
    prob = problem(n, lock_theta, coupling)
    assert prob.split == (n if coupling == 0.0 else None)
    rng = np.random.default_rng(3)
    solver = ActiveSetSolver(prob)
    N = 2 * n + prob.n_plate
    walk = status_walk(n, 30, rng)
    for status, sign in walk:
        sets = make_sets(status, sign)
        A = rows(prob, sets, np.arange(N))
        b = rng.normal(size=N)
        b[: 2 * n][np.r_[status, status] == OPEN] = 0.0  # open rows say lam = 0
        x, d = solver.solve(sets, lambda s, b=b: b)
        direct = np.linalg.solve(A, b)
        assert np.abs(A @ x - b).max() <= RESIDUAL_TOL * np.abs(A).max() * np.abs(x).max()
        assert np.allclose(x, direct, rtol=1e-9, atol=1e-10 * np.abs(direct).max())
        assert np.allclose(matvec(prob, sets, x), A @ x, rtol=1e-12, atol=1e-13)
        lam = x[: 2 * n]
        assert np.allclose(d, prob.C @ lam + prob.plate_matrix() @ x[2 * n :])
        assert np.all(lam[np.r_[status, status] == OPEN] == 0.0)
    assert solver.updates > 0
    assert solver.factorisations < len(walk)


def test_singular_system_raises_not_converged():
    from fem.activeset import NotConverged

    prob = problem(20, lock_theta=False)
    status = np.full(20, OPEN, np.int8)
    status[10] = STICK  # one pair cannot carry both P and a moment M
    sets = make_sets(status, np.ones(20))
    A = rows(prob, sets, np.arange(2 * 20 + 3))
    assert np.linalg.matrix_rank(A) < A.shape[0]
    with pytest.raises(NotConverged, match="singular"):
        ActiveSetSolver(prob).solve(sets, lambda s: np.ones(2 * 20 + 3))


def history_rhs(prob: InterfaceProblem, rng):
    """``rhs_of`` of one increment: the contact right-hand side of any sets for a fixed load
    and a random last converged state."""
    n = prob.n
    old = SimpleNamespace(lam=rng.normal(size=2 * n), d=rng.normal(size=2 * n),
                          z=rng.normal(size=3))
    load, pbar = Load(P=1.3, Q=0.2, M=None if prob.lock_theta else 0.1), rng.normal(size=n)
    return lambda s: rhs(prob, s, old, load, pbar)


@pytest.mark.parametrize("coupling", [0.0, 0.2])
@pytest.mark.parametrize("lock_theta", [True, False])
def test_systems_of_one_increment_share_the_base_solve(lock_theta, coupling):
    """The Newton systems of one increment (one right-hand side function) solve A x = b with
    the reference's own right-hand side solved once; a b that differs from it outside J is
    solved directly."""
    n = 60
    prob = problem(n, lock_theta, coupling)
    rng = np.random.default_rng(5)
    solver = ActiveSetSolver(prob)
    N = 2 * n + prob.n_plate
    rhs_of = history_rhs(prob, rng)
    walk = status_walk(n, 30, rng)
    bases = []  # the base solutions used, kept alive so that identity tells them apart
    for status, sign in walk:
        sets = make_sets(status, sign)
        A, b = rows(prob, sets, np.arange(N)), rhs_of(sets)
        x, _ = solver.solve(sets, rhs_of)
        y = solver.pool[-1].base[1]  # the reference just used is the last
        if not any(y is z for z in bases):
            bases.append(y)
        assert np.abs(A @ x - b).max() <= RESIDUAL_TOL * np.abs(A).max() * np.abs(x).max()
        assert np.allclose(x, np.linalg.solve(A, b), rtol=1e-9, atol=1e-10 * np.abs(x).max())
    assert solver.updates > 0
    assert len(bases) == solver.factorisations  # one base solve per reference
    ref = solver.pool[-1]
    J = np.flatnonzero(ref.kinds != make_sets(*walk[-1]).kinds(prob.n_plate))
    b_ref = rhs_of(ref.sets)
    b = b_ref.copy()
    outside = np.setdiff1d(np.arange(N), J)[0]
    b[outside] += 1.0
    y = ref.base_solution(prob, b, b_ref, J)
    assert np.allclose(rows(prob, ref.sets, np.arange(N)) @ y, b)


def test_update_keeps_rows_columns_and_capacitance_of_the_rows_j():
    """After any sequence of row sets J (rows entering, leaving, changing kind) the update
    holds J in some order with W = A0^{-1} E_J, A[J] and A[J] W (slip and open rows from
    their entries, the others by products), and computes fewer rows and columns of A[J] W
    than rebuilding it every time."""
    from fem.activeset import factor_reference, update

    n = 40
    prob = problem(n, lock_theta=True)
    N = 2 * n + prob.n_plate
    status = np.full(n, OPEN, np.int8)
    status[10:30] = STICK
    ref = factor_reference(prob, make_sets(status, np.ones(n)))
    A0 = rows(prob, ref.sets, np.arange(N))
    rebuilt, sparse_seen = 0, False
    for lo, hi, slip, sgn in ((8, 30, 0, 1), (8, 32, 2, 1), (6, 32, 4, -1), (6, 33, 4, 1),
                              (12, 28, 3, 1), (8, 30, 0, 1)):
        st = np.full(n, OPEN, np.int8)
        st[lo:hi] = STICK
        st[lo : lo + slip] = SLIP
        sets = make_sets(st, np.full(n, float(sgn)))
        kinds = sets.kinds(prob.n_plate)
        J = np.flatnonzero(ref.kinds != kinds)
        u = update(ref, prob, sets, J, kinds[J])
        idx = u.idx[: u.m]
        assert np.array_equal(np.sort(idx), J)
        assert np.array_equal(u.kinds[: u.m], kinds[idx])
        AJ = rows(prob, sets, idx)
        dense = ~u.sparse[: u.m]
        assert np.array_equal(u.AJ[: u.m][dense], AJ[dense])
        assert np.allclose(A0 @ u.Wt[: u.m].T, np.eye(N)[:, idx], atol=1e-12)
        S = AJ @ u.Wt[: u.m].T
        assert np.allclose(u.S[: u.m, : u.m], S, rtol=0, atol=1e-13 * np.abs(S).max())
        x = np.random.default_rng(lo).normal(size=N)
        assert np.allclose(u.times(x), AJ @ x, rtol=0, atol=1e-13 * np.abs(AJ).max())
        assert np.array_equal(u.sparse[: u.m], np.count_nonzero(AJ, axis=1) <= 2)
        sparse_seen |= u.sparse[: u.m].any() and not u.sparse[: u.m].all()
        rebuilt += 2 * J.size
    assert sparse_seen
    assert 0 < u.computed < rebuilt


@pytest.mark.parametrize("lock_theta", [True, False])
@pytest.mark.parametrize("any_stick", [True, False])
def test_rows_of_some_columns_equal_the_columns_of_the_full_rows(lock_theta, any_stick,
                                                                 monkeypatch):
    """``rows(..., cols)`` (the active block of a reference) is exactly the columns cols of
    the full rows, for every kind of row (stick, slip of both signs, open, plate) and for
    column sets that leave out some pair and plate columns (C gathered in several blocks of
    rows)."""
    from fem import activeset

    monkeypatch.setattr(activeset, "GATHER_ROWS", 7)
    n = 30
    prob = problem(n, lock_theta)
    N = 2 * n + prob.n_plate
    rng = np.random.default_rng(7)
    status = rng.choice(np.array([OPEN, SLIP, STICK] if any_stick else [OPEN, SLIP], np.int8),
                        n)
    sets = make_sets(status, rng.choice([-1.0, 1.0], n))
    full = rows(prob, sets, np.arange(N))
    a = np.flatnonzero(status > OPEN)
    for cols in (np.r_[a, a + n, 2 * n + np.arange(prob.n_plate)], np.arange(N),
                 np.sort(rng.choice(N, N // 2, replace=False))):
        idx = rng.permutation(N)[: N - 5]
        assert np.array_equal(rows(prob, sets, idx, cols), full[np.ix_(idx, cols)])


@pytest.mark.parametrize("lock_theta", [True, False])
def test_a_decoupled_reference_factorises_the_normal_and_the_sticking_tangential_blocks(
        lock_theta):
    """With C's tangential-normal blocks zero the reference LU-factorises the normal block
    (active lam_n, v_p, theta) and the sticking pairs' tangential block (lam_t, u_p) apart,
    the slip rows solved between them, and solves A0 x = B as the dense solve does; with a
    coupled C it factorises one block of all active rows."""
    n = 40
    status = np.full(n, OPEN, np.int8)
    status[8:32] = STICK
    status[8:13] = SLIP
    status[28:32] = SLIP
    sign = np.where(np.arange(n) < 20, -1.0, 1.0)
    sets = make_sets(status, sign)
    B = np.random.default_rng(2).normal(size=(2 * n + (2 if lock_theta else 3), 3))
    for coupling in (0.0, 0.2):
        prob = problem(n, lock_theta, coupling)
        N = 2 * n + prob.n_plate
        ref = factor_reference(prob, sets)
        sizes = [b.size for b in ref.blocks]
        if coupling == 0.0:
            assert sizes == [24 + prob.n_plate - 1, 15 + 1]
        else:
            assert sizes == [2 * 24 + prob.n_plate]
        A = rows(prob, sets, np.arange(N))
        X = ref.solve(prob, B)
        assert np.allclose(X, np.linalg.solve(A, B), rtol=1e-10, atol=1e-12 * np.abs(X).max())


def test_compliance_product_by_halves_equals_the_full_product():
    """``split``: the blocks across the tangential and normal halves are skipped (they are
    zero), in the run-by-run and in the gathered (many runs) product alike."""
    n = 30
    prob = problem(n, lock_theta=True)
    rng = np.random.default_rng(4)
    for runs in (3, 40):  # a few runs of neighbours; more runs than MAX_BLOCKS allows
        lam = np.zeros((2 * n, 2))
        cols = rng.choice(2 * n, size=runs, replace=False) if runs > 3 else np.r_[
            np.arange(n - 4, n + 5), np.arange(2, 6)]
        lam[cols] = rng.normal(size=(cols.size, 2))
        rows_ = np.sort(rng.choice(2 * n, size=2 * n - 7, replace=False))
        full = (prob.C @ lam)[rows_]
        halves = compliance_product(prob.C, lam, rows_, prob.split)
        assert np.allclose(halves, full, rtol=1e-13, atol=1e-15 * np.abs(full).max())


def zone_sets(n: int, lo: int, hi: int, slip: int = 0, sign: float = 1.0):
    """Sets with pairs lo..hi-1 in contact, the first ``slip`` of them slipping."""
    status = np.full(n, OPEN, np.int8)
    status[lo:hi] = STICK
    status[lo : lo + slip] = SLIP
    return make_sets(status, np.full(n, sign))


#: Walks of sets from a reference (stick on pairs 10..29 of 40): J only gains rows (the zone
#: grows), only loses rows (it shrinks back), or gains, loses and changes the kind of rows
#: (slip zones of both signs at a moving edge).
WALKS = {
    "adds": [(10, 31, 0, 1), (9, 31, 0, 1), (8, 32, 0, 1), (7, 33, 0, 1)],
    "drops": [(4, 36, 0, 1), (5, 35, 0, 1), (6, 34, 0, 1), (6, 33, 0, 1)],
    "mixed": [(8, 32, 3, 1), (8, 31, 4, 1), (7, 31, 4, -1), (9, 33, 2, -1), (8, 32, 3, 1)],
}


@pytest.mark.parametrize("coupling", [0.0, 0.2])
@pytest.mark.parametrize("walk", sorted(WALKS))
def test_bordered_capacitance_solves_equal_dense_solves(walk, coupling, monkeypatch):
    """After the first system of a walk the capacitance S = A[J] W is solved by a bordered
    solve with the first system's LU (rows of J added, dropped, changed in kind, and all
    three), as the dense solve does, and the full system's solution equals the dense one."""
    from fem import activeset
    from fem.activeset import capacitance_solver, update

    monkeypatch.setattr(activeset, "BORDER_FRACTION", 1.0)
    monkeypatch.setattr(activeset, "BORDER_MIN_RANK", 0)
    monkeypatch.setattr(activeset, "REFACTOR_FRACTION", 1.0)
    n = 40
    prob = problem(n, lock_theta=False, coupling=coupling)
    N = 2 * n + prob.n_plate
    ref = factor_reference(prob, zone_sets(n, 10, 30))
    rng = np.random.default_rng(11)
    for step, (lo, hi, slip, sgn) in enumerate(WALKS[walk]):
        sets = zone_sets(n, lo, hi, slip, sgn)
        kinds = sets.kinds(prob.n_plate)
        J = np.flatnonzero(ref.kinds != kinds)
        u = update(ref, prob, sets, J, kinds[J])
        solve = capacitance_solver(u, "singular")
        assert (u.factored, u.bordered) == (1, step)
        S = rows(prob, sets, u.idx[: u.m]) @ u.Wt[: u.m].T
        g = rng.normal(size=u.m)
        t = solve(g)
        assert np.allclose(t, np.linalg.solve(S, g), rtol=0, atol=1e-12 * np.abs(t).max())
        assert u.factored == 1  # the backward error check passed
    solver = ActiveSetSolver(prob)
    for lo, hi, slip, sgn in [(10, 30, 0, 1), *WALKS[walk]]:
        sets = zone_sets(n, lo, hi, slip, sgn)
        b = rhs(prob, sets, SimpleNamespace(lam=rng.normal(size=2 * n), d=rng.normal(size=2 * n),
                                            z=rng.normal(size=3)),
                Load(P=1.0, Q=0.1, M=0.05), rng.normal(size=n))
        x, _ = solver.solve(sets, lambda s, b=b: b)
        assert np.allclose(x, np.linalg.solve(rows(prob, sets, np.arange(N)), b), rtol=1e-9,
                           atol=1e-10 * np.abs(x).max())
    assert solver.factorisations == 1
    assert solver.pool[0].work.bordered == len(WALKS[walk]) - 1


def test_bordered_capacitance_limits_and_falls_back_to_a_fresh_lu(monkeypatch):
    """A |J| below BORDER_MIN_RANK, a border beyond BORDER_FRACTION of |J|, or a bordered
    solve whose backward error exceeds BORDER_BACKWARD_ERROR: S is factorised afresh (the
    new base)."""
    from fem import activeset
    from fem.activeset import capacitance_solver, update

    n = 40
    prob = problem(n, lock_theta=True)
    ref = factor_reference(prob, zone_sets(n, 10, 30))

    def step(lo, hi):
        sets = zone_sets(n, lo, hi)
        kinds = sets.kinds(prob.n_plate)
        J = np.flatnonzero(ref.kinds != kinds)
        u = update(ref, prob, sets, J, kinds[J])
        S = rows(prob, sets, u.idx[: u.m]) @ u.Wt[: u.m].T
        g = np.ones(u.m)
        t = capacitance_solver(u, "singular")(g)
        assert np.allclose(t, np.linalg.solve(S, g), rtol=0, atol=1e-12 * np.abs(t).max())
        return u

    monkeypatch.setattr(activeset, "BORDER_FRACTION", 0.2)
    u = step(6, 34)  # |J| = 16 rows (8 pairs)
    u = step(6, 33)  # 2 rows leave, but |J| = 14 < BORDER_MIN_RANK
    assert (u.factored, u.bordered) == (2, 0)
    monkeypatch.setattr(activeset, "BORDER_MIN_RANK", 0)
    u = step(6, 34)  # 2 rows enter: border 2 <= 0.2 * 16
    assert (u.factored, u.bordered) == (2, 1)
    u = step(9, 31)  # 10 rows leave: border 12 > 0.2 * 6
    assert (u.factored, u.bordered) == (3, 1)
    monkeypatch.setattr(activeset, "BORDER_FRACTION", 0.5)
    # below any residual, an exact zero included (some BLAS kernels give one here)
    monkeypatch.setattr(activeset, "BORDER_BACKWARD_ERROR", -1.0)
    u = step(9, 32)  # 2 rows enter: a bordered solve, rejected
    assert (u.factored, u.bordered) == (4, 2)


@pytest.mark.parametrize("perturbation", [0.0, 1e-15])
def test_singular_capacitance_is_factorised_afresh_and_raises_not_converged(perturbation,
                                                                          monkeypatch):
    """Where a bordered solve would apply, an S that is singular to working precision (a row
    that repeats another one, up to a relative ``perturbation``) is factorised afresh
    (:data:`SCHUR_PIVOT`), and an exactly singular one raises NotConverged from its LU, as
    without bordered solves."""
    from fem import activeset
    from fem.activeset import NotConverged, capacitance_solver, update

    monkeypatch.setattr(activeset, "BORDER_FRACTION", 1.0)
    monkeypatch.setattr(activeset, "BORDER_MIN_RANK", 0)
    n = 20
    prob = problem(n, lock_theta=False)
    ref = factor_reference(prob, zone_sets(n, 6, 14))
    for lo in (7, 8):
        sets = zone_sets(n, lo, 14)
        kinds = sets.kinds(prob.n_plate)
        J = np.flatnonzero(ref.kinds != kinds)
        u = update(ref, prob, sets, J, kinds[J])
        if lo == 7:
            capacitance_solver(u, "singular")(np.ones(u.m))
            continue
        assert activeset.bordered(u.base, u, "singular") is not None
        new = np.flatnonzero(u.idx[: u.m] % n == 7)[0]
        same = u.S[np.flatnonzero(u.idx[: u.m] % n == 6)[0], : u.m]
        u.S[new, : u.m] = same * (1.0 + perturbation * np.linspace(-1.0, 1.0, u.m))
        assert activeset.bordered(u.base, u, "singular") is None
        if perturbation:
            capacitance_solver(u, "singular")(np.ones(u.m))
        else:
            with pytest.raises(NotConverged, match="singular"):
                capacitance_solver(u, "singular")(np.ones(u.m))
    assert (u.factored, u.bordered) == (1 + bool(perturbation), 0)


@pytest.mark.parametrize("coupling", [0.0, 0.2])
def test_reference_solves_of_unit_and_zero_columns_equal_dense_solves(coupling):
    """The columns ``A0^{-1} e_j`` of tangential, normal, open and plate rows and zero
    columns (a block's solve skips the columns of its right-hand side that are zero)."""
    n = 40
    prob = problem(n, lock_theta=False, coupling=coupling)
    N = 2 * n + prob.n_plate
    sets = zone_sets(n, 8, 32, slip=5, sign=-1.0)
    ref = factor_reference(prob, sets)
    cols = np.array([3, 9, 20, n + 9, n + 20, n + 35, 2 * n, 2 * n + 2])
    B = np.zeros((N, cols.size + 2))
    B[cols, np.arange(cols.size)] = 1.0
    X = ref.solve(prob, B)
    A = rows(prob, sets, np.arange(N))
    assert np.allclose(X, np.linalg.solve(A, B), rtol=0, atol=1e-12 * np.abs(X).max())
    assert np.all(X[:, cols.size :] == 0.0)
    if coupling == 0.0:  # the tangential columns have no normal part
        assert np.all(X[n : 2 * n, :3] == 0.0)
