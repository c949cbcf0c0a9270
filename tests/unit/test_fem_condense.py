"""Per-body Schur condensation (CHOLMOD) equals the compliance from blocked solves; the
recovery's backward-only pair solves equal a coupled solve."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp

import fem
from fem.bulk import reduced_bodies, reduced_stiffness, split_stiffness
from fem.condense import body_blocks, compliance, condense, mirror_lower, pair_loads
from fem.fields import FieldRecovery
from fem.history import assemble_bodies, build_model, load_schedule, resolve_contact, run_increments
from fem.linsolve import available_backends, factorize

pytestmark = pytest.mark.skipif("cholmod" not in available_backends(),
                                reason="the Schur path needs CHOLMOD (scikit-sparse)")


def laplacian(m: int) -> sp.csc_matrix:
    """SPD 2-D grid Laplacian (Dirichlet) of m x m nodes."""
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(m, m))
    return (sp.kron(T, sp.eye(m)) + sp.kron(sp.eye(m), T)).tocsc()


def pairs(m: int, offset: int) -> np.ndarray:
    """Dofs of the first grid row of a body (its 'interface'), offset into the global K."""
    return offset + np.arange(m)


def test_uncoupled_bodies_give_the_blocked_solve_compliance():
    m = 12
    K = sp.block_diag([laplacian(m), 2.0 * laplacian(m)], format="csc")
    f1, f2 = pairs(m, 0), pairs(m, m * m)
    assert body_blocks(K, f1, f2) is not None
    factor, C = condense(K, f1, f2, "cholmod")
    ref = compliance(factorize(K, "scipy-splu"), f1, f2)
    assert np.array_equal(C, C.T)
    assert np.allclose(C, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())
    b = np.random.default_rng(0).normal(size=(K.shape[0], 3))
    assert np.allclose(K @ factor.solve(b), b)


def test_coupled_bodies_fall_back_to_blocked_solves():
    m = 10
    K = sp.block_diag([laplacian(m), laplacian(m)], format="lil")
    K[m - 1, m * m] = K[m * m, m - 1] = -0.5  # one spring between the two bodies
    K = K.tocsc()
    f1, f2 = pairs(m, 0), pairs(m, m * m)
    assert body_blocks(K, f1, f2) is None
    _, C = condense(K, f1, f2, "cholmod")
    ref = compliance(factorize(K, "scipy-splu"), f1, f2)
    assert np.allclose(C, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())


@pytest.mark.parametrize("m", [5, 600])  # one row block, and several (RHS_BLOCK = 256)
def test_mirror_lower_copies_the_lower_triangle(m):
    lower = np.tril(np.random.default_rng(m).normal(size=(m, m)))
    A = lower.copy()
    mirror_lower(A)
    assert np.array_equal(A, A.T)
    assert np.array_equal(np.tril(A), lower)


def coupled_solve(K: sp.csc_matrix, f1: np.ndarray, f2: np.ndarray, lam: np.ndarray
                  ) -> np.ndarray:
    """Reference: the pair loads solved with the whole K by SuperLU (no per-body factor)."""
    return factorize(K, "scipy-splu").solve(pair_loads(K.shape[0], f1, f2, lam))


def test_pair_solve_equals_a_coupled_solve():
    m = 12
    K = sp.block_diag([laplacian(m), 2.0 * laplacian(m)], format="csc")
    f1, f2 = pairs(m, 0), pairs(m, m * m)
    factor, C = condense(K, f1, f2, "cholmod")
    lam = np.random.default_rng(1).normal(size=(m, 5))
    ref = coupled_solve(K, f1, f2, lam)
    got = factor.pair_solve(lam)
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
    assert np.allclose(got[f1] - got[f2], C @ lam, rtol=0, atol=1e-12 * np.abs(ref).max())
    one = factor.pair_solve(lam[:, 0])  # one load case as a 1-D vector
    assert np.allclose(one[:, 0], got[:, 0], rtol=0, atol=1e-15 * np.abs(ref).max())


@pytest.mark.parametrize("backend", available_backends())
def test_every_backend_has_a_pair_solve(backend):
    m = 8
    K = sp.block_diag([laplacian(m), laplacian(m)], format="csc")
    f1, f2 = pairs(m, 0), pairs(m, m * m)
    factor, _ = condense(K, f1, f2, backend)
    lam = np.random.default_rng(2).normal(size=(m, 3))
    ref = coupled_solve(K, f1, f2, lam)
    assert np.allclose(factor.pair_solve(lam), ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    rows = np.random.default_rng(4).permutation(K.shape[0] + 7)[: K.shape[0]]
    out = np.full((K.shape[0] + 7, 3), 5.0)  # written in place: rows[i] gets dof i
    assert factor.pair_solve(lam, out=out, rows=rows) is out
    assert np.array_equal(out[rows], factor.pair_solve(lam))
    assert np.all(np.delete(out, rows, axis=0) == 5.0)
    start = np.random.default_rng(1).normal(size=out.shape)  # add: onto what out holds
    added = factor.pair_solve(lam, out=start.copy(), rows=rows, add=True)
    want = start.copy()
    want[rows] += factor.pair_solve(lam)
    assert np.array_equal(added, want)


def test_recovered_fields_equal_a_coupled_solve_on_a_small_mesh():
    """FieldRecovery's backward-only solves against SuperLU of the whole bulk, with the
    half-plane far field and the plate's rigid motion, for every increment."""
    P0, mu, E, nu = 0.01, 0.5, 1.0, 0.3
    a = np.sqrt(2 * 3.64 * 0.01 * 100 / np.pi)
    window = (-1.3 * a, 1.3 * a)
    timings: dict = {}
    mesh = fem.MeshSpec(level=-2)
    tbm, _, disc = assemble_bodies(mesh, window, (), E, nu, timings)
    settings = resolve_contact(None, E, tbm.h_min)
    model = build_model(*split_stiffness(disc)[::-1], lambda x: x**2 / 200.0, mu, window,
                        settings, True, "cholmod", timings)
    schedule = load_schedule(P0, 0.002, None, fem.LoadPath(n_normal=2, n_tangential=2))
    states = run_increments(model.prob, schedule, settings, None)
    got = FieldRecovery.from_states(model, states)
    splu = factorize(reduced_stiffness(disc, model.free), "scipy-splu")
    ref = FieldRecovery.from_states(replace(model, factor=splu), states)
    for body in (0, 1):
        scale = np.max(np.abs(ref.U[body]))
        assert np.max(np.abs(got.U[body] - ref.U[body])) <= 1e-10 * scale
    for i in range(len(states)):
        r_got, r_ref = np.array(got.reactions(i)), np.array(ref.reactions(i))
        assert np.allclose(r_got, r_ref, rtol=0, atol=1e-10 * P0)


