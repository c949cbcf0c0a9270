"""Q1 elements with incompatible modes (fem.bulk.mode_gradients, Simo-Rifai form of the
Wilson-Taylor modes): patch test on distorted quadrilaterals, pure bending of a rectangle
exact, and the strains the stress projection reads (fem.fields.mode_strain_operators)."""

import numpy as np
import pytest
import scipy.sparse as sp
from skfem import Basis, ElementQuad1, MeshQuad

import fem
from fem.bulk import elasticity_matrix, mode_recovery
from fem.errors import InputError
from fem.fields import iter_strain_operators

E, NU = 2.0, 0.3


def distorted_basis(seed: int = 0) -> Basis:
    m = MeshQuad.init_tensor(np.linspace(0, 2, 6), np.linspace(0, 1, 5))
    p = m.p + 0.05 * np.random.default_rng(seed).standard_normal(m.p.shape)
    return Basis(MeshQuad(p, m.t), ElementQuad1())


def linear_field(b: Basis) -> np.ndarray:
    x, y = b.doflocs
    u = np.zeros(2 * b.N)
    u[0::2], u[1::2] = 0.3 * x + 0.2 * y + 0.1, -0.1 * x + 0.4 * y - 0.2
    return u


def test_patch_test_on_distorted_quadrilaterals():
    """A linear displacement field is in equilibrium at every interior node (Taylor's
    correction; without it the modes fail the patch test on non-parallelograms)."""
    b = distorted_basis()
    K = elasticity_matrix(b, E, NU, incompatible=True)
    f = K @ linear_field(b)
    interior = np.setdiff1d(np.arange(b.N), b.mesh.boundary_nodes())
    assert np.abs(f[np.r_[2 * interior, 2 * interior + 1]]).max() < 1e-13
    assert np.abs(K - K.T).max() < 1e-14 * np.abs(K).max()


def bending_element() -> tuple[Basis, np.ndarray]:
    """One 4 x 1 rectangle centred on the origin and the nodal field u = x y, v = 0."""
    b = Basis(MeshQuad.init_tensor(np.array([-2.0, 2.0]), np.array([-0.5, 0.5])),
              ElementQuad1())
    x, y = b.doflocs
    u = np.zeros(2 * b.N)
    u[0::2] = x * y
    return b, u


def test_pure_bending_of_a_rectangle_is_exact():
    """u = x y at the nodes: the modes take the bending (v = -x^2 / 2) that plain Q1 resists by
    parasitic shear; strain energy of eps_xx = y (nu = 0): E * 4 / 12."""
    b, u = bending_element()
    exact = E * 4.0 / 12.0
    assert u @ elasticity_matrix(b, E, 0.0, incompatible=True) @ u == pytest.approx(exact,
                                                                                  rel=1e-13)
    assert u @ elasticity_matrix(b, E, 0.0) @ u > 8 * exact  # Q1: 9x, the shear locking


def test_recovered_strains_include_the_modes():
    """The strain operators with the modes give the bending strains exactly: eps_xx = y,
    eps_yy = 0 (nu = 0), no shear, at every quadrature point."""
    b, u = bending_element()
    Bxx, Byy, Bxy = iter_strain_operators(b, (0, 1, 2), mode_recovery(b, E, 0.0))
    y = b.mapping.F(b.X)[1].ravel()
    assert np.allclose(Bxx @ u, y, atol=1e-14)
    assert np.allclose(Byy @ u, 0.0, atol=1e-14) and np.allclose(Bxy @ u, 0.0, atol=1e-14)


def test_modes_are_silent_in_linear_fields():
    """Linear fields (rigid motions included) excite no mode: the strains are those of plain
    Q1, exactly the constant strain."""
    b = distorted_basis(1)
    u = linear_field(b)
    T, _ = mode_recovery(b, E, NU)
    ue = u[np.asarray(fem.bulk.vector_dofs(b).element_dofs)]  # (8, e)
    assert np.abs(np.einsum("ekj,je->ek", T, ue)).max() < 1e-13
    with_modes = iter_strain_operators(b, (0, 1, 2), mode_recovery(b, E, NU))
    for B, want in zip(with_modes, (0.3, 0.4, 0.5 * (0.2 - 0.1)), strict=True):
        assert np.allclose(B @ u, want, atol=1e-13)


def test_plain_q1_operators_unchanged_by_the_mode_path():
    """With zero mode amplitudes the mode path's operators are plain Q1's."""
    b = distorted_basis(2)
    T, G = mode_recovery(b, E, NU)
    plain = iter_strain_operators(b)
    zero = iter_strain_operators(b, (0, 1, 2), (np.zeros_like(T), G))
    for A, B in zip(plain, zero, strict=True):
        assert abs(A - B).max() == 0.0


@pytest.mark.parametrize("block", [3, 4096])
def test_projection_operators_are_the_loads_of_the_strain_operators(monkeypatch, block):
    """The stress projection's operators with the modes, assembled element by element (by
    blocks of 3 elements: 20 elements in 7 blocks): ``load_operator @ B`` of the strain
    operators to rounding (the sums in another order), in the projector's order."""
    import fem.fields as fields

    monkeypatch.setattr(fields, "MODES_BLOCK", block)
    b = distorted_basis(3)
    modes = mode_recovery(b, E, NU)
    load = fields.load_operator(b)
    got = fields.mode_projection_operators(b, fields.XY_FIRST, E, NU, fem.bulk.mass_matrix(b))
    want = iter_strain_operators(b, fields.XY_FIRST, modes)
    for A, B in zip(got, want, strict=True):
        ref = (load @ B).toarray()
        assert np.abs(A.toarray() - ref).max() <= 1e-14 * np.abs(ref).max()


def test_incompatible_must_be_a_bool():
    with pytest.raises(InputError, match="incompatible='yes' is not allowed: need True or False"):
        fem.solve_history(lambda x: x**2, 1.0, 0.1, 0.5, 1.0, 0.3,
                          mesh=fem.MeshSpec(incompatible="yes"), window=(-0.5, 0.5))


def test_report_names_the_element_with_its_modes():
    from types import SimpleNamespace

    from compare.report.html import OWN_FE, fe_text

    def res(order, incompatible):
        return SimpleNamespace(source=OWN_FE, fem=SimpleNamespace(backend="cholmod",
                                                                  n_dofs=10, order=order),
                               case=SimpleNamespace(fem=SimpleNamespace(
                                   level=1, incompatible=incompatible)))

    assert "Q4 (linear) with incompatible modes, level 1" in fe_text(res(1, True))
    assert "Q4 (linear), level 1" in fe_text(res(1, False))
    assert "Q9 (quadratic), level 1" in fe_text(res(2, True))  # no modes on Q9


def test_vector_pattern_needs_every_pair_of_nodes_of_an_element():
    import fem.fields as fields

    b = distorted_basis(4)
    mass = fem.bulk.mass_matrix(b)
    indptr, indices, where = fields.vector_pattern(mass, b.element_dofs)
    assert indices.size == 2 * mass.nnz and where.shape == (b.nelems, 4, 8)
    assert np.unique(where).size == indices.size  # every entry is some element's
    diagonal = sp.diags(mass.diagonal()).tocsr()  # only each node with itself
    with pytest.raises(RuntimeError, match="lacks a pair of nodes"):
        fields.vector_pattern(diagonal, b.element_dofs)
