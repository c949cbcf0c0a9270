"""The low-rank-updated active-set solves (fem.activeset) equal direct dense solves."""

from __future__ import annotations

import numpy as np
import pytest

from fem.activeset import OPEN, SLIP, STICK, ActiveSetSolver, make_sets, matvec, rows
from fem.contact import InterfaceProblem

#: Relative residual of an updated solve: one refinement step brings it to rounding
#: (measured 1e-15 .. 4e-14 on these problems).
RESIDUAL_TOL = 1e-12


def problem(n: int, lock_theta: bool) -> InterfaceProblem:
    """A half-plane-like interface: SPD log-kernel compliance, uncoupled t and n blocks."""
    x = np.linspace(-1.0, 1.0, n)
    w = np.full(n, x[1] - x[0])
    r = np.abs(x[:, None] - x[None, :]) + 0.3 * w[0]
    block = np.log(8.0 / r) * w[None, :] / np.pi
    C = np.zeros((2 * n, 2 * n))
    C[:n, :n] = block
    C[n:, n:] = block
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


@pytest.mark.parametrize("lock_theta", [True, False])
def test_updated_solves_equal_direct_solves(lock_theta):
    n = 60
    prob = problem(n, lock_theta)
    rng = np.random.default_rng(3)
    solver = ActiveSetSolver(prob)
    N = 2 * n + prob.n_plate
    walk = status_walk(n, 30, rng)
    for status, sign in walk:
        sets = make_sets(status, sign)
        A = rows(prob, sets, np.arange(N))
        b = rng.normal(size=N)
        b[: 2 * n][np.r_[status, status] == OPEN] = 0.0  # open rows say lam = 0
        x, d = solver.solve(sets, b)
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
        ActiveSetSolver(prob).solve(sets, np.ones(2 * 20 + 3))


def test_capacitance_reuses_entries_of_the_last_update():
    """A[J] W from the last update's entries where row (index and kind) and column match,
    the rest computed: equal to the full product, whichever rows changed kind."""
    from fem.activeset import factor_reference

    n = 40
    prob = problem(n, lock_theta=True)
    status = np.full(n, OPEN, np.int8)
    status[10:30] = STICK
    ref = factor_reference(prob, make_sets(status, np.ones(n)))
    for k, (lo, hi, slip) in enumerate(((8, 30, 0), (8, 32, 2), (6, 32, 4), (6, 33, 4))):
        st = np.full(n, OPEN, np.int8)
        st[lo:hi] = STICK
        st[lo : lo + slip] = SLIP
        sets = make_sets(st, -np.ones(n))
        J = np.flatnonzero(ref.kinds != sets.kinds(prob.n_plate))
        W, AJ = ref.block(prob, J), rows(prob, sets, J)
        reused = ref.last is not None and np.isin(J, ref.last[0]).any()
        S = ref.capacitance(AJ, W, J, sets.kinds(prob.n_plate)[J])
        assert reused == (k > 0)
        assert np.allclose(S, AJ @ W, rtol=0, atol=1e-13 * np.abs(AJ @ W).max())
    lJ, lk, lS = ref.last
    ref.last = (lJ, lk, lS + 1.0)  # the same J and kinds again: every entry comes from the cache
    assert np.array_equal(ref.capacitance(AJ, W, J, sets.kinds(prob.n_plate)[J]), lS + 1.0)
