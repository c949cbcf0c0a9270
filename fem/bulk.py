"""Bulk discretisation of the two linear elastic bodies (scikit-fem).

mesh -> basis -> ``plane_strain_elasticity`` form -> assemble. The interface is
described by matched node pairs (body-1 dof, body-2 dof at the same x) with their
tributary lengths ``w_i = integral of phi_i over the interface`` (trapezoid weights
for Q1, Simpson weights 1/6, 4/6, 1/6 for Q2).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from skfem import (
    Basis,
    ElementQuad1,
    ElementQuad2,
    ElementVector,
    FacetBasis,
    LinearForm,
    MeshQuad,
    asm,
)
from skfem.assembly import Dofs
from skfem.models.elasticity import lame_parameters, linear_elasticity

from .mesh import INTERFACE_ATOL, TwoBodyMesh

ELEMENTS = {1: ElementQuad1, 2: ElementQuad2}


@dataclass(frozen=True)
class Interface:
    """Matched interface node pairs sorted by x.

    x: node x coordinates; w: tributary lengths; dof1, dof2: scalar dof indices in
    body 1 / body 2 (vector dof of component k is ``2*dof + k``).
    """

    x: np.ndarray
    w: np.ndarray
    dof1: np.ndarray
    dof2: np.ndarray


@dataclass(frozen=True, eq=False)
class VectorDofs:
    """Vector dof numbering of one body, ``2 * scalar dof + component`` (skfem's
    ``ElementVector`` numbering), without a vector basis's quadrature data (its values and
    gradients at every quadrature point: 0.8 GB at cattaneo ring level 5, issue 28).

    N: vector dofs; doflocs: (2, N) dof coordinates; element_dofs: (2 n_loc, n_elements),
    row ``2 a + k`` the component-k dof of local scalar dof a.
    """

    N: int
    doflocs: np.ndarray
    element_dofs: np.ndarray


def vector_dofs(scalar: Basis) -> VectorDofs:
    """The vector dof numbering over a scalar basis."""
    ed = scalar.element_dofs
    element_dofs = np.empty((2 * ed.shape[0], ed.shape[1]), dtype=ed.dtype)
    element_dofs[0::2], element_dofs[1::2] = 2 * ed, 2 * ed + 1
    return VectorDofs(N=2 * scalar.N, doflocs=np.repeat(scalar.doflocs, 2, axis=1),
                      element_dofs=element_dofs)


def vector_facet_dofs(scalar: Basis, vec: VectorDofs, facets: np.ndarray) -> np.ndarray:
    """Vector dofs on ``facets`` in the order of skfem's vector ``Basis.get_dofs(facets)``."""
    dofs = Dofs(scalar.mesh, ElementVector(scalar.elem))
    return dofs.get_facet_dofs(facets, doflocs=vec.doflocs).all()


class ScalarBases(Sequence):
    """The bodies' scalar skfem bases, each built on first use and then kept until released
    (:meth:`release`; its dof coordinates are kept, :meth:`doflocs`).  The history
    (factorisation, increments, displacement recovery) needs none of their quadrature data, so
    :func:`discretise` does not keep the ones it assembled with (they would sit beside the
    factors: about 0.5 GB at cattaneo ring level 6, issue 28); the stress projection, the
    stress metrics and the VTK output build them again (the same bases: a basis is a function
    of its mesh and element)."""

    def __init__(self, meshes, order: int):
        self.meshes, self.order = tuple(meshes), order
        self._built = [None] * len(self.meshes)
        self._doflocs = [None] * len(self.meshes)

    def __len__(self) -> int:
        return len(self.meshes)

    def __getitem__(self, body: int) -> Basis:
        if self._built[body] is None:
            self._built[body] = Basis(self.meshes[body], ELEMENTS[self.order]())
            self._doflocs[body] = self._built[body].doflocs
        return self._built[body]

    def doflocs(self, body: int) -> np.ndarray:
        """(2, N) coordinates of a body's scalar dofs (the basis's, kept when it is released:
        no quadrature data is built again for them)."""
        if self._doflocs[body] is None:
            self[body]
        return self._doflocs[body]

    def release(self, body: int) -> None:
        """Drop a body's basis and its mesh's cached mapping (built again when next asked
        for): a caller done with its quadrature data frees them (issue 28: the stress
        projection, whose solve they had sat beside, 30 MB at cattaneo ring level 3)."""
        self._built[body] = None
        drop_mapping_cache(self.meshes[body])


