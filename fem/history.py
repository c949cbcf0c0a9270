"""Three-stage load history driver: ``solve_history`` and ``FemHistory``.

mesh -> discretise -> factorise once -> interface compliance -> per increment the
condensed contact solve (with cut-back) -> multi-RHS solves (by blocks of increments)
recovering the full field of every increment -> plate reactions checked against (P, Q, M).
What a phase no longer needs is dropped before the next (the stiffness matrices once the
blocks the history reads are cut from them, before the factorisation; the compliance after
the increments) and the freed heap handed back
(:func:`return_freed_memory`; issue 28).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ._heap import return_freed_memory
from ._validate import check_scalars, check_settings
from .activeset import ActiveSetSolver
from .bulk import BulkBlocks, Discretisation, discretise, split_stiffness
from .condense import condense_bodies, pair_dofs
from .contact import (
    ContactState,
    InterfaceProblem,
    Load,
    NotConverged,
    initial_state,
    penetration,
    solve_augmented,
    uncoupled,
)
from .errors import ConvergenceError, InputError
from .farfield import FarField, lift
from .linsolve import Factor
from .mesh import TwoBodyMesh, as_windows, build_mesh, read_mesh
from .results import FemInterface, FemStep, runs, zones_with_uncertainty
from .settings import (
    INCOMPATIBLE_MODES,
    ContactSettings,
    LoadPath,
    MeshFile,
    MeshSpec,
    validate_boundary,
    validate_path,
)

#: Plate reactions must reproduce the applied loads to this relative accuracy (P, Q relative
#: to P0; M relative to P0 times the largest lever arm of the reaction forces, the scale of
#: the rounding in their moment sum: relative to the contact span instead, valid runs at
#: level 4 or with large bodies failed at 1e-8 while P and Q agreed to 1e-10).
EQUILIBRIUM_TOL = 1e-8
#: A contact zone needs at least this many nodes for a meaningful edge estimate.
MIN_ZONE_NODES = 5


@dataclass(frozen=True)
class FemHistory:
    """Converged increments of the three-stage history plus model information.

    steps: all increments in load order. n_dofs: displacement dofs of both bodies.
    order: element order. backend: sparse solver that ran ('cholmod', 'pypardiso'
    or 'scipy-splu'). timings: wall-clock seconds for 'mesh' (build or read), 'assembly'
    (stiffness matrices and interface),
    'factorisation+condensation' (the one factorisation and the interface
    compliance), 'increments' (all contact solves), 'recovery' (full fields and
    reaction checks of all increments) and 'history' (everything after assembly);
    ``timings['cpu']``: the same phases in process CPU seconds.
    mu, E, nu, P0, Q0: the inputs. h_min: finest
    interface element length. n_candidates: interface pairs in the contact model.
    fields: the body-field recovery (displacements, stresses); None for an interface-only
    result read from another code (``compare.external``).
    """

    steps: tuple
    n_dofs: int
    order: int
    backend: str
    timings: dict
    mu: float
    E: float
    nu: float
    P0: float
    Q0: float
    h_min: float
    n_candidates: int
    fields: object = field(repr=False, compare=False)

    @property
    def has_fields(self) -> bool:
        """Whether body fields (displacements, stresses) can be recovered."""
        return self.fields is not None

    def stage(self, k: int) -> tuple:
        """Steps of stage k (1, 2 or 3)."""
        return tuple(s for s in self.steps if s.stage == k)

    def at(self, stage: int, Q: float | None = None, P: float | None = None) -> FemStep:
        """The step of ``stage`` at tangential load Q (stages 2, 3) or normal load P (stage 1)."""
        steps = self.stage(stage)
        key, val = ("P", P) if stage == 1 else ("Q", Q)
        if val is None:
            raise InputError(f"at(stage={stage}) needs {key}=...")
        match = [s for s in steps if abs(getattr(s, key) - val) <= 1e-9 * max(self.P0, 1.0)]
        if not match:
            have = [getattr(s, key) for s in steps]
            raise InputError(f"{key}={val!r} is not a step of stage {stage}: available {have}")
        return match[-1]

    def displacement(self, step: FemStep) -> tuple[np.ndarray, np.ndarray]:
        """Full-field displacement vectors (body 1, body 2) of a step."""
        return self.fields.displacement(step.index)

    def stress(self, step: FemStep) -> tuple[np.ndarray, np.ndarray]:
        """Nodal-projected stress (sxx, syy, sxy, szz) per body, shape (4, n_points)."""
        return self.fields.stress(step.index)

    def body_stress(self, step: FemStep, body: int) -> np.ndarray:
        """Nodal-projected stress (sxx, syy, sxy, szz) of one body (0: body 1, 1: body 2)."""
        return self.fields.body_stress(step.index, body)

    def body_stresses(self, steps, body: int) -> list[np.ndarray]:
        """:meth:`body_stress` of several steps, those not yet computed projected together."""
        return self.fields.body_stresses([s.index for s in steps], body)


@dataclass(frozen=True)
class Model:
    """Everything fixed during the history: discretisation, factor, interface problem.

    disc: the discretisation without its stiffness matrices (:func:`fem.bulk.split_stiffness`
    cuts the blocks the history reads and drops them before the factorisation, issue 28);
    reaction_rows: body 1's stiffness rows of its top dofs
    (``disc.fixed[0]``), all the recovery reads of it (the plate reactions ``K1 u1``); factor:
    the bulk factor, None once the fields are recovered (:func:`without_factor`)."""

    disc: Discretisation
    factor: Factor | None
    free: np.ndarray
    f1: np.ndarray
    f2: np.ndarray
    cand: np.ndarray
    prob: InterfaceProblem
    h0_all: np.ndarray
    far: FarField | None = None
    reaction_rows: object = None


def resolve_mesh(mesh, window, kinks) -> tuple[TwoBodyMesh, int, str]:
    """Build or read the two-body mesh; return it, the element order and the boundary (the
    spec's other element setting, ``incompatible``, :func:`assemble_bodies` reads)."""
    if mesh is None:
        mesh = MeshSpec()
    if isinstance(mesh, (str, Path)):
        mesh = MeshFile(Path(mesh))
    if isinstance(mesh, MeshFile):
        if mesh.order not in (1, 2):
            raise InputError(f"order={mesh.order!r} is not allowed: need 1 or 2")
        validate_boundary(mesh.boundary)
        return read_mesh(mesh), mesh.order, mesh.boundary
    if not isinstance(mesh, MeshSpec):
        raise InputError(f"mesh={mesh!r} is not allowed: need a MeshSpec, MeshFile or a path")
    if window is None:
        raise InputError(
            "window=None is not allowed with a generated mesh: pass the expected "
            "contact window (xmin, xmax) so that the mesh is refined there"
        )
    return build_mesh(mesh, window, kinks), mesh.order, mesh.boundary


def mesh_path(mesh) -> Path | None:
    """The file of a mesh read from one (a path or MeshFile), None for a generated mesh."""
    if isinstance(mesh, (str, Path)):
        return Path(mesh)
    return mesh.path if isinstance(mesh, MeshFile) else None


def resolve_contact(contact: ContactSettings | None, E: float, h: float) -> ContactSettings:
    """Fill the default penalty stiffness and penetration tolerance."""
    c = contact or ContactSettings()
    k_n = c.k_n if c.k_n is not None else c.penalty_factor * E / h
    k_t = c.k_t if c.k_t is not None else k_n
    pen_tol = c.pen_tol if c.pen_tol is not None else 1e-4 * h
    for name, val in (("k_n", k_n), ("k_t", k_t), ("pen_tol", pen_tol)):
        if not np.isfinite(val) or val <= 0:
            raise InputError(f"{name}={val!r} is not allowed: need a positive number")
    return replace(c, k_n=k_n, k_t=k_t, pen_tol=pen_tol)


def gap_at(h0: Callable, x: np.ndarray) -> np.ndarray:
    """Evaluate the user gap function and check it (real numbers of x's shape, or one number;
    finite or +inf, >= 0)."""
    raw = np.asarray(h0(np.asarray(x, float)))
    if raw.dtype.kind not in "biuf" or raw.size not in (1, x.size):
        raise InputError(f"h0 returned {_what(raw)} for {x.size} points; need one real gap per "
                         "point (an array of x's shape), h0 >= 0 or +inf where contact is "
                         "impossible")
    g = np.broadcast_to(raw.astype(float).ravel(), x.shape).copy()  # x is 1-D
    bad = np.isnan(g) | (
        g < -1e-12 * max(1.0, float(np.max(np.abs(g[np.isfinite(g)]), initial=1.0)))
    )
    if np.any(bad) or np.any(g == -np.inf):
        i = int(np.flatnonzero(bad | (g == -np.inf))[0])
        raise InputError(
            f"h0({x[i]:g})={g[i]!r} is not allowed: need h0 >= 0 (or +inf where "
            "contact is impossible)"
        )
    return np.maximum(g, 0.0)


def _what(a: np.ndarray) -> str:
    """A user function's result in words (for an error message)."""
    if a.dtype == object and a.size == 1 and a.reshape(-1)[0] is None:
        return "None"
    return f"an array of {a.size} {a.dtype} value(s)"


def add_far_field(C: np.ndarray, D: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``C + D R`` (the bulk compliance and the far-field lift's low-rank term: D the pairs'
    relative response to the lifted fields, R the pair forces' moments), summed into C by
    blocks of FAR_FIELD_ROWS rows (C is overwritten and returned: neither a third dense
    2n x 2n array nor the whole ``D R`` beside C at the history's peak, issue 28).  If the
    bulk's tangential-normal blocks are zero (the bodies are mirror images,
    ``fem.condense``: a tangential pair force moves the pairs apart by no normal
    displacement), the lift's are zero by the same symmetry, up to its rounding (cattaneo,
    three_cylinders, applied_moment: 1.5e-14 to 4.9e-13 of max |C|), and are left out: the
    sum stays decoupled (``fem.activeset`` factorises the normal and tangential blocks
    apart)."""
    n = C.shape[0] // 2
    keep_uncoupled = uncoupled(C)
    C = row_major_in_place(C)  # the layout C + Cf had: the contact solver's rounding follows it
    for r0 in range(0, C.shape[0], FAR_FIELD_ROWS):
        r1 = min(r0 + FAR_FIELD_ROWS, C.shape[0])
        term = D[r0:r1] @ R
        if keep_uncoupled:
            term[:max(n - r0, 0), n:] = 0.0
            term[max(n - r0, 0):, :n] = 0.0
        C[r0:r1] += term
    return C


#: Rows per block of :func:`add_far_field`'s sum.
FAR_FIELD_ROWS = 256
#: Rows (and columns) per block of :func:`row_major_in_place`'s swaps.
TRANSPOSE_BLOCK = 512


def row_major_in_place(A: np.ndarray) -> np.ndarray:
    """A square A as a C-ordered array in A's own memory (A itself if it is C-ordered; a
    Fortran-ordered A's buffer transposed block by block in place: the compliance of
    ``fem.condense`` is Fortran-ordered, and a copy would cost a third dense matrix)."""
    if A.flags.c_contiguous or not A.flags.f_contiguous or A.shape[0] != A.shape[1]:
        return np.ascontiguousarray(A)
    B = A.T  # C-ordered view of the buffer: B[j, i] = A[i, j]; transposed in place, B = A
    m = B.shape[0]
    for r0 in range(0, m, TRANSPOSE_BLOCK):
        r1 = min(r0 + TRANSPOSE_BLOCK, m)
        B[r0:r1, r0:r1] = B[r0:r1, r0:r1].T.copy()
        for c0 in range(r1, m, TRANSPOSE_BLOCK):
            c1 = min(c0 + TRANSPOSE_BLOCK, m)
            upper = B[r0:r1, c0:c1].copy()
            B[r0:r1, c0:c1] = B[c0:c1, r0:r1].T
            B[c0:c1, r0:r1] = upper.T
    return B


def build_model(
    disc: Discretisation,
    bulk: BulkBlocks,
    h0: Callable,
    mu: float,
    window,
    contact: ContactSettings,
    lock_theta: bool,
    backend: str,
    timings: dict,
) -> Model:
    """Factorise the bulk, pick the candidate pairs and condense onto them.  ``bulk`` and
    ``disc``: :func:`fem.bulk.split_stiffness` (the stiffness matrices are gone before the
    factorisation: only their blocks ``bulk`` are read, and its bodies are handed to it)."""
    free, index = bulk.free, bulk.index
    x = disc.interface.x
    h0_all = gap_at(h0, x)
    cand = np.isfinite(h0_all) & (index[2 * disc.interface.dof1] >= 0)
    cand &= index[2 * disc.interface.dof2 + disc.bases[0].N] >= 0
    if window is not None:
        windows = as_windows(window)
        lo, hi = windows[0][0], windows[-1][1]
        cand &= (x >= lo - 0.5 * (hi - lo)) & (x <= hi + 0.5 * (hi - lo))
    cand = np.flatnonzero(cand)
    if cand.size < 2:
        raise InputError("h0 is infinite at (nearly) all interface nodes: no contact is possible")
    f1, f2 = pair_dofs(disc, index, cand)
    with timed(timings, "factorisation+condensation"):
        factor, C = condense_bodies(bulk.bodies, f1, f2, backend)
        far = None
        if disc.boundary == "half-plane":
            return_freed_memory()  # the factorisation's temporaries, beneath the lift's
            far = lift(disc, bulk.coupling, factor, free, x[cand])
            C = add_far_field(C, far.fields[free[f1]] - far.fields[free[f2]], far.R)
    prob = InterfaceProblem(
        C=C,
        x=x[cand],
        w=disc.interface.w[cand],
        h0=h0_all[cand],
        mu=mu,
        k_n=contact.k_n,
        k_t=contact.k_t,
        lock_theta=lock_theta,
    )
    return Model(
        disc=disc,
        factor=factor,
        free=free,
        f1=f1,
        f2=f2,
        cand=cand,
        prob=prob,
        h0_all=h0_all,
        far=far,
        reaction_rows=bulk.reaction_rows,
    )


def load_schedule(P0: float, Q0: float, M: float | None, path: LoadPath):
    """List of (stage, t, Load) targets of the whole history."""
    s2, s3 = validate_path(path, Q0)
    out = []
    for k in range(1, path.n_normal + 1):
        f = k / path.n_normal
        out.append((1, f, Load(P0 * f, 0.0, None if M is None else M * f)))
    if Q0 > 0:
        out += [(2, 1.0 + q / Q0, Load(P0, float(q), M)) for q in s2]
        out += [(3, 2.0 + (Q0 - q) / (2 * Q0), Load(P0, float(q), M)) for q in s3]
    return out


def blend(a: Load, b: Load, f: float) -> Load:
    """Load a + f (b - a)."""
    M = None if b.M is None else a.M + f * (b.M - a.M)
    return Load(a.P + f * (b.P - a.P), a.Q + f * (b.Q - a.Q), M)


def advance(
    prob: InterfaceProblem,
    old: ContactState,
    target: Load,
    contact: ContactSettings,
    stage: int,
    solver: ActiveSetSolver,
    before: ContactState | None = None,
) -> ContactState:
    """Reach ``target`` from ``old``, halving the step on failure (up to max_cutbacks times;
    ``before``: the converged state before ``old``, for the secant predictor of
    :func:`fem.contact.solve_increment`).  A step of zero length (``target`` the load reached,
    e.g. a stage 3 listed from Q0) keeps the state: solving it found no slip direction and the
    active set cycled through every cut-back."""
    if target == old.load:
        return replace(old, iterations=0)
    n_sub, last = 1, ""
    for _ in range(contact.max_cutbacks + 1):
        state, prev, its = old, before, 0
        try:
            for k in range(1, n_sub + 1):
                state, prev = solve_augmented(
                    prob, state, blend(old.load, target, k / n_sub), contact, solver, prev
                ), state
                its += state.iterations
            return replace(state, iterations=its)
        except NotConverged as exc:
            last = str(exc)
            n_sub *= 2
    raise ConvergenceError(
        f"stage {stage}: no convergence to P={target.P:g}, Q={target.Q:g} even with "
        f"{n_sub // 2} sub-increments; last failure: {last}; previous state P={old.load.P:g}, "
        f"Q={old.load.Q:g}, {int(np.count_nonzero(old.status))} active pairs, "
        f"max penetration {penetration(prob, old):.3e}"
    )


def run_increments(prob: InterfaceProblem, schedule, contact: ContactSettings, M):
    """Converged states of all scheduled increments."""
    state, before = initial_state(prob, M), None
    solver = ActiveSetSolver(prob)
    states = []
    for stage, _, target in schedule:
        state, before = advance(prob, state, target, contact, stage, solver, before), state
        states.append(state)
    return states


def check_zone_size(prob: InterfaceProblem, state: ContactState, h: float,
                    mesh_file: Path | None = None) -> None:
    """Raise InputError if a contact zone at full load holds fewer than MIN_ZONE_NODES nodes
    (``mesh_file``: the mesh read, named in the advice; None: a generated mesh)."""
    remedy = (f"refine the mesh file {mesh_file} at the interface near the contact"
              if mesh_file is not None else "raise MeshSpec.level or narrow the window")
    for i0, i1 in runs(state.status > 0):
        if i1 - i0 + 1 < MIN_ZONE_NODES:
            raise InputError(
                f"mesh too coarse: the contact zone near x=[{prob.x[i0]:g}, {prob.x[i1]:g}] "
                f"holds {i1 - i0 + 1} nodes at P0, need >= {MIN_ZONE_NODES} (element size "
                f"{h:g}): {remedy}"
            )


@contextmanager
def timed(timings: dict, key: str) -> Iterator[None]:
    """Add the wall-clock seconds of the block to ``timings[key]`` and its process CPU
    seconds to ``timings['cpu'][key]`` (on a shared machine the CPU time is the stable one; a
    phase timed in two blocks is their sum)."""
    t0, c0 = time.perf_counter(), time.process_time()
    yield
    timings[key] = timings.get(key, 0.0) + time.perf_counter() - t0
    cpu = timings.setdefault("cpu", {})
    cpu[key] = cpu.get(key, 0.0) + time.process_time() - c0


def assemble_bodies(
    mesh, window, kinks, E: float, nu: float, timings: dict
) -> tuple[TwoBodyMesh, int, Discretisation]:
    """Build or read the mesh and assemble the bulk; return the mesh, the element order and
    the discretisation (timed as 'mesh' and 'assembly')."""
    with timed(timings, "mesh"):
        tbm, order, boundary = resolve_mesh(mesh, window, kinks)
    incompatible = getattr(mesh, "incompatible", INCOMPATIBLE_MODES)  # a path: the default
    with timed(timings, "assembly"):
        disc = discretise(tbm, order, E, nu, boundary, incompatible)
    return tbm, order, disc


def solve_increments(prob: InterfaceProblem, schedule, contact: ContactSettings, M,
                     timings: dict) -> list:
    """Converged states of all scheduled increments (timed as 'increments')."""
    with timed(timings, "increments"):
        return run_increments(prob, schedule, contact, M)


def check_stage1_end(model: Model, state: ContactState, h: float,
                     mesh_file: Path | None) -> None:
    """The contact at full normal load must lie inside the candidate nodes (a run reaching
    their end where h0 goes on beyond: the window misses the contact or is too small; at a
    corner h0 = inf ends the candidates, and the contact may reach it) and be resolved
    (:func:`check_zone_size`)."""
    cand, h0_all = model.cand, model.h0_all  # h0 at every interface node
    for i0, i1 in runs(state.status > 0):
        for end, beyond in ((i0, cand[i0] - 1), (i1, cand[i1] + 1)):
            if end in (0, cand.size - 1) and 0 <= beyond < h0_all.size and \
                    np.isfinite(h0_all[beyond]):
                raise InputError(
                    f"window too small or misplaced: the contact at P0 reaches the end of the "
                    f"contact candidates at x={model.prob.x[end]:g}, where h0 goes on (the "
                    f"window gives the candidates); pass a window around the contact (the "
                    f"expected zone, with a margin)")
    check_zone_size(model.prob, state, h, mesh_file)


def without_compliance(model: Model) -> Model:
    """The model without the interface compliance C, which only the contact iterations read
    (``(2n)^2`` numbers: 0.7 GB at cattaneo ring level 6; issue 28): for the recovery."""
    return replace(model, prob=replace(model.prob, C=None))


def without_factor(model: Model) -> Model:
    """The model without the bulk factor, which nothing reads once the fields are recovered
    (cattaneo ring level 3: 50 MB held beside the fields while the steps were built; issue 28)."""
    return replace(model, factor=None)


def far_field_first(model: Model, states) -> tuple[np.ndarray, Model]:
    """(the start of the full fields of all increments: the far field of their pair forces,
    :func:`fem.fields.far_field_start`; the model without the far field's basis).  The
    caller drops its model for this one, so that the basis is gone before the backward sweeps
    at the recovery's peak (issue 28)."""
    from .fields import far_field_start

    lam = np.array([s.lam for s in states]).T
    return far_field_start(model.disc.n_dofs, model.far, lam), replace(model, far=None)


def recover_fields(model: Model, states, U: np.ndarray):
    """Full fields of all increments (:class:`fem.fields.FieldRecovery`) from their start U
    (:func:`far_field_first`)."""
    from .fields import FieldRecovery

    return FieldRecovery.from_states(model, states, U)


def result_steps(model: Model, schedule, states, fields, P0: float, mu: float) -> tuple:
    """The result step of every increment (:func:`make_step`)."""
    return tuple(
        make_step(model, i, sched, st, fields, P0, mu)
        for i, (sched, st) in enumerate(zip(schedule, states, strict=True))
    )


def solve_history(
    h0: Callable,
    P0: float,
    Q0: float,
    mu: float,
    E: float,
    nu: float,
    *,
    M: float | None = None,
    mesh=None,
    contact: ContactSettings | None = None,
    increments: LoadPath | None = None,
    kinks=(),
    window=None,
    vtk_dir=None,
    backend: str = "auto",
) -> FemHistory:
    """Solve the three-stage load history (paper, Table 1) by the finite element method.

    Parameters: h0 vectorised gap callable (np.inf where contact is impossible); P0 > 0 normal
    force; 0 <= Q0 <= mu P0 tangential amplitude; mu friction coefficient; E, nu (-1 < nu < 0.5)
    of both bodies (plane strain); M: applied moment (None: plate rotation locked = vertical
    indentation, M reported); mesh: MeshSpec, MeshFile or path; contact: ContactSettings;
    increments: LoadPath; kinks: x of profile corners (mesh nodes placed there); window:
    expected contact window (xmin, xmax), or one window per expected zone ((xmin, xmax), ...),
    for refinement (required for generated meshes; with a mesh file it limits the candidate
    contact nodes); vtk_dir: write the VTK time series there; backend: sparse solver ('auto',
    'cholmod', 'pypardiso', 'scipy-splu').
    """
    P0, Q0, mu, E, nu, M = check_scalars(P0, Q0, mu, E, nu, M)
    check_settings(h0, mesh, contact, increments, kinks, window, vtk_dir, backend)
    schedule = load_schedule(P0, Q0, M, increments or LoadPath())
    timings = {}
    tbm, order, disc = assemble_bodies(mesh, window, kinks, E, nu, timings)
    return_freed_memory()  # the assembly's temporaries
    with timed(timings, "history"):
        settings = resolve_contact(contact, E, tbm.h_min)
        with timed(timings, "factorisation+condensation"):
            bulk, disc = split_stiffness(disc)  # the stiffness matrices go: their blocks stay
        return_freed_memory()
        model = build_model(disc, bulk, h0, mu, window, settings, M is None, backend, timings)
        del bulk
        return_freed_memory()  # the factorisation's temporaries
        states = solve_increments(model.prob, schedule, settings, M, timings)
        stage1_end = max(i for i, step in enumerate(schedule) if step[0] == 1)
        check_stage1_end(model, states[stage1_end], tbm.h_min, mesh_path(mesh))
        model = without_compliance(model)
        return_freed_memory()  # the compliance and the contact solver's matrices
        with timed(timings, "recovery"):
            U, model = far_field_first(model, states)
            fields = recover_fields(model, states, U)
            model = without_factor(model)
            steps = result_steps(model, schedule, states, fields, P0, mu)
    hist = FemHistory(
        steps=steps,
        n_dofs=model.disc.n_dofs,
        order=order,
        backend=fields.backend,
        timings=timings,
        mu=mu,
        E=E,
        nu=nu,
        P0=P0,
        Q0=Q0,
        h_min=tbm.h_min,
        n_candidates=int(model.cand.size),
        fields=fields,
    )
    if vtk_dir is not None:
        from .vtk import write_vtk

        write_vtk(hist, vtk_dir)
    return hist


def make_step(
    model: Model, i: int, sched, st: ContactState, fields, P0: float, mu: float
) -> FemStep:
    """Package one converged state as a FemStep (all interface nodes, zones, reactions)."""
    stage, t, load = sched
    prob, cand = model.prob, model.cand
    iface = model.disc.interface
    n_all, n = iface.x.size, prob.n
    p, q, slip = np.zeros(n_all), np.zeros(n_all), np.zeros(n_all)
    status = np.zeros(n_all, dtype=np.int8)
    p[cand] = st.lam[n:] / prob.w
    q[cand] = -st.lam[:n] / prob.w
    status[cand] = st.status
    slip[cand] = np.where(st.status > 0, st.d[:n] + st.lam[:n] / (prob.w * prob.k_t), 0.0)
    gap = model.h0_all + fields.normal_jump(i)
    gap[cand] = prob.h0 + st.d[n:]
    candidate = np.zeros(n_all, dtype=bool)
    candidate[cand] = True
    check_outside_gap(gap, candidate, iface.x, stage, load)
    zones, sticks, u_zones, u_sticks = zones_with_uncertainty(iface.x, p, q, status, candidate,
                                                              mu, gap)
    M = float(np.sum(iface.x * p * iface.w)) if load.M is None else load.M
    reac = fields.reactions(i)
    scale = (P0, P0, P0 * max(fields.lever, float(np.max(np.abs(prob.x)))))
    res = tuple(abs(r - v) / s for r, v, s in zip(reac, (load.P, load.Q, M), scale, strict=True))
    if max(res) > EQUILIBRIUM_TOL:
        raise ConvergenceError(
            f"equilibrium check failed at stage {stage}, t={t:g}: plate reactions "
            f"(P, Q, M)={reac} vs applied ({load.P:g}, {load.Q:g}, {M:g}); "
            f"relative residuals {res} > {EQUILIBRIUM_TOL:g}"
        )
    fi = FemInterface(
        x=iface.x,
        w=iface.w,
        p=p,
        q=q,
        status=status,
        slip=slip,
        penetration=np.maximum(-np.where(np.isfinite(gap), gap, 0.0), 0.0),
        gap=gap,
    )
    return FemStep(
        index=i,
        stage=stage,
        t=float(t),
        P=load.P,
        Q=load.Q,
        M=M,
        interface=fi,
        contact_zones=zones,
        stick_zones=sticks,
        plate=(float(st.z[0]), float(st.z[1]), -float(st.z[2])),  # theta: h = h0 - theta x
        reactions=reac,
        residuals=res,
        iterations=st.iterations,
        edge_uncertainty=u_zones,
        stick_uncertainty=u_sticks,
    )


def check_outside_gap(gap, candidate, x, stage, load) -> None:
    """Nodes outside the contact model must stay open (else the window was too small)."""
    bad = (~candidate) & np.isfinite(gap) & (gap < 0)
    if np.any(bad):
        raise InputError(
            f"window too small: interface node x={x[np.flatnonzero(bad)[0]]:g} outside "
            f"the candidate region penetrates at stage {stage} (P={load.P:g}, "
            f"Q={load.Q:g}); pass a wider window"
        )
