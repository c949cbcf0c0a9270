"""Full-field recovery of every increment from the condensed solution.

Multi-RHS solves with the existing factor give the clamped-top response of both bodies to the
pair forces of all increments, added to their far field (with CHOLMOD's per-body factors
only the backward sweep, ``Factor.pair_solve``, by blocks of increments:
``fem.condense.RECOVERY_BLOCK``); body 1 then gets the plate's rigid motion
``u = u_p - theta y, v = v_p + theta x``. Plate reactions are
recovered as ``K1 u1`` on the top dofs (the rows of K1 the model kept); stresses are
projected (L2) onto the nodal basis on demand, the increments asked for together in one
multi-RHS solve with sparse strain operators.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np
from scipy.sparse import csr_matrix
from skfem.models.elasticity import lame_parameters

from .bulk import MODES_BLOCK, compact, mass_matrix, mode_block, vector_dofs
from .condense import pair_loads
from .linsolve import factorize

#: Per strain operator (xx, yy, xy): its (component c, derivative d, factor) terms d_d u_c.
STRAIN_PARTS = (((0, 0, 1.0),), ((1, 1, 1.0),), ((0, 1, 0.5), (1, 0, 0.5)))
#: Rows of the recovered fields per block of :func:`far_field_start` and
#: :func:`add_plate_motion` (even: a node's two dofs).
MOTION_ROWS = 8192
#: Order in which the projector builds the strain operators: eps_xy (twice the entries) first.
XY_FIRST = (2, 0, 1)


class FieldRecovery:
    """Displacements of both bodies for all increments; stresses computed lazily."""

    def __init__(self, disc, U1: np.ndarray, U2: np.ndarray, backend: str = "auto",
                 reaction_rows=None):
        """``reaction_rows``: body 1's stiffness rows of its top dofs ``disc.fixed[0]`` (None:
        read from ``disc.stiffness``)."""
        self.disc = disc
        #: Sparse backend of the stress projections (the bulk's: CHOLMOD when available).
        self.backend = backend
        self.U = (U1, U2)
        top = disc.fixed[0]
        if reaction_rows is None:
            reaction_rows = disc.stiffness[0][top]
        F1 = reaction_rows @ U1  # the top rows of K1 U1 only
        xy = disc.bases[0].doflocs[:, top]
        is_x = top % 2 == 0
        rx = np.where(is_x[:, None], F1, 0.0)
        ry = np.where(~is_x[:, None], F1, 0.0)
        self._reactions = np.c_[-ry.sum(axis=0), rx.sum(axis=0), -(xy[0] @ ry - xy[1] @ rx)]
        #: Largest lever arm (about (0, 0)) of the plate reaction forces (length).
        self.lever = float(np.max(np.hypot(xy[0], xy[1])))
        self._stress = {}
        self._mass = {}
        self._projector = {}

    @classmethod
    def from_states(cls, model, states, U: np.ndarray | None = None) -> FieldRecovery:
        """Recover the full fields of a list of converged contact states (the model of
        :func:`fem.history.build_model`); the sweeps' temporaries are of one block of
        increments (``fem.condense.RECOVERY_BLOCK``), the numbers those of all at once.  ``U``:
        the fields' start, :func:`far_field_start` of the states (None: made here from
        ``model.far``); the sweeps add the bulk response to it in place, then body 1 gets the
        plate's motion by blocks of rows (:func:`add_plate_motion`)."""
        disc = model.disc
        lam = np.array([s.lam for s in states]).T
        if U is None:
            U = far_field_start(disc.n_dofs, model.far, lam)
        if model.factor.pair_solve is not None:  # straight into the free rows of U
            model.factor.pair_solve(lam, out=U, rows=model.free, add=True)
        else:
            U[model.free] += model.factor.solve(pair_loads(model.free.size, model.f1,
                                                           model.f2, lam))
        N1 = disc.bases[0].N
        add_plate_motion(U, disc.bases[0].doflocs, np.array([s.z for s in states]).T)
        U1, U2 = U[:N1], U[N1:]  # views: no second copy of the fields
        return cls(disc, U1, U2, model.factor.backend, model.reaction_rows)

    def displacement(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Displacement dof vectors (body 1, body 2) of increment i."""
        return self.U[0][:, i].copy(), self.U[1][:, i].copy()

    def reactions(self, i: int) -> tuple[float, float, float]:
        """Plate reactions (P, Q, M) of increment i from the top-dof forces of body 1."""
        return tuple(float(v) for v in self._reactions[i])

    def normal_jump(self, i: int) -> np.ndarray:
        """v1 - v2 at every interface pair."""
        iface = self.disc.interface
        return self.U[0][2 * iface.dof1 + 1, i] - self.U[1][2 * iface.dof2 + 1, i]

    def stress(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Nodal (L2-projected) stresses (sxx, syy, sxy, szz) of both bodies at increment i."""
        return self.body_stress(i, 0), self.body_stress(i, 1)

    def body_stress(self, i: int, body: int) -> np.ndarray:
        """Nodal stresses of one body (0: body 1, 1: body 2) at increment i (computed once)."""
        return self.body_stresses([i], body)[0]

    def mass(self, body: int):
        """Scalar nodal mass matrix of one body (assembled once; the stress projection and the
        lumped nodal weights of the stress metrics share it)."""
        if body not in self._mass:
            self._mass[body] = mass_matrix(self.disc.scalar_bases[body])
        return self._mass[body]

    def lumped_mass(self, body: int) -> np.ndarray:
        """Row sums of :meth:`mass` (the area of each scalar node)."""
        return np.asarray(self.mass(body).sum(axis=1)).ravel()

    def body_stresses(self, indices, body: int) -> list[np.ndarray]:
        """Nodal stresses of one body at several increments; those not yet computed are
        projected together (one multi-RHS solve with the body's mass factor)."""
        todo = [i for i in dict.fromkeys(int(i) for i in indices) if (i, body) not in self._stress]
        if todo:
            for i, s in zip(todo, self._project(body, todo), strict=True):
                self._stress[i, body] = s
        return [self._stress[int(i), body] for i in indices]

    def _project(self, body: int, cols: list[int]) -> list[np.ndarray]:
        """Plane-strain stresses (sxx, syy, sxy, szz) of increments ``cols`` of one body, L2
        projected onto its scalar nodal basis: ``M s = int phi sigma(u) dx`` per component."""
        if body not in self._projector:  # one factorisation and one operator per body
            ops = projection_operators(self.disc, body, self.mass(body))
            self._projector[body] = (factorize(self.mass(body), self.backend),
                                     tuple(ops[XY_FIRST.index(c)] for c in range(3)))
            self.disc.scalar_bases.release(body)  # the mass and the operators hold its data
        mass, (Rxx, Ryy, Rxy) = self._projector[body]
        E, nu = self.disc.E, self.disc.nu
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
        U = self.U[body][:, cols]
        exx, eyy, exy = Rxx @ U, Ryy @ U, Rxy @ U  # the loads of the strains
        del U
        tr = exx + eyy
        k = len(cols)
        rhs = np.empty((tr.shape[0], 4 * k), order="F")  # the solver's order: no copy of it
        rhs[:, :k] = lam * tr + 2 * mu * exx
        rhs[:, k:2 * k] = lam * tr + 2 * mu * eyy
        rhs[:, 2 * k:3 * k] = 2 * mu * exy
        rhs[:, 3 * k:] = lam * tr
        del exx, eyy, exy, tr
        S = mass.solve(rhs)  # column c k + j: component c of increment j
        del rhs
        return [np.ascontiguousarray(S[:, j::k].T) for j in range(k)]


def far_field_start(n_dofs: int, far, lam: np.ndarray) -> np.ndarray:
    """The start of the recovered fields (all dofs of both bodies x increments, C order): the
    far field of the pair forces ``lam`` (``far``: ``fem.farfield.FarField``, its
    :meth:`displacement`; None, clamped bodies: zeros), by blocks of MOTION_ROWS rows (no
    full-field temporary).  It comes first so that the far field's basis can go before the
    backward sweeps, which add the bulk response to it (issue 28: 3.8 MB of the recovery's
    peak at cattaneo ring level 3; the sums are those of the response plus the far field)."""
    U = np.zeros((n_dofs, lam.shape[1]))
    if far is not None:
        moments = far.R @ lam
        for r0 in range(0, n_dofs, MOTION_ROWS):
            r1 = min(r0 + MOTION_ROWS, n_dofs)
            U[r0:r1] += far.fields[r0:r1] @ moments
    return U


def add_plate_motion(U: np.ndarray, loc: np.ndarray, z: np.ndarray) -> None:
    """Add to the recovered fields U body 1's rigid motion with the plate ``u = u_p - theta y,
    v = v_p + theta x`` (``z`` (3, increments), ``loc`` body 1's (2, N1) dof coordinates), by
    blocks of MOTION_ROWS rows of all increments: contiguous rows of U, no full-field
    temporary (issue 28)."""
    n1 = loc.shape[1]
    for r0 in range(0, n1, MOTION_ROWS):
        b1 = min(r0 + MOTION_ROWS, n1)  # x dofs at even rows, y dofs at odd ones (MOTION_ROWS even)
        U[r0:b1:2] += z[0] - loc[1, r0:b1:2, None] * z[2]
        U[r0 + 1:b1:2] += z[1] + loc[0, r0 + 1:b1:2, None] * z[2]


def projection_operators(disc, body: int, mass: csr_matrix) -> list[csr_matrix]:
    """The loads of the strains on one body's scalar nodal basis, ``load_operator @ B`` for
    the strain operators B in XY_FIRST's order (``disc.incompatible``: Q1 elements with
    incompatible modes, :func:`mode_projection_operators`, on the pattern of the body's
    ``mass`` matrix)."""
    scalar = disc.scalar_bases[body]
    if disc.incompatible:  # Q1 only (fem.bulk.discretise)
        return mode_projection_operators(scalar, XY_FIRST, disc.E, disc.nu, mass)
    load, ops = load_operator(scalar), []
    # one at a time (issue 28: level 5's peak; no zip, whose result tuple would hold the last
    # one while the next is built), the largest (eps_xy) first: its temporaries then sit
    # beside the load operator alone
    for B in iter_strain_operators(scalar, XY_FIRST):
        ops.append((load @ B).tocsr())
        del B
    return ops


def strain_operators(scalar) -> tuple[csr_matrix, csr_matrix, csr_matrix]:
    """The three operators of :func:`iter_strain_operators` together."""
    return tuple(iter_strain_operators(scalar))


def iter_strain_operators(scalar, components: Sequence[int] = (0, 1, 2), modes=None
                          ) -> Iterator[csr_matrix]:
    """Sparse ``(Bxx, Byy, Bxy)`` with ``B @ u`` the strains ``eps_xx, eps_yy, eps_xy`` of the
    vector dof vector u (numbering :class:`fem.bulk.VectorDofs`) at the quadrature points of
    the scalar basis (rows ``(e, k)`` as in :func:`load_operator`; row ``(e, k)`` holds element
    e's vector dofs ``2 a + c`` in that order, the gradient of component c of vector shape
    function ``(a, c)`` being scalar ``grad phi_a`` in row c, exact zeros dropped; built in CSR
    form directly), yielded one at a time, each built from the basis's gradients alone (a row
    of ``eps_cc`` holds only the component-c dofs: no structural zeros, no stacked copy of the
    gradients, 32-bit indices where they fit), so that a caller need not hold all three and
    the temporaries are of one operator's size (issue 28); ``components``: which of them (0, 1,
    2: xx, yy, xy) in which order.  ``modes``: the incompatible modes' ``(T, G)`` of
    :func:`fem.bulk.mode_recovery` (Q1 elements with incompatible modes): their strain joins
    every operator, ``sum_(m, i) sym(G_m e_i) (T u_e)_(m, i)``, and every row then holds all
    the element's dofs."""
    if modes is not None:
        yield from mode_strain_operators(scalar, components, modes)
        return
    n_el, n_qp = scalar.dx.shape
    vec = vector_dofs(scalar)
    n_loc = vec.element_dofs.shape[0]
    itype = np.int32 if vec.N < np.iinfo(np.int32).max else np.int64
    dofs = np.asarray(vec.element_dofs, dtype=itype).T  # (n_el, n_loc)
    grad = [np.asarray(phi[0].grad) for phi in scalar.basis]  # views: (2, n_el, n_qp) each
    # eps_cc: d_c of component c; eps_xy = (d_y u_x + d_x u_y) / 2
    for parts in (STRAIN_PARTS[c] for c in components):
        local = sorted(2 * a + c for c, _, _ in parts for a in range(n_loc // 2))
        g = np.empty((n_el, n_qp, len(local)))
        for c, d, f in parts:
            for a in range(n_loc // 2):
                g[..., local.index(2 * a + c)] = grad[a][d] if f == 1.0 else f * grad[a][d]
        indices = np.ascontiguousarray(
            np.broadcast_to(dofs[:, None, local], (n_el, n_qp, len(local)))).ravel()
        indptr = np.arange(0, n_el * n_qp * len(local) + 1, len(local), dtype=itype)
        B = csr_matrix((g.ravel(), indices, indptr), shape=(n_el * n_qp, vec.N))
        del g, indices
        entries = B.nnz
        B.eliminate_zeros()
        if B.nnz < entries:  # zeros dropped: arrays of B's own size (else they already are)
            B = compact(B)
        yield B
        del B


def mode_strain_operators(scalar, components: Sequence[int], modes) -> Iterator[csr_matrix]:
    """:func:`iter_strain_operators` of Q1 elements with incompatible modes ``(T, G)``: row
    ``(e, k)`` holds the element's 8 vector dofs ``2 a + c`` in that order."""
    T, G = modes
    n_el, n_qp = scalar.dx.shape
    vec = vector_dofs(scalar)
    itype = np.int32 if vec.N < np.iinfo(np.int32).max else np.int64
    dofs = np.asarray(vec.element_dofs, dtype=itype).T  # (n_el, 8)
    grad = [np.asarray(phi[0].grad) for phi in scalar.basis]
    indptr = np.arange(0, n_el * n_qp * 8 + 1, 8, dtype=itype)
    for parts in (STRAIN_PARTS[c] for c in components):
        g = mode_strain_values(grad, parts, T, G)
        indices = np.ascontiguousarray(np.broadcast_to(dofs[:, None, :], g.shape)).ravel()
        yield csr_matrix((g.ravel(), indices, indptr), shape=(n_el * n_qp, vec.N))
        del g, indices


def mode_strain_values(grad: list, parts, T: np.ndarray, G: np.ndarray) -> np.ndarray:
    """(e, q, 8): the strain ``parts`` (:data:`STRAIN_PARTS`) of each local vector dof ``2 a +
    c`` of Q1 elements with incompatible modes, at their quadrature points: the standard
    gradients ``grad`` (per local node a, (2, e, q)) and the modes' strain (mode (m, i) at
    column 2 m + i, its amplitudes ``T u_e``; T (e, 4, 8), G (2, 2, e, q),
    ``fem.bulk.mode_recovery``)."""
    shape = grad[0].shape[1:]
    g = np.zeros((*shape, 8))
    modal = np.zeros((*shape, 4))
    for c, d, f in parts:
        for a in range(4):
            g[..., 2 * a + c] += f * grad[a][d]
        for m in range(2):
            modal[..., 2 * m + c] += f * G[m, d]
    g += np.einsum("eqk,ekj->eqj", modal, T)
    return g


def mode_projection_operators(scalar, components: Sequence[int], E: float, nu: float,
                              nodal: csr_matrix) -> list[csr_matrix]:
    """``load_operator(scalar) @ B`` for each B of :func:`mode_strain_operators` (the loads of
    the strains on the scalar nodal basis; Q1 elements with incompatible modes of the material
    E, nu), assembled element by element, ``sum_q phi_a(x_eq) dx_eq g_eq``
    (:func:`mode_strain_values`) per (scalar node a, vector dof), by blocks of
    ``fem.bulk.MODES_BLOCK`` elements with the modes of the block alone
    (``fem.bulk.mode_block``), the operators sharing one pattern (:func:`vector_pattern` of
    ``nodal``, a scalar matrix coupling the nodes of every element: the mass matrix):
    neither the load operator, nor B (8 entries per quadrature point: 17 MB each at cattaneo
    ring level 3, the comparison's peak, issue 28), nor the modes of all elements is formed.
    The numbers are the product's to rounding (the sums in another order)."""
    vec = vector_dofs(scalar)
    n_el = scalar.nelems
    lam, mu = lame_parameters(E, nu)
    grad = [np.asarray(phi[0].grad) for phi in scalar.basis]
    weight = [np.asarray(phi[0]) * scalar.dx for phi in scalar.basis]  # (e, q) each
    indptr, indices, where = vector_pattern(nodal, np.asarray(scalar.element_dofs))
    data = [np.zeros(indices.size) for _ in components]
    for e0 in range(0, n_el, MODES_BLOCK):
        sl = slice(e0, min(e0 + MODES_BLOCK, n_el))
        T, G = mode_block(scalar, sl, lam, mu, grad)
        block = [ga[:, sl] for ga in grad]
        w = np.array([wa[sl] for wa in weight])  # (4, e, q)
        for out, c in zip(data, components, strict=True):
            local = np.einsum("aeq,eqj->eaj", w, mode_strain_values(block, STRAIN_PARTS[c], T, G))
            np.add.at(out, where[sl].ravel(), local.ravel())  # O(block), not O(nnz)
    return [csr_matrix((d, indices, indptr), shape=(scalar.N, vec.N)) for d in data]


def vector_pattern(nodal: csr_matrix, element_dofs: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pattern ``(indptr, indices)`` of an operator from a scalar nodal basis to its vector
    dofs (``2 b + c``, ``fem.bulk.VectorDofs``) coupling the nodes of every element, and
    ``where`` (e, a, 2 b + c): the position in its data of element e's entry (local node a,
    local vector dof).  ``nodal``: a scalar matrix (CSR, sorted indices) with an entry for
    every two nodes of an element (the mass matrix), each of whose columns b becomes the
    columns 2 b, 2 b + 1; ``element_dofs``: the scalar basis's (n_loc, e)."""
    n = nodal.shape[1]
    itype = np.int32 if 2 * max(n, nodal.nnz) < np.iinfo(np.int32).max else np.int64
    indptr = (2 * nodal.indptr).astype(itype)
    indices = np.empty(2 * nodal.nnz, dtype=itype)
    indices[0::2], indices[1::2] = 2 * nodal.indices, 2 * nodal.indices + 1
    keys = np.repeat(np.arange(nodal.shape[0], dtype=np.int64), np.diff(nodal.indptr))
    keys = keys * n + nodal.indices  # ascending: CSR order
    dofs = element_dofs.T.astype(np.int64)  # (e, n_loc)
    wanted = dofs[:, :, None] * n + dofs[:, None, :]  # (e, a, b)
    pos = np.searchsorted(keys, wanted)
    if not np.array_equal(keys[np.minimum(pos, keys.size - 1)], wanted):
        raise RuntimeError("the nodal pattern lacks a pair of nodes of an element")
    del wanted
    where = (2 * pos.astype(itype))[..., None] + np.arange(2, dtype=itype)  # (e, a, b, c)
    return indptr, indices, where.reshape(pos.shape[0], pos.shape[1], -1)


def load_operator(scalar) -> csr_matrix:
    """Sparse B with ``B @ f.ravel() = asm(LinearForm(f v), scalar)`` for a field f given at
    the quadrature points (shape (n_elements, n_points)): B[dof, (e, k)] = phi(x_ek) dx_ek.

    Built in CSR form directly (columns ascending in every row: the arrays ``coo.tocsr()``
    gives, without its COO-sized temporaries, issue 28): an element's local dofs are distinct,
    so sorting the (dof, element) pairs orders every row."""
    n_el, n_qp = scalar.dx.shape
    dofs = np.asarray(scalar.element_dofs)  # (n_loc, n_el)
    order = np.lexsort((np.tile(np.arange(n_el), dofs.shape[0]), dofs.ravel()))
    local, el = np.divmod(order, n_el)
    itype = np.int32 if max(scalar.N, n_el * n_qp + 1, order.size * n_qp) < 2**31 else np.int64
    indices = (el.astype(itype)[:, None] * n_qp + np.arange(n_qp, dtype=itype)).ravel()
    data = np.empty((order.size, n_qp))
    for i, phi in enumerate(scalar.basis):
        rows = local == i
        data[rows] = (np.asarray(phi[0]) * scalar.dx)[el[rows]]
    indptr = np.zeros(scalar.N + 1, itype)
    np.cumsum(np.bincount(dofs.ravel(), minlength=scalar.N) * n_qp, out=indptr[1:])
    return csr_matrix((data.ravel(), indices, indptr), shape=(scalar.N, n_el * n_qp))


def von_mises(s: np.ndarray) -> np.ndarray:
    """Von Mises stress from (sxx, syy, sxy, szz) rows."""
    sxx, syy, sxy, szz = s
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3 * sxy**2)