@pytest.mark.parametrize("layout", ["tensor", "rings"])
def test_recovery_by_blocks_of_increments_equals_all_at_once_bit_for_bit(monkeypatch, layout):
    """The recovery's backward sweeps by blocks of increments (22 increments: blocks 8 + 8 +
    6, and of RECOVERY_BLOCK) give the numbers of one block of all increments bit for bit
    (tensor: two factors; rings: body 2 the mirror of body 1; the far field and the plate's
    motion are added by rows, fem.fields.add_motions), and the model's stiffness rows of the
    top give the reactions of the whole stiffness."""
    import fem.condense as cd

    P0, mu, E, nu = 0.01, 0.5, 1.0, 0.3
    a = np.sqrt(2 * 3.64 * 0.01 * 100 / np.pi)
    window = (-1.3 * a, 1.3 * a)
    timings: dict = {}
    tbm, _, disc = assemble_bodies(fem.MeshSpec(level=-2, layout=layout), window, (), E, nu,
                                   timings)
    settings = resolve_contact(None, E, tbm.h_min)
    bulk, bare = split_stiffness(disc)
    model = build_model(bare, bulk, lambda x: x**2 / 200.0, mu, window, settings, True,
                        "cholmod", timings)
    assert model.disc.stiffness is None and disc.stiffness is not None  # the caller's stays
    assert bulk.bodies == []  # handed to the factorisation
    schedule = load_schedule(P0, 0.002, None, fem.LoadPath(n_normal=4, n_tangential=6))
    states = run_increments(model.prob, schedule, settings, None)
    assert len(states) == 22 and cd.column_blocks(22, 8) == [slice(0, 8), slice(8, 16),
                                                             slice(16, 22)]
    default = FieldRecovery.from_states(model, states)
    monkeypatch.setattr(cd, "RECOVERY_BLOCK", 8)
    got = FieldRecovery.from_states(model, states)
    monkeypatch.setattr(cd, "RECOVERY_BLOCK", len(states))
    ref = FieldRecovery.from_states(model, states)
    whole = FieldRecovery(disc, *ref.U)  # reactions from the whole K1 of the caller's disc
    for body in (0, 1):
        assert np.array_equal(got.U[body], ref.U[body])
        assert np.array_equal(default.U[body], ref.U[body])
    assert np.array_equal(got._reactions, whole._reactions)