@dataclass(frozen=True)
class Discretisation:
    """Assembled two-body problem: dof numberings, bases, stiffness matrices, fixed dofs,
    interface.

    bases: per body, the vector dof numbering (:class:`VectorDofs`); scalar_bases: per body,
    the scalar skfem basis (quadrature data for the stress projection and the mass matrix;
    :class:`ScalarBases`, built when first asked for). stiffness: (K1, K2); None in a
    history's model and result (:func:`split_stiffness` cuts the blocks the history reads and
    the driver drops the matrices before the factorisation).
    fixed: prescribed dofs of body 1 (top, or the whole outer boundary with
    boundary='half-plane') and body 2 (bottom, or its whole outer boundary).
    E, nu: material; order: element order; incompatible: Q1 elements carry incompatible modes
    (:func:`mode_gradients`; no effect on Q2).
    """

    mesh: TwoBodyMesh
    order: int
    E: float
    nu: float
    bases: tuple
    scalar_bases: ScalarBases
    stiffness: tuple
    fixed: tuple
    interface: Interface
    boundary: str = "clamped"
    incompatible: bool = False

    @property
    def n_dofs(self) -> int:
        """Total number of displacement dofs of both bodies (before constraints)."""
        return int(sum(b.N for b in self.bases))


def plane_strain_elasticity(E: float, nu: float):
    """Bilinear form of plane-strain isotropic elasticity (3-D Lame constants)."""
    return linear_elasticity(*lame_parameters(E, nu))


def stiffness(mesh: MeshQuad, order: int, E: float, nu: float) -> tuple[Basis, sp.csr_matrix]:
    """Vector basis and plane-strain stiffness matrix of one body (the form
    :func:`plane_strain_elasticity`, assembled by :func:`elasticity_matrix`)."""
    basis = Basis(mesh, ElementVector(ELEMENTS[order]()))
    return basis, elasticity_matrix(Basis(mesh, ELEMENTS[order]()), E, nu)


#: Elements per block of the vectorised element kernel (memory ~ 8 (2 n_loc)^2 bytes each).
ELEMENT_BLOCK = 20000
#: Elements per block with incompatible modes: their condensation's temporaries are about 3 kB an
#: element (a whole block of 20000: +117 MB above the assembly's own arrays at cattaneo ring
#: level 3; issue 28's memory).
MODES_BLOCK = 4096


def elasticity_matrix(scalar: Basis, E: float, nu: float, incompatible: bool = False
                      ) -> sp.csr_matrix:
    """Plane-strain stiffness in the vector numbering ``2 * scalar dof + component``, from the
    scalar basis gradients in one vectorised kernel (the bilinear form of
    :func:`plane_strain_elasticity`, ``sigma(u) : eps(v)``, without its per-entry Python
    loop): with ``D_ab^kl = int d_k phi_a d_l phi_b``,
    ``K[(a, i), (b, j)] = lam D_ab^ij + mu D_ab^ji + mu delta_ij (D_ab^00 + D_ab^11)``.
    ``incompatible``: Q1 elements with the incompatible modes of :func:`mode_matrices`,
    condensed element by element (:func:`condensed`)."""
    lam, mu = lame_parameters(E, nu)
    grads = np.array([phi[0].grad for phi in scalar.basis])  # (n_loc, 2, n_el, n_qp)
    dofs = scalar.element_dofs  # (n_loc, n_el)
    n_loc, n_el = dofs.shape
    per_el = (2 * n_loc) ** 2
    # the triplets go straight into arrays of their final size: no list of per-block arrays
    # and no concatenated copy (the blocks' arrays, freed at once, leave no heap behind)
    n = 2 * scalar.N
    itype = np.int32 if max(n, n_el * per_el) < np.iinfo(np.int32).max else np.int64
    data = np.empty(n_el * per_el)  # 32-bit indices where they fit: the COO keeps them as they are
    r, c = np.empty(n_el * per_el, dtype=itype), np.empty(n_el * per_el, dtype=itype)
    block = MODES_BLOCK if incompatible else ELEMENT_BLOCK
    for e0 in range(0, n_el, block):
        sl = slice(e0, min(e0 + block, n_el))
        g = grads[:, :, sl]
        Ke = pair_stiffness(lam, mu, g, g, scalar.dx[sl])  # (e, a, b, i, j)
        if incompatible:
            Ke = condensed(Ke, *mode_matrices(scalar, sl, lam, mu, g))
        vec = 2 * dofs[:, sl].T[:, :, None] + np.arange(2)  # (e, a, i)
        out = slice(sl.start * per_el, sl.stop * per_el)
        data[out] = Ke.ravel()
        r[out] = np.broadcast_to(vec[:, :, None, :, None], Ke.shape).ravel()
        c[out] = np.broadcast_to(vec[:, None, :, None, :], Ke.shape).ravel()
        del Ke, vec
    del grads
    return compact(sp.coo_matrix((data, (r, c)), shape=(n, n)).tocsr())


