"""Nodal stresses of the full-field recovery: the batched projection (sparse strain operators,
one multi-RHS mass solve) equals skfem's own assembly of the L2 projection, one increment at
a time."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.sparse.linalg import spsolve
from skfem import ElementVector, LinearForm, asm
from skfem.helpers import sym_grad

import fem
from fem.bulk import ELEMENTS, discretise, mass_matrix
from fem.fields import FieldRecovery
from fem.mesh import build_mesh


def reference_stress(disc, body: int, u: np.ndarray) -> np.ndarray:
    """(sxx, syy, sxy, szz) projected with skfem's LinearForm and a sparse direct solve."""
    E, nu = disc.E, disc.nu
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    scalar = disc.scalar_bases[body]
    basis = scalar.with_element(ElementVector(ELEMENTS[disc.order]()))
    M = mass_matrix(scalar).tocsc()
    out = []
    for comp in range(4):
        def form(v, w, comp=comp):
            eps = sym_grad(w["u"])
            tr = eps[0, 0] + eps[1, 1]
            return (lam * tr + 2 * mu * eps[0, 0], lam * tr + 2 * mu * eps[1, 1],
                    2 * mu * eps[0, 1], lam * tr)[comp] * v
        out.append(spsolve(M, asm(LinearForm(form), scalar, u=basis.interpolate(u))))
    return np.array(out)


@pytest.mark.parametrize("order", [1, 2])
def test_batched_stresses_equal_the_projection_of_each_increment(order):
    m = build_mesh(fem.MeshSpec(level=-2, order=order), (-1.0, 1.0))
    disc = discretise(m, order, 2.0, 0.3)
    rng = np.random.default_rng(order)
    U = [rng.normal(size=(b.N, 3)) for b in disc.bases]
    rec = FieldRecovery(disc, *U)
    for body in (0, 1):
        got = rec.body_stresses([2, 0], body)
        for j, i in enumerate((2, 0)):
            ref = reference_stress(disc, body, U[body][:, i])
            assert got[j].shape == ref.shape
            assert np.max(np.abs(got[j] - ref)) <= 1e-10 * np.max(np.abs(ref))
        assert rec.body_stress(2, body) is got[0]  # computed once, then cached
        one = rec.body_stress(1, body)  # a single increment on its own
        ref = reference_stress(disc, body, U[body][:, 1])
        assert np.max(np.abs(one - ref)) <= 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("boundary", ["clamped", "half-plane"])
def test_vector_numbering_and_strains_equal_skfem_vector_basis(order, boundary):
    """VectorDofs (no quadrature data) numbers, places and fixes the dofs exactly as skfem's
    vector basis, and the strain operators from the scalar gradients equal those of the vector
    basis entry for entry (same order: the recovered stresses do not change by a bit)."""
    from fem.bulk import facets_on, outer_facets
    from fem.fields import strain_operators

    m = build_mesh(fem.MeshSpec(level=-2, order=order, layout="rings"), (-1.0, 1.0))
    disc = discretise(m, order, 2.0, 0.3, boundary)
    for body, name in ((0, "top"), (1, "bottom")):
        scalar = disc.scalar_bases[body]
        vec = scalar.with_element(ElementVector(ELEMENTS[order]()))
        mine = disc.bases[body]
        assert mine.N == vec.N
        assert np.array_equal(mine.doflocs, vec.doflocs)
        assert np.array_equal(mine.element_dofs, vec.element_dofs)
        facets = (outer_facets(m.bodies[body]) if boundary == "half-plane"
                  else facets_on(m.bodies[body], m.nodes[name]))
        assert np.array_equal(disc.fixed[body], vec.get_dofs(facets).all())
        n_el, n_qp = vec.dx.shape
        grads = np.stack([np.asarray(phi[0].grad) for phi in vec.basis], axis=-1)
        cols = np.broadcast_to(vec.element_dofs.T[:, None, :], grads.shape[2:]).ravel()
        indptr = np.arange(0, cols.size + 1, grads.shape[-1])
        for B, g in zip(strain_operators(scalar),
                        (grads[0, 0], grads[1, 1], 0.5 * (grads[0, 1] + grads[1, 0])),
                        strict=True):  # rows (e, k): element e's vector dofs in basis order
            ref = csr_matrix((g.ravel(), cols.copy(), indptr.copy()), shape=(n_el * n_qp, vec.N))
            ref.eliminate_zeros()
            assert np.array_equal(B.indptr, ref.indptr)
            assert np.array_equal(B.indices, ref.indices)
            assert np.array_equal(B.data, ref.data)


