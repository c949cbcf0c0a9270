"""Flamant far field (fem.farfield): the closed form and its multipole expansion."""

import numpy as np
import pytest

from fem.farfield import ORDERS, flamant_body, flamant_lower, moment_matrix

#: Rounding of a sum of a few products of O(1) numbers, relative to their size.
ROUNDING = 1e-15

E, NU = 2.0, 0.3
LAM, G = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
#: Central-difference step and the agreement it allows (truncation ~ step^2 / r^2).
STEP, FD_TOL = 1e-5, 1e-6


def stress(x, y, force, upper):
    """Plane-strain stress (sxx, syy, sxy) from central differences of the displacement."""
    ux = [np.array(flamant_body(x + s * STEP, y, force, upper, E, NU)) for s in (1, -1)]
    uy = [np.array(flamant_body(x, y + s * STEP, force, upper, E, NU)) for s in (1, -1)]
    dx, dy = (ux[0] - ux[1]) / (2 * STEP), (uy[0] - uy[1]) / (2 * STEP)
    tr = dx[0] + dy[1]
    return LAM * tr + 2 * G * dx[0], LAM * tr + 2 * G * dy[1], G * (dx[1] + dy[0])


@pytest.mark.parametrize("upper", [False, True])
@pytest.mark.parametrize("force", [1.0 + 0.0j, 1.0j, 0.6 - 0.8j])
def test_flamant_is_the_surface_point_force(force, upper):
    """Traction-free surface away from the load; the stresses on a half-circle balance the
    force (Flamant: sigma_rr = -2 F cos / (pi r))."""
    side = 1.0 if upper else -1.0
    xs = np.array([-3.0, -0.7, 0.4, 2.5])
    sxx, syy, sxy = stress(xs, side * 2 * STEP, force, upper)
    assert np.max(np.abs(syy)) < 1e-4 and np.max(np.abs(sxy)) < 1e-4
    n, r = 4000, 2.0
    th = (np.arange(n) + 0.5) * np.pi / n  # midpoint rule, off the surface
    nx, ny = np.cos(th), side * np.sin(th)
    sxx, syy, sxy = stress(r * nx, r * ny, force, upper)
    fx = np.sum(sxx * nx + sxy * ny) * r * np.pi / n
    fy = np.sum(sxy * nx + syy * ny) * r * np.pi / n
    assert fx == pytest.approx(-force.real, abs=1e-5)
    assert fy == pytest.approx(-force.imag, abs=1e-5)


@pytest.mark.parametrize("m", range(1, ORDERS))
def test_multipole_terms_are_x_derivatives(m):
    x, y = np.array([-2.0, 0.5, 3.0]), np.array([-1.0, -0.2, -2.5])
    for force in (1.0 + 0.0j, 1.0j):
        fd = (
            flamant_lower(x + STEP, y, force, E, NU, m - 1)
            - flamant_lower(x - STEP, y, force, E, NU, m - 1)
        ) / (2 * STEP)
        exact = flamant_lower(x, y, force, E, NU, m)
        assert np.max(np.abs(fd - exact)) < FD_TOL * np.max(np.abs(exact)) * 10


def test_expansion_reproduces_distributed_forces_far_away():
    """sum_j f_j G(x - x_j) vs the truncated multipole series about xr: error ~ (a / r)^ORDERS."""
    xj = np.linspace(-0.3, 0.5, 9)
    f = np.cos(xj)
    R = moment_matrix(xj, 0.1)
    moments = R[ORDERS:] @ np.r_[np.zeros_like(f), f]
    for r, tol in ((10.0, 1e-4), (40.0, 3e-6)):
        px, py = r * np.cos(-2.0), r * np.sin(-2.0)
        exact = sum(
            fj * flamant_lower(px - x, py, 1.0j, E, NU) for fj, x in zip(f, xj, strict=True)
        )
        series = sum(
            (-1) ** m
            / np.prod(np.arange(1, m + 1))
            * moments[m]
            * flamant_lower(px - 0.1, py, 1.0j, E, NU, m)
            for m in range(ORDERS)
        )
        far = flamant_lower(px - 0.1, py, 1.0j, E, NU, 1) * f.sum()  # dipole-size scale
        assert abs(series - exact) < tol * abs(far) * r


@pytest.mark.parametrize("rows", [256, 3])
def test_far_field_term_keeps_a_decoupled_compliance_decoupled(monkeypatch, rows):
    """The lift's tangential-normal blocks (rounding of a term that is zero between mirror-image
    bodies) are left out when the bulk's are zero, and kept when the bulk couples them; by
    row blocks (of 3: blocks across the tangential-normal border) the sum is the whole
    product's to rounding (BLAS's kernels for a block's rows are not the whole product's)."""
    import fem.history as history

    monkeypatch.setattr(history, "FAR_FIELD_ROWS", rows)
    rng = np.random.default_rng(1)
    n = 5
    C = np.diag(rng.uniform(1.0, 2.0, 2 * n))
    D, R = rng.normal(size=(2 * n, 6)), rng.normal(size=(6, 2 * n))
    Cf = D @ R
    into = C.copy()
    out = history.add_far_field(into, D, R)
    assert out is into  # summed in place: no third dense matrix at the history's peak
    assert not np.any(out[:n, n:]) and not np.any(out[n:, :n])
    close = dict(rtol=0.0, atol=ROUNDING * np.abs(Cf).max())
    assert np.allclose(out[:n, :n], C[:n, :n] + Cf[:n, :n], **close)
    assert np.allclose(out[n:, n:], C[n:, n:] + Cf[n:, n:], **close)
    C[0, n] = C[n, 0] = 0.1
    assert np.allclose(history.add_far_field(C.copy(), D, R), C + Cf, **close)


@pytest.mark.parametrize("m", [1, 7, 10, 12])
def test_row_major_in_place_keeps_the_values_in_the_same_memory(monkeypatch, m):
    """A Fortran-ordered square matrix becomes C-ordered in its own buffer (blocks of 3: full,
    partial and diagonal blocks), value for value; a C-ordered one is returned as it is."""
    import fem.history as history

    monkeypatch.setattr(history, "TRANSPOSE_BLOCK", 3)
    A = np.asfortranarray(np.random.default_rng(m).normal(size=(m, m)))
    want = A.copy()
    B = history.row_major_in_place(A)
    assert B.flags.c_contiguous and np.shares_memory(A, B)
    assert np.array_equal(B, want)
    assert history.row_major_in_place(B) is B


def test_far_field_sum_of_a_fortran_compliance_is_row_major():
    """fem.condense's compliance is Fortran-ordered: the sum has the layout ``C + Cf`` had (the
    contact solver's rounding follows the layout), in C's memory."""
    from fem.history import add_far_field

    rng = np.random.default_rng(2)
    C = np.asfortranarray(rng.normal(size=(8, 8)))
    D, R = rng.normal(size=(8, 6)), rng.normal(size=(6, 8))
    want = C + D @ R
    out = add_far_field(C.copy(order="F"), D, R)
    assert out.flags.c_contiguous and np.array_equal(out, want)  # one block: one product