def test_nested_dissection_ordering_of_large_bodies_gives_the_same_compliance(monkeypatch):
    import fem.condense as cd

    m = 12
    K = sp.block_diag([laplacian(m), 2.0 * laplacian(m)], format="csc")
    f1, f2 = pairs(m, 0), pairs(m, m * m)
    monkeypatch.setattr(cd, "NESDIS_MIN_DOFS", 0)  # every body takes INNER_ORDERING
    factor, C = condense(K, f1, f2, "cholmod")
    ref = compliance(factorize(K, "scipy-splu"), f1, f2)
    assert np.allclose(C, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())
    b = np.random.default_rng(1).normal(size=(K.shape[0], 2))
    assert np.allclose(K @ factor.solve(b), b)


def elastic_like(m: int) -> sp.csc_matrix:
    """SPD stiffness-like matrix with two interleaved dofs (x, y) per node of an m x m grid."""
    return sp.kron(laplacian(m), np.array([[2.0, 0.5], [0.5, 2.0]])).tocsc()


def test_a_mirror_body_reuses_the_first_factor_and_gives_the_same_compliance():
    import fem.condense as cd

    m = 10
    K1 = elastic_like(m)
    d = np.tile([1.0, -1.0], m * m)  # the mirror flips the y dofs
    K2 = (sp.diags(d) @ K1 @ sp.diags(d)).tocsc()
    K = sp.block_diag([K1, K2], format="csc")
    f1, f2 = pairs(2 * m, 0), pairs(2 * m, 2 * m * m)
    assert np.array_equal(cd.mirror_signs(K1, K2, f1, f2 - 2 * m * m), d)
    factor, C = condense(K, f1, f2, "cholmod")
    ref = compliance(factorize(K, "scipy-splu"), f1, f2)
    assert np.allclose(C, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())
    assert np.array_equal(C, C.T)
    b = np.random.default_rng(2).normal(size=(K.shape[0], 3))
    assert np.allclose(K @ factor.solve(b), b)
    assert np.allclose(K @ factor.solve(b[:, 0]), b[:, 0])
    lam = np.random.default_rng(4).normal(size=(f1.size, 3))  # the recovery's backward solves
    ref_u = coupled_solve(K, f1, f2, lam)
    assert np.max(np.abs(factor.pair_solve(lam) - ref_u)) <= 1e-12 * np.abs(ref_u).max()