def pair_stiffness(lam: float, mu: float, ga: np.ndarray, gb: np.ndarray, wt: np.ndarray
                   ) -> np.ndarray:
    """``K[e, A, B, i, j] = int sigma(f_A e_i) : eps(f_B e_j) wt`` of two sets of scalar
    functions given by their gradients ``ga`` (nA, 2, e, q), ``gb`` (nB, 2, e, q) at the
    quadrature points with weights ``wt`` (e, q): :func:`elasticity_matrix`'s kernel (its
    formula), also for the incompatible modes' blocks (:func:`mode_matrices`)."""
    D = np.einsum("akeq,bleq,eq->eabkl", ga, gb, wt, optimize=True)
    trace = D[..., 0, 0] + D[..., 1, 1]
    return lam * D + mu * D.transpose(0, 1, 2, 4, 3) + mu * trace[..., None, None] * np.eye(2)


def mode_gradients(scalar: Basis, sl: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Incompatible modes of the Q1 elements ``sl`` (Wilson-Taylor, in Simo-Rifai's enhanced
    strain form, as Abaqus's CPE4I): ``b_m = X_m (1 - X_m)`` on the reference square [0, 1]^2,
    m = 0, 1, with the gradient mapped by the element's Jacobian J0 at its centre and scaled by
    ``det J0 / det J`` (Taylor's correction: ``int grad b_m dx = 0`` on every quadrilateral, so
    the element passes the patch test, and is exact in pure bending of a rectangle).  Returns
    (G, w_ci, w_ii): G (2, 2, e, q) the modes' J0-mapped gradients, and the quadrature weights
    of the (standard, mode) and (mode, mode) products, ``det J0 W`` and ``det J0^2 / det J W``
    (e, q)."""
    X, W = scalar.X, scalar.W
    J0 = scalar.mapping.DF(np.full((2, 1), 0.5), tind=np.arange(scalar.nelems)[sl])[..., 0]
    det0 = J0[0, 0] * J0[1, 1] - J0[0, 1] * J0[1, 0]  # (e,)
    inv0 = np.array([[J0[1, 1], -J0[0, 1]], [-J0[1, 0], J0[0, 0]]]) / det0  # dX_m / dx_k
    G = inv0[:, :, :, None] * (1.0 - 2.0 * X)[:, None, None, :]  # (m, k, e, q)
    w_ci = det0[:, None] * W
    return G, w_ci, w_ci * det0[:, None] * W / scalar.dx[sl]


def mode_matrices(scalar: Basis, sl: slice, lam: float, mu: float, grads: np.ndarray,
                  modes: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(K_ci (e, 8, 4), K_ii (e, 4, 4)) of the incompatible modes (:func:`mode_gradients`, or
    ``modes`` if given) of the elements ``sl``, rows and columns ``2 a + i`` (standard) and
    ``2 m + i`` (modes); ``grads``: the standard gradients (4, 2, e, q) of those elements."""
    G, w_ci, w_ii = mode_gradients(scalar, sl) if modes is None else modes
    n = grads.shape[2]
    Kci = pair_stiffness(lam, mu, grads, G, w_ci).transpose(0, 1, 3, 2, 4).reshape(n, 8, 4)
    Kii = pair_stiffness(lam, mu, G, G, w_ii).transpose(0, 1, 3, 2, 4).reshape(n, 4, 4)
    return Kci, Kii


def condensed(Ke: np.ndarray, Kci: np.ndarray, Kii: np.ndarray) -> np.ndarray:
    """``K_cc - K_ci K_ii^-1 K_ic`` per element (the incompatible modes condensed out; no
    displacement dof is added), ``Ke`` (e, a, b, i, j) in and out, symmetrised."""
    n, n_loc = Ke.shape[0], Ke.shape[1]
    Kcc = Ke.transpose(0, 1, 3, 2, 4).reshape(n, 2 * n_loc, 2 * n_loc)
    K = Kcc - Kci @ np.linalg.solve(Kii, Kci.transpose(0, 2, 1))
    K = 0.5 * (K + K.transpose(0, 2, 1))
    return K.reshape(n, n_loc, 2, n_loc, 2).transpose(0, 1, 3, 2, 4)


def mode_recovery(scalar: Basis, E: float, nu: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, G): the incompatible modes' amplitudes ``alpha = T u_e`` (T = -K_ii^-1 K_ic, (e, 4,
    8), the condensed equations of the element) and their strain gradients G (2, 2, e, q)
    already scaled by ``det J0 / det J``: the strain of mode (m, i) at a quadrature point is
    ``sym(G_m e_i) alpha_(m, i)`` (by blocks of MODES_BLOCK elements, :func:`mode_block`)."""
    lam, mu = lame_parameters(E, nu)
    grads = [np.asarray(phi[0].grad) for phi in scalar.basis]  # views (2, e, q)
    n_el, n_qp = scalar.dx.shape
    T, G = np.empty((n_el, 4, 8)), np.empty((2, 2, n_el, n_qp))
    for e0 in range(0, n_el, MODES_BLOCK):
        sl = slice(e0, min(e0 + MODES_BLOCK, n_el))
        T[sl], G[:, :, sl] = mode_block(scalar, sl, lam, mu, grads)
    return T, G


def mode_block(scalar: Basis, sl: slice, lam: float, mu: float, grads: list
               ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`mode_recovery`'s (T, G) of the elements ``sl`` (``grads``: the standard
    gradients, per local node (2, e, q), of all elements; Lame parameters lam, mu)."""
    modes = mode_gradients(scalar, sl)
    block = np.array([g[:, sl] for g in grads])  # one block's copy, not all elements'
    Kci, Kii = mode_matrices(scalar, sl, lam, mu, block, modes)
    return -np.linalg.solve(Kii, Kci.transpose(0, 2, 1)), modes[0] * (modes[1] / scalar.dx[sl])


