"""The vectorised stiffness and mass kernels (fem.bulk) equal scikit-fem's generic assembly."""

from __future__ import annotations

import numpy as np
import pytest
from skfem import Basis, BilinearForm, ElementVector, MeshQuad, asm

from fem.bulk import ELEMENTS, elasticity_matrix, mass_matrix, plane_strain_elasticity

#: Entry-wise agreement relative to the largest entry: only the summation order differs
#: (measured 4e-16 .. 5e-16).
KERNEL_TOL = 1e-14


def graded_mesh() -> MeshQuad:
    """A distorted (non-affine) quad mesh: the kernels must use the full isoparametric map."""
    m = MeshQuad.init_tensor(np.linspace(0.0, 1.0, 9) ** 1.4, np.linspace(0.0, 1.0, 7) ** 1.7)
    p = m.p.copy()
    p[0] += 0.03 * np.sin(3.0 * p[1])
    return MeshQuad(p, m.t)


@pytest.mark.parametrize("order", [1, 2])
def test_elasticity_matrix_equals_generic_assembly(order):
    mesh = graded_mesh()
    want = asm(plane_strain_elasticity(2.1, 0.27), Basis(mesh, ElementVector(ELEMENTS[order]())))
    got = elasticity_matrix(Basis(mesh, ELEMENTS[order]()), 2.1, 0.27)
    assert got.shape == want.shape
    assert abs(got - want).max() <= KERNEL_TOL * abs(want).max()


@pytest.mark.parametrize("order", [1, 2])
def test_mass_matrix_equals_generic_assembly(order):
    scalar = Basis(graded_mesh(), ELEMENTS[order]())
    want = asm(BilinearForm(lambda u, v, w: u * v), scalar)
    got = mass_matrix(scalar)
    assert abs(got - want).max() <= KERNEL_TOL * abs(want).max()