@pytest.mark.parametrize("m", [5, 300])
def test_flip_add_on_the_lower_triangle_then_mirror_lower_gives_c_plus_dcd(m):
    """The mirror body's compliance D C D added on potri's lower triangle (upper zero), then
    mirrored: exactly C + D C D."""
    from fem.condense import flip_add

    rng = np.random.default_rng(m)
    A = rng.normal(size=(m, m))
    C = A + A.T
    d = rng.choice([-1.0, 1.0], size=m)
    got = np.tril(C)
    flip_add(got, d)
    mirror_lower(got)
    assert np.array_equal(got, C + d[:, None] * C * d[None, :])


@pytest.mark.parametrize(("d", "k"), [([1, 1, -1, -1, -1], 2), ([-1, 1, 1], 1), ([1, 1], None),
                                      ([1, -1, 1], None), ([1, -1, -1, 1], None), ([], None)])
def test_sign_split_finds_one_sign_then_the_other(d, k):
    from fem.condense import sign_split

    assert sign_split(np.array(d, dtype=float)) == k


@pytest.mark.parametrize(("m", "k"), [(6, 3), (7, 2), (300, 150), (301, 120)])
def test_mirror_compliance_is_potri_plus_its_flip_to_rounding(m, k):
    """The block-diagonal route gives potri's C + D C D (D = +1 on the first k dofs, -1 on
    the rest) on the lower triangle to rounding, zero between the blocks, in L22's place."""
    from scipy.linalg.lapack import dpotri

    from fem.condense import flip_add, mirror_compliance

    rng = np.random.default_rng(m)
    L22 = np.asfortranarray(np.tril(rng.normal(size=(m, m))) / np.sqrt(m))
    L22[np.diag_indices(m)] = 1.0 + rng.random(m)
    ref, info = dpotri(L22.copy(order="F"), lower=1)
    assert info == 0
    flip_add(ref, np.r_[np.ones(k), -np.ones(m - k)])
    ref = np.tril(ref)
    got = mirror_compliance(L22, k)
    assert got is L22 and got.flags.f_contiguous
    got = np.tril(got)
    assert not got[k:, :k].any()
    assert np.max(np.abs(got - ref)) <= 1e-13 * np.abs(ref).max()


class CountingFactor:
    """A CHOLMOD factor that records the shape of every right-hand side it solves."""

    def __init__(self, chol, calls: list):
        self.chol, self.calls = chol, calls

    def __call__(self, b):
        self.calls.append(np.shape(b))
        return self.chol(b)

    def __getattr__(self, name):
        return getattr(self.chol, name)


@pytest.mark.parametrize("k", [1, 3])
def test_a_mirror_body_is_solved_with_its_original_in_one_pass(monkeypatch, k):
    """``solve`` hands both bodies' right-hand sides to the shared factor at once (the
    far-field lift's solves: one pass through the factor, not two), with the same answer."""
    import fem.condense as cd

    m = 10
    K1 = elastic_like(m)
    d = np.tile([1.0, -1.0], m * m)
    K = sp.block_diag([K1, (sp.diags(d) @ K1 @ sp.diags(d)).tocsc()], format="csc")
    f1, f2 = pairs(2 * m, 0), pairs(2 * m, 2 * m * m)
    calls = []
    monkeypatch.setattr(cd, "natural_cholesky",
                        lambda *a, f=cd.natural_cholesky: CountingFactor(f(*a), calls))
    factor, _ = condense(K, f1, f2, "cholmod")
    b = np.random.default_rng(6).normal(size=(K.shape[0], k))
    calls.clear()
    x = factor.solve(b)
    assert calls == [(2 * m * m, 2 * k)]
    assert np.max(np.abs(K @ x - b)) <= 1e-12 * np.abs(b).max()
    assert factor.solve(b[:, 0]).shape == b[:, 0].shape


def test_no_mirror_when_the_bodies_differ():
    import fem.condense as cd

    K1 = elastic_like(6)
    g = np.arange(12)
    assert cd.mirror_signs(K1, (2.0 * K1).tocsc(), g, g) is None  # not D K1 D
    K2 = K1.copy()
    K2.data[0] *= 1 + 1e-9  # off by more than rounding
    assert cd.mirror_signs(K1, K2, g, g) is None
    assert cd.mirror_signs(K1, K1, g, g + 1) is None  # pair dofs elsewhere
    assert np.array_equal(cd.mirror_signs(K1, K1, g, g), np.ones(K1.shape[0]))