def compact(A: sp.csr_matrix) -> sp.csr_matrix:
    """A with arrays of its own size: ``coo.tocsr()`` sums the duplicates in place and keeps
    views into the COO-sized arrays (one entry per element-matrix entry, 1.8x the nonzeros of
    a Q1 stiffness: 0.5 GB held for nothing at cattaneo ring level 5, issue 28)."""
    return sp.csr_matrix((A.data.copy(), A.indices.copy(), A.indptr.copy()), shape=A.shape)


def mass_matrix(scalar: Basis) -> sp.csr_matrix:
    """Scalar mass matrix ``M_ab = int phi_a phi_b`` (vectorised, as :func:`elasticity_matrix`)."""
    phi = np.array([np.asarray(p[0]) for p in scalar.basis])  # (n_loc, n_el, n_qp)
    Me = np.einsum("aeq,beq,eq->eab", phi, phi, scalar.dx, optimize=True)
    dofs = scalar.element_dofs.T  # (n_el, n_loc)
    rows = np.broadcast_to(dofs[:, :, None], Me.shape)
    cols = np.broadcast_to(dofs[:, None, :], Me.shape)
    n = scalar.N
    return compact(sp.coo_matrix((Me.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n)).tocsr())


def facets_on(mesh: MeshQuad, nodes: np.ndarray) -> np.ndarray:
    """Boundary facet indices whose end nodes all belong to ``nodes``."""
    bf = mesh.boundary_facets()
    return bf[np.isin(mesh.facets[:, bf], nodes).all(axis=0)]


