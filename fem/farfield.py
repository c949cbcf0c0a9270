"""Far-field boundary condition: the outer boundary of each body moves as a half-plane.

The analytic solution treats both bodies as half-planes; finite FE bodies with a clamped
outer boundary are stiffer, which moves the contact edges (finite-body error, issue 14).
Here the outer boundary of each body (everything but the interface line y = 0) is given the
displacement of a half-plane loaded by the body's interface forces, expanded in surface
multipoles about a reference point ``xr`` on the interface:

    sum_j f_j G(x - x_j, y) = sum_m (-1)^m / m! * M_m * d^m/dx^m G(x - xr, y),
    M_m = sum_j f_j (x_j - xr)^m     (m = 0: resultant force, m = 1: moment of the normal
                                      force about xr and the first moment of the shear, ...)

with G the Flamant displacement of a unit surface force.  The multipole moments are linear
in the pair forces, so the boundary data enter the condensed interface problem as a
low-rank term ``C_ff = D R`` (D: interface response to the lifted boundary fields, R: the
moments of the pair forces).  The expansion error at the boundary is of order
``(a / W)^ORDERS`` relative to the leading term (a: contact span, W: body size).

Flamant solution (Muskhelishvili, Some Basic Problems of the Mathematical Theory of
Elasticity, Sec. 93; Barber, Elasticity, Ch. 12): a force (X, Y) at the origin of the
half-plane y < 0 has the complex potentials ``phi = -(X + iY) log(z) / (2 pi)``,
``psi = (X - iY) log(z) / (2 pi)``, and ``2G (u + iv) = kappa phi - z conj(phi') -
conj(psi)`` with ``kappa = 3 - 4 nu`` (plane strain), ``G = E / (2 (1 + nu))``.  The
displacement is defined up to a rigid motion (the log's reference length): body 2 takes it
as given, body 1's rigid motion is the plate's.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

from .condense import column_blocks

#: Multipole orders kept (0: resultant, 1: first moments, 2: second moments).
ORDERS = 3
#: Columns of the lift's solves at a time (of 2 ORDERS): its right-hand sides and CHOLMOD's
#: two copies of them are of this width (issue 28: the lift set the condensation's peak, 185
#: MB at cattaneo ring level 3; one more pass through the factor).
LIFT_BLOCK = ORDERS


def log_lower(z: np.ndarray) -> np.ndarray:
    """log z on the closed lower half-plane (arg in [-pi, 0], the cut above it)."""
    return np.log(np.abs(z)) + 1j * np.arctan2(-np.abs(z.imag), z.real)


def log_derivative(z: np.ndarray, m: int) -> np.ndarray:
    """m-th derivative of log_lower: log z for m = 0, (-1)^(m-1) (m-1)! / z^m otherwise."""
    if m == 0:
        return log_lower(z)
    return (-1) ** (m - 1) * factorial(m - 1) / z**m


def flamant_lower(
    x: np.ndarray, y: np.ndarray, force: complex, E: float, nu: float, m: int = 0
) -> np.ndarray:
    """m-th x-derivative of the displacement ``u + iv`` at (x, y <= 0) of the half-plane
    y < 0 under the unit surface force ``force = X + iY`` at the origin (Flamant).

    ``d^m/dx^m [kappa phi - z conj(phi') - conj(psi)] = kappa phi^(m) - m conj(phi^(m))
    - z conj(phi^(m+1)) - conj(psi^(m))`` (m >= 1; the m = 0 form above), divided by 2G.
    """
    z = np.asarray(x, float) + 1j * np.asarray(y, float)
    c1, c2 = -force / (2 * np.pi), np.conj(force) / (2 * np.pi)
    kappa, G = 3.0 - 4.0 * nu, E / (2.0 * (1.0 + nu))
    phi_m, phi_m1 = c1 * log_derivative(z, m), c1 * log_derivative(z, m + 1)
    w = (
        kappa * phi_m
        - m * np.conj(phi_m)
        - z * np.conj(phi_m1)
        - np.conj(c2 * log_derivative(z, m))
    )
    return w / (2.0 * G)


def flamant_body(
    x: np.ndarray, y: np.ndarray, force: complex, upper: bool, E: float, nu: float, m: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of body 1 (upper, y >= 0: the lower solution mirrored in y) or body 2."""
    if not upper:
        w = flamant_lower(x, y, force, E, nu, m)
        return w.real, w.imag
    w = flamant_lower(x, -np.asarray(y, float), np.conj(force), E, nu, m)
    return w.real, -w.imag


def boundary_fields(
    dofs: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
    xr: float,
    E: float,
    nu: float,
) -> np.ndarray:
    """Prescribed displacements, one column per multipole k = (component, order), for a unit
    moment M_m of the force on body 1 (body 2 carries the opposite forces).

    dofs: per body (locations (2, m) of its prescribed dofs, True where a dof is an x
    component); rows: body 1's dofs, then body 2's.  Columns: [x-force m = 0..ORDERS-1,
    y-force m = 0..ORDERS-1].
    """
    cols = []
    for force in (1.0 + 0.0j, 1.0j):
        for m in range(ORDERS):
            coef = (-1) ** m / factorial(m)
            parts = []
            for body, (loc, is_x) in enumerate(dofs):
                u, v = flamant_body(loc[0] - xr, loc[1], force, body == 0, nu=nu, E=E, m=m)
                parts.append((coef if body == 0 else -coef) * np.where(is_x, u, v))
            cols.append(np.concatenate(parts))
    return np.array(cols).T


def moment_matrix(x: np.ndarray, xr: float) -> np.ndarray:
    """R: multipole moments of the pair forces ``lam = [lam_t..., lam_n...]`` on body 1,
    rows ordered as in :func:`boundary_fields`."""
    n = x.size
    R = np.zeros((2 * ORDERS, 2 * n))
    for m in range(ORDERS):
        R[m, :n] = (x - xr) ** m
        R[ORDERS + m, n:] = (x - xr) ** m
    return R


@dataclass(frozen=True)
class FarField:
    """Lifted far-field boundary data of a discretisation.

    fields: (n_dofs, 2 ORDERS) displacement of both bodies (body-2 dofs after body 1's) for a
    unit multipole moment, equal to the Flamant data on the prescribed dofs and solving the
    bulk equations elsewhere; R: (2 ORDERS, 2 n) moments of the pair forces (moment_matrix);
    xr: the expansion point.
    """

    fields: np.ndarray
    R: np.ndarray
    xr: float

    def displacement(self, lam: np.ndarray) -> np.ndarray:
        """Full-field far-field displacement for pair forces lam (columns: load cases)."""
        return self.fields @ (self.R @ lam)


def coupling_loads(coupling: tuple, G: np.ndarray) -> np.ndarray:
    """``K[free][:, fixed] @ G`` of the block-diagonal K of both bodies (``fixed`` body 1's
    prescribed dofs then body 2's, G's rows in that order), body by body from ``coupling``
    (``fem.bulk.BulkBlocks.coupling``: each body's ``K_b[free_b][:, fixed_b]``): the bodies
    are uncoupled, and the whole K is not formed (issue 28)."""
    k1 = coupling[0].shape[1]
    return np.concatenate((coupling[0] @ G[:k1], coupling[1] @ G[k1:]))


def lift(disc, coupling: tuple, factor, free: np.ndarray, x_pairs: np.ndarray) -> FarField:
    """Far-field fields of ``disc`` (boundary='half-plane'): the Flamant multipole data on
    the prescribed dofs, lifted into the bodies with the bulk factor (2 ORDERS solves, by
    blocks of LIFT_BLOCK; ``coupling``: :func:`coupling_loads`)."""
    xr = 0.5 * float(x_pairs.min() + x_pairs.max())
    dofs = tuple((b.doflocs[:, f], f % 2 == 0) for b, f in zip(disc.bases, disc.fixed, strict=True))
    fixed = np.r_[disc.fixed[0], disc.fixed[1] + disc.bases[0].N]
    G = boundary_fields(dofs, xr, disc.E, disc.nu)
    fields = np.zeros((disc.n_dofs, G.shape[1]))
    fields[fixed] = G
    for cols in column_blocks(G.shape[1], LIFT_BLOCK):
        lifted = factor.solve(coupling_loads(coupling, G[:, cols]))
        fields[free, cols] = np.negative(lifted, out=lifted)
        del lifted
    return FarField(fields=fields, R=moment_matrix(x_pairs, xr), xr=xr)