def test_ring_mesh_bodies_share_one_factor_and_match_two_factorisations(monkeypatch):
    """The generated ring meshes are mirror images: one CHOLMOD factorisation serves both
    bodies, and C and the solves agree with two separate factorisations to rounding."""
    import fem
    import fem.condense as cd
    from fem.bulk import discretise, free_dofs, reduced_stiffness
    from fem.mesh import build_mesh

    tbm = build_mesh(fem.MeshSpec(level=0, layout="rings"), (-0.2, 0.2))
    disc = discretise(tbm, 1, 1.0, 0.3, "half-plane")
    free, index = free_dofs(disc)
    cand = np.flatnonzero(np.abs(disc.interface.x) <= 0.3)
    f1, f2 = cd.pair_dofs(disc, index, cand)
    K = reduced_stiffness(disc, free)
    calls = []
    monkeypatch.setattr(cd, "natural_cholesky",
                        lambda *a, f=cd.natural_cholesky: calls.append(1) or f(*a))
    one, C1 = condense(K, f1, f2, "cholmod")
    assert len(calls) == 1
    monkeypatch.setattr(cd, "mirror_signs", lambda *a: None)
    two, C2 = condense(K, f1, f2, "cholmod")
    assert len(calls) == 3
    assert np.max(np.abs(C1 - C2)) <= 1e-12 * np.max(np.abs(C2))
    b = np.random.default_rng(3).normal(size=(K.shape[0], 2))
    assert np.max(np.abs(one.solve(b) - two.solve(b))) <= 1e-10 * np.max(np.abs(two.solve(b)))
    lam = np.random.default_rng(5).normal(size=(f1.size, 2))
    ref_u = two.pair_solve(lam)
    assert np.max(np.abs(one.pair_solve(lam) - ref_u)) <= 1e-10 * np.max(np.abs(ref_u))


def ring_discretisation(boundary: str = "half-plane"):
    from fem.bulk import discretise, free_dofs
    from fem.mesh import build_mesh

    tbm = build_mesh(fem.MeshSpec(level=0, layout="rings"), (-0.2, 0.2))
    disc = discretise(tbm, 1, 1.0, 0.3, boundary)
    free, index = free_dofs(disc)
    return disc, free, index


def same_sparse(A, B) -> bool:
    return (A.shape == B.shape and np.array_equal(A.indptr, B.indptr)
            and np.array_equal(A.indices, B.indices) and np.array_equal(A.data, B.data))


def test_reduced_bodies_are_the_blocks_of_the_reduced_stiffness_bit_for_bit():

    disc, free, _ = ring_discretisation()
    K = reduced_stiffness(disc, free)
    K1, K2 = reduced_bodies(disc, free)
    n1 = K1.shape[0]
    assert n1 + K2.shape[0] == K.shape[0]
    assert same_sparse(K1, K[:n1][:, :n1].tocsc())
    assert same_sparse(K2, K[n1:][:, n1:].tocsc())
    assert K[:n1][:, n1:].nnz == 0


def ring_pairs_with_a_condense_spy(monkeypatch):
    """``(disc, free, f1, f2, calls)`` of a small ring mesh; ``calls`` grows by one per call
    of ``fem.condense.condense`` (the whole-K path)."""
    import fem.condense as cd

    disc, free, index = ring_discretisation()
    cand = np.flatnonzero(np.abs(disc.interface.x) <= 0.3)
    f1, f2 = cd.pair_dofs(disc, index, cand)
    calls = []
    monkeypatch.setattr(cd, "condense", lambda *a, f=cd.condense: calls.append(1) or f(*a))
    return disc, free, f1, f2, calls