@pytest.mark.parametrize("order", [1, 2])
def test_load_operator_equals_the_sorted_coo_assembly_and_skfem(order):
    """The CSR load operator built directly has the arrays of ``coo.tocsr()`` (the earlier
    construction: same values, columns ascending in every row, same index type) and assembles
    skfem's LinearForm of a quadrature-point field."""
    from scipy.sparse import coo_matrix

    from fem.fields import load_operator

    m = build_mesh(fem.MeshSpec(level=-2, order=order, layout="rings"), (-1.0, 1.0))
    scalar = discretise(m, order, 2.0, 0.3).scalar_bases[1]
    n_el, n_qp = scalar.dx.shape
    cols = np.arange(n_el * n_qp).reshape(n_el, n_qp)
    ref = coo_matrix((np.concatenate([(np.asarray(phi[0]) * scalar.dx).ravel()
                                      for phi in scalar.basis]),
                      (np.concatenate([np.repeat(d, n_qp) for d in scalar.element_dofs]),
                       np.tile(cols.ravel(), len(scalar.basis)))),
                     shape=(scalar.N, n_el * n_qp)).tocsr()
    B = load_operator(scalar)
    for name in ("indptr", "indices", "data"):
        got, want = getattr(B, name), getattr(ref, name)
        assert got.dtype == want.dtype and np.array_equal(got, want), name
    f = np.random.default_rng(order).normal(size=(n_el, n_qp))
    want = asm(LinearForm(lambda v, w: w["f"] * v), scalar, f=f)
    np.testing.assert_allclose(B @ f.ravel(), want, rtol=0, atol=1e-13 * np.max(np.abs(want)))


def test_strain_operators_in_any_order_are_the_same_operators():
    from fem.fields import XY_FIRST, iter_strain_operators, strain_operators

    m = build_mesh(fem.MeshSpec(level=-2, order=2, layout="rings"), (-1.0, 1.0))
    scalar = discretise(m, 2, 2.0, 0.3).scalar_bases[1]
    ref = strain_operators(scalar)
    for c, B in zip(XY_FIRST, iter_strain_operators(scalar, XY_FIRST), strict=True):
        for name in ("indptr", "indices", "data"):
            assert np.array_equal(getattr(B, name), getattr(ref[c], name))


def test_released_scalar_bases_keep_their_dof_coordinates_and_are_built_again():
    """ScalarBases.release drops a body's quadrature data; its dof coordinates stay (no
    basis is built for them) and the basis is built again, the same, when asked for."""
    from fem.bulk import ScalarBases
    from fem.mesh import build_mesh

    tbm = build_mesh(fem.MeshSpec(level=-2), (-0.2, 0.2))
    bases = ScalarBases(tbm.bodies, 1)
    first = bases[1]
    xy = first.doflocs.copy()
    bases.release(1)
    assert bases._built[1] is None
    assert np.array_equal(bases.doflocs(1), xy) and bases._built[1] is None
    again = bases[1]
    assert again is not first and np.array_equal(again.doflocs, xy)
    assert np.array_equal(np.asarray(again.dx), np.asarray(first.dx))


@pytest.mark.parametrize("rows", [4, 8192])
def test_far_field_and_plate_motion_are_added_by_blocks_of_rows(monkeypatch, rows):
    """far_field_start: the far field of every dof, by blocks of rows (of 4: blocks inside
    body 1, across its end and in body 2), the numbers of the whole product to rounding;
    add_plate_motion: body 1's rigid motion with the plate, in U itself."""
    import fem.fields as fields
    from fem.farfield import FarField, moment_matrix

    monkeypatch.setattr(fields, "MOTION_ROWS", rows)
    rng = np.random.default_rng(5)
    n1, n, k = 10, 22, 7  # body 1: 5 nodes, 10 dofs
    far = FarField(fields=rng.normal(size=(n, 6)), R=moment_matrix(np.linspace(-1, 1, 4), 0.1),
                   xr=0.1)
    lam, z = rng.normal(size=(8, k)), rng.normal(size=(3, k))
    loc = np.repeat(rng.normal(size=(2, n1 // 2)), 2, axis=1)  # a node's two dofs, one place
    want = far.displacement(lam)
    U = fields.far_field_start(n, far, lam)
    assert U.shape == (n, k) and U.flags.c_contiguous
    assert np.allclose(U, want, rtol=0.0, atol=1e-14 * np.abs(want).max())
    assert np.array_equal(fields.far_field_start(n, None, lam), np.zeros((n, k)))  # clamped
    start = rng.normal(size=(n, k))
    moved = start.copy()
    moved[0:n1:2] += z[0] - loc[1, 0::2, None] * z[2]
    moved[1:n1:2] += z[1] + loc[0, 1::2, None] * z[2]
    buffer = start
    fields.add_plate_motion(start, loc, z)
    assert start is buffer and np.array_equal(start, moved)  # body 2's rows untouched