@LinearForm
def unit_traction(v, w):
    """Integral of a test function over a facet set (tributary lengths)."""
    return v


def interface_side(mesh: MeshQuad, nodes: np.ndarray, order: int, scalar: Basis | None = None):
    """Scalar interface dofs of one body, sorted by x, with their weights (``scalar``: the
    body's scalar basis, built if None)."""
    facets = facets_on(mesh, nodes)
    scalar = scalar or Basis(mesh, ELEMENTS[order]())
    dofs = scalar.get_dofs(facets).all()
    weights = asm(unit_traction, FacetBasis(centred(mesh, nodes), ELEMENTS[order](),
                                            facets=facets))
    x = scalar.doflocs[0, dofs]
    order_x = np.argsort(x)
    return x[order_x], weights[dofs[order_x]], dofs[order_x]


def centred(mesh: MeshQuad, nodes: np.ndarray) -> MeshQuad:
    """``mesh`` moved along x so that ``nodes`` are centred on x = 0 (same topology: the same
    facets).  skfem's facet basis maps its quadrature points back into each quad by a Newton
    iteration with an absolute tolerance of 1e-12 in reference coordinates, which the rounding
    of x fails once |x| / h passes about 4000 (a contact at x = 10 at level 1 raised skfem's bare
    "Newton iteration didn't converge"); the tributary lengths do not depend on the shift."""
    x0 = 0.5 * float(np.min(mesh.p[0, nodes]) + np.max(mesh.p[0, nodes]))
    return mesh.translated((-x0, 0.0)) if x0 else mesh


def outer_facets(mesh: MeshQuad) -> np.ndarray:
    """Boundary facets off the interface line y = 0 (the far-field boundary of a body)."""
    bf = mesh.boundary_facets()
    on_interface = np.all(np.abs(mesh.p[1, mesh.facets[:, bf]]) <= INTERFACE_ATOL, axis=0)
    return bf[~on_interface]


def discretise(
    mesh: TwoBodyMesh, order: int, E: float, nu: float, boundary: str = "clamped",
    incompatible: bool = False,
) -> Discretisation:
    """Assemble both bodies and pair their interface dofs.

    boundary: 'clamped' (body 1's top and body 2's bottom fixed, the sides free) or
    'half-plane' (every boundary dof off y = 0 fixed; fem.farfield prescribes it).
    incompatible: Q1 elements with incompatible modes (:func:`mode_gradients`; order 1 only).
    """
    incompatible = bool(incompatible and order == 1)
    parts = [assemble_body(mesh, body, order, E, nu, boundary, incompatible) for body in (0, 1)]
    (b1, K1, (x1, w1, d1), fixed1), (b2, K2, (x2, w2, d2), fixed2) = parts
    iface = Interface(x=0.5 * (x1 + x2), w=0.5 * (w1 + w2), dof1=d1, dof2=d2)
    return Discretisation(
        mesh=mesh,
        order=order,
        E=E,
        nu=nu,
        bases=(b1, b2),
        scalar_bases=ScalarBases(mesh.bodies, order),
        stiffness=(K1, K2),
        fixed=(fixed1, fixed2),
        interface=iface,
        boundary=boundary,
        incompatible=incompatible,
    )


def assemble_body(mesh: TwoBodyMesh, body: int, order: int, E: float, nu: float,
                  boundary: str, incompatible: bool = False) -> tuple:
    """One body of :func:`discretise`: its vector dofs, stiffness, interface side ``(x, w,
    dofs)`` and fixed dofs, from a scalar basis of its own that goes on return with the mesh's
    cached mapping (the bodies one after the other: one basis's quadrature data at a time,
    issue 28)."""
    m = mesh.bodies[body]
    scalar = Basis(m, ELEMENTS[order]())
    vec = vector_dofs(scalar)
    K = elasticity_matrix(scalar, E, nu, incompatible)
    side = interface_side(m, mesh.nodes[("contact_upper", "contact_lower")[body]], order, scalar)
    if boundary == "half-plane":
        fixed = vector_facet_dofs(scalar, vec, outer_facets(m))
    else:
        fixed = vector_facet_dofs(scalar, vec, facets_on(m, mesh.nodes[("top", "bottom")[body]]))
    del scalar
    drop_mapping_cache(m)
    return vec, K, side, fixed