def test_condense_bodies_gives_the_numbers_of_condense_on_the_whole_stiffness(monkeypatch):
    import fem.condense as cd

    disc, free, f1, f2, calls = ring_pairs_with_a_condense_spy(monkeypatch)
    factor, C = cd.condense_bodies(reduced_bodies(disc, free), f1, f2, "cholmod")
    assert calls == []  # the bodies went straight to the per-body factors
    ref_factor, ref_C = condense(reduced_stiffness(disc, free), f1, f2, "cholmod")
    assert np.array_equal(C, ref_C)
    lam = np.random.default_rng(2).normal(size=(f1.size, 3))
    assert np.array_equal(factor.pair_solve(lam), ref_factor.pair_solve(lam))
    b = np.random.default_rng(4).normal(size=(free.size, 2))
    assert np.array_equal(factor.solve(b), ref_factor.solve(b))


def test_condense_bodies_falls_back_to_the_whole_stiffness_off_cholmod(monkeypatch):
    import fem.condense as cd

    disc, free, f1, f2, calls = ring_pairs_with_a_condense_spy(monkeypatch)
    bodies = reduced_bodies(disc, free)
    assert same_sparse(sp.block_diag(bodies, format="csc"), reduced_stiffness(disc, free))
    _, C = cd.condense_bodies(bodies, f1, f2, "scipy-splu")
    assert calls == [1] and bodies == []
    _, ref = cd.condense(reduced_stiffness(disc, free), f1, f2, "cholmod")
    assert np.allclose(C, ref, rtol=1e-10, atol=1e-12 * np.abs(ref).max())


def test_split_stiffness_gives_the_blocks_of_the_whole_stiffness_bit_for_bit():
    from fem.farfield import coupling_loads

    disc, free, _ = ring_discretisation()
    fixed = np.r_[disc.fixed[0], disc.fixed[1] + disc.bases[0].N]
    G = np.random.default_rng(6).normal(size=(fixed.size, 4))
    K = sp.block_diag(disc.stiffness, format="csr")
    bulk, bare = split_stiffness(disc)
    assert np.array_equal(coupling_loads(bulk.coupling, G), K[free][:, fixed] @ G)
    assert bare.stiffness is None and disc.stiffness is not None
    assert np.array_equal(bulk.free, free)
    assert same_sparse(bulk.reaction_rows, disc.stiffness[0][disc.fixed[0]])
    for got, ref in zip(bulk.bodies, reduced_bodies(disc, free), strict=True):
        assert same_sparse(got, ref)


def identical_neighbours(K: sp.csc_matrix, off: np.ndarray) -> np.ndarray:
    """Dofs i (both i and i + 1 in ``off``) whose column in K has the pattern of i + 1's."""
    ptr, ind = K.indptr, K.indices
    return np.array([i for i in range(K.shape[0] - 1) if off[i] and off[i + 1]
                     and np.array_equal(ind[ptr[i]:ptr[i + 1]], ind[ptr[i + 1]:ptr[i + 2]])])


@pytest.mark.parametrize("nesdis", [True, False])
def test_body_order_keeps_a_nodes_two_dofs_together_and_the_pair_dofs_last(monkeypatch, nesdis):
    """The ordering is of the node graph: on a ring-mesh body every free node's x and y dofs
    (consecutive dofs with one pattern) are eliminated one right after the other."""
    import fem.condense as cd

    disc, free, f1, _, _ = ring_pairs_with_a_condense_spy(monkeypatch)
    K1, _ = reduced_bodies(disc, free)
    monkeypatch.setattr(cd, "NESDIS_MIN_DOFS", 0 if nesdis else K1.shape[0] + 1)
    perm = cd.body_order(K1, f1)
    n = K1.shape[0]
    assert np.array_equal(np.sort(perm), np.arange(n)) and np.array_equal(perm[-f1.size:], f1)
    off = np.ones(n, dtype=bool)
    off[f1] = False
    pairs_ = identical_neighbours(K1, off)
    assert pairs_.size >= 0.4 * n  # most dofs are a free node's pair
    pos = np.empty(n, dtype=int)
    pos[perm] = np.arange(n)
    assert np.array_equal(pos[pairs_ + 1], pos[pairs_] + 1)


