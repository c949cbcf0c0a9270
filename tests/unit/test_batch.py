"""Unit tests of the batched equations of ``analytic._sie`` (:class:`Batch`): every member of a
batch evaluates what its own one-layout System evaluates, the gap rules planned as affine maps
reproduce the graded rule, and the one-batch finite-difference Jacobian of ``analytic._newton``
matches column-by-column differences."""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import _newton, profiles
from analytic._gap_quadrature import GAP_CHUNK
from analytic._rules import GRADING, graded_rule
from analytic._sie import Batch, Layout, System

ROUNDOFF = 1e-12
"""Same sums in a different order / batch shape: agreement to a few ulps of the sums' scale."""
NODE_ROUNDING = 1e-13
"""``f (1 + tau)/2`` against ``f/2 + f tau/2``: a few ulps of the sub-interval."""
FD_NOISE = 1e-6
"""Forward differences with step 1e-7 of the zone width: rounding ~1e-9, truncation ~1e-7."""

CASES = {
    "biquadratic": (profiles.biquadratic(1.0, 1.0), 0.5 * np.pi / 4),
    "three cylinders": (profiles.union(profiles.cylinder(1.0, center=-1.5),
                                       profiles.cylinder(0.5, center=0.2, lift=0.01),
                                       profiles.cylinder(2.0, center=1.8, lift=0.03)), 0.5),
    "flat punch + cylinder": (profiles.union(profiles.flat_punch(-2.0, -1.0),
                                             profiles.cylinder(1.0, center=1.0, lift=0.001)), 0.3),
    "double wedge": (profiles.double_wedge(1.0, 0.11, 0.07), 0.1),
}


@pytest.fixture(params=list(CASES), scope="module")
def solved(request):
    prof, P = CASES[request.param]
    return analytic.solve_normal(prof, P, 1.0)


def _members(sol, scale: float = 1e-6, k: int = 3) -> np.ndarray:
    """k edge sets: the solution's and nearby ones (free edges moved by up to ``scale`` of the
    span), all with the same quadrature structure."""
    lay = sol._system.layout
    rng = np.random.default_rng(7)
    span = lay.edges[-1] - lay.edges[0]
    moves = rng.uniform(-1, 1, (k, lay.edges.size)) * scale * span * ~lay.pinned
    moves[0] = 0.0
    return lay.edges + moves


def test_batch_members_equal_their_own_systems(solved) -> None:
    sys0 = solved._system
    edges = _members(solved)
    theta = np.array([0.0, 1e-7, -1e-7])
    batch = Batch.build(sys0.layout, sys0.profile, sys0.A, sys0.xc, edges, theta,
                        np.repeat(sys0.beta[None, :], 3, axis=0))
    ic, (P, M) = batch.interconnections(), batch.load_and_moment()
    for k in range(3):
        one = System.build(sys0.layout.with_edges(edges[k]), sys0.profile, sys0.A, theta[k],
                           sys0.xc, sys0.beta)
        scale = solved.A * solved.P + 1.0
        assert np.allclose(ic[k], one.interconnections(), rtol=0, atol=ROUNDOFF * scale)
        assert P[k] == pytest.approx(one.load_and_moment()[0], rel=ROUNDOFF)
        assert M[k] == pytest.approx(one.load_and_moment()[1], rel=ROUNDOFF, abs=ROUNDOFF)
        if sys0.layout.e > sys0.layout.n:
            mu, norm = batch.consistency()
            mu1, norm1 = one.consistency()
            assert np.allclose(mu[k], mu1, rtol=0, atol=ROUNDOFF * np.max(norm1))


def test_one_member_batch_is_the_system(solved) -> None:
    """System is the one-member batch: its equations at the solution are the solved ones."""
    sys0 = solved._system
    assert np.max(np.abs(sys0.interconnections()), initial=0.0) < 1e-12 * (solved.A * solved.P)
    assert sys0.load() == pytest.approx(solved.P, rel=1e-12) or sys0.layout.e < sys0.layout.n


@pytest.mark.parametrize(("length", "clearance", "pinned"), [
    (0.3, 0.5, False), (2.0, 0.01, False), (1.0, 0.05, True), (0.2, 0.2, False)])
def test_planned_gap_rule_is_the_graded_rule(length: float, clearance: float,
                                             pinned: bool) -> None:
    """The affine plan of a graded part (Gauss-Jacobi on the clearance, geometric Gauss-Legendre
    beyond) gives the nodes and weights of :func:`graded_rule` itself.  The zone left of the
    edge is ``clearance`` wide and the gap 10 wide, so the edge's clearance is ``clearance``."""
    lay = Layout(np.array([-clearance, 0.0, 10.0, 11.0]), np.array([False, pinned, False, False]))
    sys_ = System.build(lay, profiles.cylinder(1e6), 1.0, 0.0, 0.0, np.zeros(0))
    plan = sys_.batch.gap_plan([1], [length])
    assert not plan.far[0]  # a global piece: the graded part reaches the target
    f = min(length, clearance)
    x, w = plan.nodes(lay.edges[None, :], np.array([[f, length, length]]))
    t, w = x[0] - lay.edges[1], w[0]
    t_ref, w_ref = graded_rule(length, clearance, -0.5 if pinned else 0.5)
    i, i_ref = np.argsort(t), np.argsort(t_ref)
    assert np.allclose(t[i], t_ref[i_ref], rtol=0, atol=NODE_ROUNDING * length)
    assert np.allclose(np.abs(w[i]), w_ref[i_ref], rtol=NODE_ROUNDING, atol=0)
    n_sub = int(np.ceil(np.log(length / clearance) / np.log(GRADING))) if length > clearance else 0
    assert np.count_nonzero(t > f) == 24 * n_sub  # Gauss-Legendre sub-intervals beyond f


def test_jacobian_in_one_batch_matches_column_differences(solved) -> None:
    lay, P = solved._system.layout, solved.P
    st = _newton.fresh_state(lay, 0.0, P)
    st.beta = _newton.beta_for(st, solved.A, P)
    for M in (None, solved.M):
        mode = _newton.Mode(P, M)
        F, _ = _newton.residual(st, mode, solved.profile, solved.A)
        z = _newton._pack(st, mode)
        J = _newton._jacobian(z, F, st, mode, solved.profile, solved.A)
        steps = _newton._fd_steps(z, st, mode, solved.profile)
        for j in range(z.size):
            zp = z.copy()
            zp[j] += steps[j]
            trial = _newton._unpack(zp, st, mode, solved.A)
            col = (_newton.residual(trial, mode, solved.profile, solved.A)[0] - F) / steps[j]
            assert np.allclose(J[:, j], col, rtol=0, atol=FD_NOISE * np.max(np.abs(J)))


def test_gap_at_many_points_is_the_gap_point_by_point(solved) -> None:
    """``gap`` on more points than one chunk of gap integrals (GAP_CHUNK, which keeps memory
    linear in the number of points) agrees with one point at a time."""
    e = np.ravel(solved.zones)
    span = e[-1] - e[0]
    x = np.linspace(e[0] - 0.5 * span, e[-1] + 0.5 * span, 3 * GAP_CHUNK + 5)
    g = solved.gap(x)
    one = np.array([solved.gap(x[j:j + 1])[0] for j in range(0, x.size, 7)])
    assert np.allclose(g[::7], one, rtol=0, atol=ROUNDOFF * (solved.A * solved.P + 1.0))
    assert np.count_nonzero(g > 0) > x.size // 4  # the test has teeth: most points are in gaps
