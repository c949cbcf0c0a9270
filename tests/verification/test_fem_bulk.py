"""Bulk elasticity of fem.bulk: patch test and manufactured-solution convergence."""

import numpy as np
import pytest
from skfem import (
    Basis,
    ElementQuad1,
    ElementQuad2,
    ElementVector,
    LinearForm,
    MeshQuad,
    asm,
    condense,
    solve,
)

from fem.bulk import stiffness
from fem.linsolve import factorize

E, NU = 2.0, 0.3
LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
#: Observed orders must reach the theory (h^2 for Q1, h^3 for Q2 in L2) within this margin.
ORDER_MARGIN = 0.15


def distorted_mesh():
    """A 3x3-element patch on the unit square with moved interior nodes."""
    m = MeshQuad.init_tensor(np.linspace(0, 1, 4), np.linspace(0, 1, 4))
    p = m.p.copy()
    inner = (p[0] > 0) & (p[0] < 1) & (p[1] > 0) & (p[1] < 1)
    p[:, inner] += np.array([[0.07, -0.05, 0.04, -0.06], [0.05, 0.06, -0.07, 0.03]])
    return MeshQuad(p, m.t)


@pytest.mark.parametrize("order", [1, 2])
def test_patch_test_reproduces_linear_field(order):
    """A linear displacement field is reproduced exactly on a distorted patch."""
    mesh = distorted_mesh()
    basis, K = stiffness(mesh, order, E, NU)
    xy = basis.doflocs
    exact = np.where(
        np.arange(basis.N) % 2 == 0,
        0.01 + 0.2 * xy[0] - 0.1 * xy[1],
        -0.02 + 0.05 * xy[0] + 0.3 * xy[1],
    )
    D = basis.get_dofs().all()
    u = solve(*condense(K, np.zeros(basis.N), x=exact, D=D))
    assert np.max(np.abs(u - exact)) < 1e-12


def exact_u(x, y):
    """Manufactured u1 = u2 = sin(pi x) sin(pi y) (zero on the unit-square boundary)."""
    return np.sin(np.pi * x) * np.sin(np.pi * y)


def body_force(x, y):
    """f = -div sigma = -(mu lap u + (lam + mu) grad div u) for u1 = u2 = s(x) s(y)."""
    sx, sy, cx, cy = np.sin(np.pi * x), np.sin(np.pi * y), np.cos(np.pi * x), np.cos(np.pi * y)
    return 2 * MU * np.pi**2 * sx * sy - (LAM + MU) * np.pi**2 * (cx * cy - sx * sy)


@LinearForm
def load(v, w):
    """Body force load vector."""
    f = body_force(*w.x)
    return f * v[0] + f * v[1]


def l2_error(n: int, order: int) -> float:
    """L2 error of the FE solution on an n x n mesh."""
    mesh = MeshQuad.init_tensor(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1))
    basis, K = stiffness(mesh, order, E, NU)
    f = asm(load, basis)
    D = basis.get_dofs().all()
    free = np.setdiff1d(np.arange(basis.N), D)
    u = np.zeros(basis.N)
    u[free] = factorize(K[free][:, free]).solve(f[free])
    fine = Basis(mesh, ElementVector((ElementQuad1 if order == 1 else ElementQuad2)()), intorder=6)
    uh = fine.interpolate(u)
    ex = exact_u(*fine.global_coordinates())
    err = (uh[0] - ex) ** 2 + (uh[1] - ex) ** 2
    return float(np.sqrt(np.sum(err * fine.dx)))


@pytest.mark.parametrize("order", [1, 2])
def test_manufactured_solution_order(order):
    """Observed L2 order ~ order + 1 under uniform refinement."""
    errs = [l2_error(n, order) for n in (8, 16, 32)]
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    print(f"Q{order} L2 errors {errs}, observed orders {rates}")
    assert rates[-1] > order + 1 - ORDER_MARGIN