def drop_mapping_cache(mesh: MeshQuad) -> None:
    """Drop skfem's cached mapping of ``mesh``: it keeps the Jacobian at the quadrature points
    of the bases built on the mesh (10 MB a body at cattaneo ring level 3) for as long as the
    mesh lives, while only those bases read it; skfem builds it again when a basis needs it."""
    vars(mesh).pop("_cached_mapping", None)


def free_dofs(disc: Discretisation) -> tuple[np.ndarray, np.ndarray]:
    """Global free dofs (body-2 dofs offset by N1) and the global -> free index map."""
    n1 = disc.bases[0].N
    fixed = np.r_[disc.fixed[0], disc.fixed[1] + n1]
    mask = np.ones(disc.n_dofs, dtype=bool)
    mask[fixed] = False
    free = np.flatnonzero(mask)
    index = -np.ones(disc.n_dofs, dtype=np.int64)
    index[free] = np.arange(free.size)
    return free, index


def reduced_stiffness(disc: Discretisation, free: np.ndarray) -> sp.csc_matrix:
    """Block-diagonal stiffness of both bodies restricted to the free dofs."""
    K = sp.block_diag(disc.stiffness, format="csr")
    return K[free][:, free].tocsc()


def reduced_bodies(disc: Discretisation, free: np.ndarray) -> list[sp.csc_matrix]:
    """Each body's stiffness restricted to its own free dofs: the diagonal blocks of
    :func:`reduced_stiffness` (body 1's free dofs first), without forming the whole matrix."""
    return [K[local][:, local].tocsc() for K, local, _ in body_dofs(disc, free)]


def body_dofs(disc: Discretisation, free: np.ndarray) -> list[tuple]:
    """Per body ``(K_b, free_b, fixed_b)``: its stiffness, its free dofs (of ``free``, the
    global free dofs) and its prescribed dofs, both in the body's own numbering."""
    n1 = disc.bases[0].N
    return [(K, free[(free >= lo) & (free < hi)] - lo, fixed)
            for K, lo, hi, fixed in ((disc.stiffness[0], 0, n1, disc.fixed[0]),
                                     (disc.stiffness[1], n1, disc.n_dofs, disc.fixed[1]))]


@dataclass(frozen=True, eq=False)
class BulkBlocks:
    """What a load history reads of the stiffness matrices, cut from them so that they can go
    before the factorisation (issue 28: at cattaneo ring level 3 they were 17 MB of the
    history's peak, held beside the factor up to the far-field lift).

    free, index: :func:`free_dofs`.  bodies: each body's stiffness on its own free dofs
    (:func:`reduced_bodies`), a list that ``fem.condense.condense_bodies`` empties as it
    hands the matrices to the factorisation.  coupling: per body ``K_b[free_b][:, fixed_b]``
    (CSR, its rows the body's free dofs in order): the loads of prescribed displacements of
    the fixed dofs (the far-field lift).  reaction_rows: ``K_1[fixed_1]``, body 1's rows of
    its top dofs (the plate reactions)."""

    free: np.ndarray
    index: np.ndarray
    bodies: list
    coupling: tuple
    reaction_rows: sp.csr_matrix


def split_stiffness(disc: Discretisation) -> tuple[BulkBlocks, Discretisation]:
    """``(blocks, disc without its stiffness matrices)``: a caller that rebinds its ``disc``
    to the second frees the matrices (the blocks are copies)."""
    free, index = free_dofs(disc)
    coupling = tuple(K[:, fixed][local] for K, local, fixed in body_dofs(disc, free))
    blocks = BulkBlocks(free=free, index=index, bodies=reduced_bodies(disc, free),
                        coupling=coupling, reaction_rows=disc.stiffness[0][disc.fixed[0]])
    return blocks, replace(disc, stiffness=None)


__all__ = [
    "BulkBlocks",
    "Discretisation",
    "Interface",
    "ScalarBases",
    "VectorDofs",
    "discretise",
    "free_dofs",
    "mass_matrix",
    "reduced_bodies",
    "reduced_stiffness",
    "split_stiffness",
    "stiffness",
    "plane_strain_elasticity",
]