def test_dof_groups_are_runs_of_one_pattern_on_one_side_of_the_pair_dofs():
    from fem.condense import dof_groups

    K = elastic_like(4)  # 16 nodes, dofs 2k and 2k + 1 share their pattern
    assert np.array_equal(dof_groups(K, np.array([], dtype=int)), np.arange(32) // 2)
    gid = dof_groups(K, np.array([5]))  # node 2's y dof a pair dof: node 2 splits
    assert np.array_equal(gid[:8], [0, 0, 1, 1, 2, 3, 4, 4]) and gid[-1] == 16
    keep = np.r_[0:7, 8:32]  # node 3's y dof removed (prescribed): its x dof alone
    gid = dof_groups(K[keep][:, keep].tocsc(), np.array([], dtype=int))
    assert np.array_equal(gid[:9], [0, 0, 1, 1, 2, 2, 3, 4, 4]) and gid[-1] == 15


def groups_by_columns(K: sp.csc_matrix, gamma: np.ndarray) -> np.ndarray:
    """dof_groups' definition column by column: dof i + 1 joins dof i's group when both have
    the same row indices (sorted) and lie on the same side of gamma."""
    on = np.isin(np.arange(K.shape[0]), gamma)
    col = [K.indices[K.indptr[i]:K.indptr[i + 1]] for i in range(K.shape[0])]
    joins = [np.array_equal(col[i], col[i + 1]) and on[i] == on[i + 1]
             for i in range(K.shape[0] - 1)]
    return np.r_[0, np.cumsum(~np.array(joins, dtype=bool))]


@pytest.mark.parametrize("seed", range(6))
def test_dof_groups_equal_the_column_by_column_definition(seed):
    """Random patterns with runs of repeated columns, columns of unequal counts side by side
    (the vectorised comparison reads past a shorter neighbour), an empty column, the last
    column longer than the one before it."""
    from fem.condense import dof_groups

    rng = np.random.default_rng(seed)
    n = 40
    cols = []
    while len(cols) < n:
        rows = np.sort(rng.choice(n, size=rng.integers(1, 6), replace=False))
        cols += [rows] * int(rng.integers(1, 4))
        if rng.random() < 0.3:  # same count, different rows
            cols.append(np.sort(np.r_[rows[:-1], (rows[-1] + 1) % n]))
    cols = cols[:n - 2] + [np.array([], dtype=int), np.arange(0, n, 3)]
    indptr = np.r_[0, np.cumsum([c.size for c in cols])]
    K = sp.csc_matrix((np.ones(indptr[-1]), np.concatenate(cols), indptr), shape=(n, n))
    K.has_sorted_indices = True
    gamma = np.sort(rng.choice(n, size=5, replace=False))
    for g in (gamma, np.array([], dtype=int)):
        assert np.array_equal(dof_groups(K, g), groups_by_columns(K, g))


def test_node_graph_ordering_gives_the_compliance_of_a_reference_solve(monkeypatch):
    """Ring-mesh bodies ordered by nested dissection of the node graph: C and the solves
    agree with SuperLU on the whole stiffness to rounding."""
    import fem.condense as cd

    disc, free, f1, f2, _ = ring_pairs_with_a_condense_spy(monkeypatch)
    monkeypatch.setattr(cd, "NESDIS_MIN_DOFS", 0)
    factor, C = cd.condense_bodies(reduced_bodies(disc, free), f1, f2, "cholmod")
    K = reduced_stiffness(disc, free)
    ref = compliance(factorize(K, "scipy-splu"), f1, f2)
    assert np.max(np.abs(C - ref)) <= 1e-11 * np.abs(ref).max()
    b = np.random.default_rng(7).normal(size=(free.size, 2))
    assert np.max(np.abs(K @ factor.solve(b) - b)) <= 1e-10 * np.abs(b).max()


@pytest.mark.parametrize("panel", [1, 7, 256])
def test_triangular_solve_by_panels_is_the_whole_solve_to_rounding(monkeypatch, panel):
    """trailing_solve reads L22 a panel at a time (of 1, 7 and more than its 50 columns):
    dtrsm's solution on the whole triangle, to rounding."""
    from scipy.linalg import solve_triangular
    from scipy.linalg.lapack import dtrttp

    import fem.condense as cd

    monkeypatch.setattr(cd, "TRIANGLE_PANEL", panel)
    rng = np.random.default_rng(8)
    m = 50
    L = np.asfortranarray(np.tril(rng.normal(size=(m, m))) / np.sqrt(m) + 2.0 * np.eye(m))
    packed, _ = dtrttp(L, uplo="L")
    f = rng.normal(size=(m, 5))
    ref = solve_triangular(L, f, lower=True)
    got = cd.trailing_solve(cd.panel_reader(None, m, m, packed), f)
    assert np.max(np.abs(got - ref)) <= 1e-14 * np.max(np.abs(ref))


def test_pair_solves_reading_the_factor_in_place_equal_those_of_a_packed_copy(monkeypatch):
    """The recovery's triangular solves read L22 from the factor (no copy kept) or, for a
    factor fem.supernodal cannot read, from a packed copy: the same numbers bit for bit."""
    import fem.condense as cd

    disc, free, f1, f2, _ = ring_pairs_with_a_condense_spy(monkeypatch)
    monkeypatch.setattr(cd, "TRIANGLE_PANEL", 64)  # several panels of the 2 x 2n pair dofs
    factor, C = cd.condense_bodies(reduced_bodies(disc, free), f1, f2, "cholmod")
    monkeypatch.setattr(cd, "trailing_block", lambda *a: None)  # the chol.L() fallback
    copied, C_ref = cd.condense_bodies(reduced_bodies(disc, free), f1, f2, "cholmod")
    assert f1.size > 64 and np.array_equal(C, C_ref)
    lam = np.random.default_rng(9).normal(size=(f1.size, 5))
    assert np.array_equal(factor.pair_solve(lam), copied.pair_solve(lam))


@pytest.mark.parametrize("layout", ["tensor", "rings"])
def test_the_far_field_lift_by_blocks_solves_the_bulk_equations(monkeypatch, layout):
    """fem.farfield.lift, its 2 ORDERS solves by blocks of LIFT_BLOCK columns: the lifted
    fields take the Flamant data on the prescribed dofs and solve K u = 0 on the free ones
    (the caller's whole stiffness), and one block of all columns gives the same fields."""
    import fem.farfield as ff

    E, nu = 1.0, 0.3
    a = np.sqrt(2 * 3.64 * 0.01 * 100 / np.pi)
    window = (-1.3 * a, 1.3 * a)
    tbm, _, disc = assemble_bodies(fem.MeshSpec(level=-2, layout=layout), window, (), E, nu, {})
    settings = resolve_contact(None, E, tbm.h_min)

    def far_fields() -> np.ndarray:
        bulk, bare = split_stiffness(disc)
        model = build_model(bare, bulk, lambda x: x**2 / 200.0, 0.5, window, settings, True,
                            "cholmod", {})
        return model.far.fields, model.free

    assert 0 < ff.LIFT_BLOCK < 2 * ff.ORDERS
    blocks, free = far_fields()
    monkeypatch.setattr(ff, "LIFT_BLOCK", 2 * ff.ORDERS)
    whole, _ = far_fields()
    assert np.allclose(blocks, whole, rtol=0, atol=1e-13 * np.abs(whole).max())
    K = sp.block_diag(disc.stiffness, format="csr")
    residual = (K @ blocks)[free]
    assert np.abs(residual).max() <= 1e-9 * np.abs(K @ np.where(
        np.isin(np.arange(K.shape[0]), free)[:, None], 0.0, blocks)).max()
