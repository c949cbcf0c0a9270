"""Condensed frictional contact solver on the interface (penalty / augmented Lagrangian).

Unknowns of one load increment: the pair forces ``lam = [lam_t, lam_n]`` on body 1
(``-lam`` on body 2) and the plate DOFs ``z = (u_p, v_p, theta)`` (theta dropped in
vertical-indentation mode). Kinematics: relative displacement of body 1 over body 2
``d = C lam + B z`` with ``d_t = u_p``-part, ``d_n = v_p + theta x`` rigid part (plate
rotation about the point (0, 0)). Gap ``g = h0 + d_n``.

Constitutive laws per candidate pair j (tributary length w_j):
- normal: ``p_j = max(0, pbar_j - k_n g_j)``, ``lam_n = w p`` (pbar = 0: penalty;
  pbar = Uzawa multiplier: augmented Lagrangian);
- tangential: trial ``tau = tau_old - k_t (d_t - d_t_old)`` (stick), Coulomb return
  mapping ``tau = mu p sign(tau_trial)`` when ``|tau_trial| > mu p`` (slip);
  ``lam_t = w tau``. History (tau_old, d_t_old) is the last converged state.
- plate equilibrium: ``sum lam_t = -Q``, ``sum lam_n = P``, ``sum x lam_n = M``.

The laws are piecewise linear in (lam, z), so the semi-smooth Newton method with the
consistent tangent is the primal-dual active-set iteration: fix the sets
(open / stick / slip+sign), solve the small dense linear system (``fem.activeset``: a
low-rank update of a reference factorisation, not a new one per iteration), re-classify, stop
when the sets repeat and the law residual is below tolerance.  The first sets of an increment
are extrapolated along the secant of the last two converged states while the load keeps its
direction (:func:`secant_guess`: the contact and slip fronts move on by their last step), else
(change of stage, reversal; or if the iteration from the secant guess fails) the elastic
predictor's (:func:`first_guess`: the previously active pairs stick).  The first loaded
increment (no pair active before) starts from the same increment solved on every k-th pair
(:func:`coarse_guess`), not from the first-touch pairs: from those the iteration overshoots to
nearly the whole window and shrinks the set by ~25 % per system, each a new reference
factorisation; if the iteration from the coarse guess fails, or the problem is small, it
starts from the first-touch pairs.  Cattaneo, ring level 3: 61 Newton systems for the 42
increments (69 with the first increment from the first-touch pair, 204 with the elastic
predictor alone).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from .activeset import OPEN, SLIP, STICK, ActiveSetSolver, NotConverged, make_sets, rhs


def uncoupled(C: np.ndarray) -> bool:
    """Whether the tangential-normal blocks of C (order ``[t..., n...]``) are exactly zero."""
    n = C.shape[0] // 2
    return not (np.any(C[:n, n:]) or np.any(C[n:, :n]))


@dataclass(frozen=True)
class InterfaceProblem:
    """Condensed interface problem of the candidate pairs (finite h0).

    C: (2n, 2n) relative-displacement compliance, order [t..., n...].
    x, w, h0: pair x, tributary length, initial gap. mu: friction coefficient.
    k_n, k_t: penalty stiffness (stress / length). lock_theta: vertical indentation.
    """

    C: np.ndarray
    x: np.ndarray
    w: np.ndarray
    h0: np.ndarray
    mu: float
    k_n: float
    k_t: float
    lock_theta: bool

    @property
    def n(self) -> int:
        """Number of candidate pairs."""
        return self.x.size

    @property
    def n_plate(self) -> int:
        """Number of free plate DOFs (2 if theta is locked, else 3)."""
        return 2 if self.lock_theta else 3

    def plate_matrix(self) -> np.ndarray:
        """B: rigid relative displacement of the pairs per plate DOF (u_p, v_p, theta);
        read-only, built once (every Newton system reads it)."""
        return self._plate

    @cached_property
    def _plate(self) -> np.ndarray:
        n = self.n
        B = np.zeros((2 * n, 3))
        B[:n, 0] = 1.0
        B[n:, 1] = 1.0
        B[n:, 2] = self.x
        B = np.ascontiguousarray(B[:, : self.n_plate])
        B.flags.writeable = False
        return B

    @cached_property
    def split(self) -> int | None:
        """n if C's tangential-normal blocks are exactly zero (the bodies are mirror images of
        each other: elastically similar, mirrored meshes), else None."""
        return self.n if uncoupled(self.C) else None

    @cached_property
    def compliance_scale(self) -> np.ndarray:
        """``|C_jj|`` (1 where it is zero), read-only: the size of pair row j's compliance
        (the coefficient of an open row in ``fem.activeset``)."""
        c = np.abs(np.diag(self.C))
        c = np.where(c > 0, c, 1.0)
        c.flags.writeable = False
        return c


@dataclass(frozen=True)
class Load:
    """Plate load: normal force P, tangential force Q, moment M (None: theta locked)."""

    P: float
    Q: float
    M: float | None


@dataclass(frozen=True)
class ContactState:
    """Converged interface state: pair forces, relative displacement, plate DOFs, status."""

    lam: np.ndarray
    d: np.ndarray
    z: np.ndarray
    status: np.ndarray
    pbar: np.ndarray
    load: Load
    iterations: int = 0


def initial_state(prob: InterfaceProblem, M0: float | None) -> ContactState:
    """Unloaded state: zero forces and displacements, everything open."""
    n = prob.n
    return ContactState(
        lam=np.zeros(2 * n),
        d=np.zeros(2 * n),
        z=np.zeros(3),
        status=np.zeros(n, dtype=np.int8),
        pbar=np.zeros(n),
        load=Load(0.0, 0.0, None if M0 is None else 0.0),
    )


def trial(prob: InterfaceProblem, old: ContactState, d: np.ndarray, pbar: np.ndarray):
    """Trial pressure and trial shear stress (on body 1) for relative displacement d."""
    n = prob.n
    p_tr = pbar - prob.k_n * (prob.h0 + d[n:])
    tau_tr = old.lam[:n] / prob.w - prob.k_t * (d[:n] - old.d[:n])
    return p_tr, tau_tr


def classify(prob: InterfaceProblem, old: ContactState, d: np.ndarray, pbar: np.ndarray):
    """Status (open/stick/slip) and slip sign from the trial state."""
    p_tr, tau_tr = trial(prob, old, d, pbar)
    status = np.where(p_tr > 0, STICK, OPEN).astype(np.int8)
    slip = (p_tr > 0) & (np.abs(tau_tr) > prob.mu * p_tr)
    status[slip] = SLIP
    return status, np.sign(tau_tr)


def law_forces(prob: InterfaceProblem, old: ContactState, d: np.ndarray, pbar: np.ndarray):
    """Pair forces given by the contact laws (return mapping) at relative displacement d."""
    p_tr, tau_tr = trial(prob, old, d, pbar)
    p = np.maximum(p_tr, 0.0)
    tau = np.clip(tau_tr, -prob.mu * p, prob.mu * p)
    return np.r_[prob.w * tau, prob.w * p]


def law_scale(prob: InterfaceProblem, old: ContactState, lam, d, pbar) -> np.ndarray:
    """Per pair force the size of the terms the contact laws balance: the force itself, the
    penalty terms ``w k_n (|pbar/k_n| + |h0| + |d_n|)`` (normal) and ``|tau_old w| + w k_t
    (|d_t| + |d_t_old|)`` plus mu times the normal ones (tangential: slip follows mu p).
    Rounding in ``d`` (a dense solve) is relative to these, not to P: with a stiff penalty
    (k ~ 1e4 E/h) law residuals relative to P stalled above 1e-10 at convergence."""
    n, w = prob.n, prob.w
    normal = w * (np.abs(pbar) + prob.k_n * (np.abs(prob.h0) + np.abs(d[n:])))
    tangential = np.abs(old.lam[:n]) + w * prob.k_t * (np.abs(d[:n]) + np.abs(old.d[:n]))
    return np.abs(lam) + np.r_[tangential + prob.mu * normal, normal]


def law_residual(prob: InterfaceProblem, old: ContactState, lam, d, load: Load, pbar) -> float:
    """Largest violation of the contact laws (relative to :func:`law_scale` of each pair,
    at least P) and of force equilibrium (relative to P)."""
    n, P = prob.n, max(abs(load.P), 1e-300)
    scale = np.maximum(law_scale(prob, old, lam, d, pbar), P)
    laws = np.max(np.abs(lam - law_forces(prob, old, d, pbar)) / scale)
    equil = max(abs(lam[:n].sum() + load.Q), abs(lam[n:].sum() - load.P)) / P
    return float(max(laws, equil))


def solve_sets(
    solver: ActiveSetSolver, old: ContactState, status, sign, load: Load, pbar
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forces, plate DOFs and relative displacement for fixed active sets (the linear system
    of ``fem.activeset``, solved by low-rank updates of reference factorisations)."""
    prob = solver.prob
    sets = make_sets(status, sign)
    x, d = solver.solve(sets, lambda s: rhs(prob, s, old, load, pbar))
    z = np.zeros(3)
    z[: prob.n_plate] = x[2 * prob.n :]
    return x[: 2 * prob.n], z, d


FIRST_MOMENT_PAIRS = 3  # rotation free: a moment needs >= 2 pairs to be carried at all


def first_guess(prob: InterfaceProblem, old: ContactState, load: Load) -> np.ndarray:
    """Elastic predictor: previously active pairs stick; if none is active, the first-touch
    pairs, or, with the rotation free, the pairs nearest the load centre M/P (one pair alone
    cannot balance a moment: the plate equations would be singular)."""
    status = np.where(old.status > OPEN, STICK, OPEN).astype(np.int8)
    if np.any(status):
        return status
    gap = prob.h0 + old.d[prob.n :]
    if not prob.lock_theta and load.M is not None and load.P > 0:
        reachable = np.flatnonzero(np.isfinite(prob.h0))
        nearest = np.argsort(np.abs(prob.x[reachable] - load.M / load.P))
        status[reachable[nearest[:FIRST_MOMENT_PAIRS]]] = STICK
        return status
    status[gap <= gap.min() + 1e-12 * max(1.0, abs(gap.min()))] = STICK
    return status


#: Most pairs of the coarse problem of the first loaded increment (:func:`coarse_guess`):
#: every k-th candidate pair, k = ceil(n / COARSE_PAIRS).  Cattaneo rings, first increment
#: alone at 64 / 128 / 256 / 512 / 1024: level 4 (n = 1150) 5 / 4 / 3 / 2 / 2 fine systems,
#: 0.031 / 0.027 / 0.027 / 0.042 / 0.055 s CPU; level 6 (n = 4389) 7 / 6 / 5 / 4 / 4 systems,
#: 0.38 / 0.36 / 0.31 / 0.28 / 0.36 s (5.9 s from the first-touch pair): flat from 128 to 512.
COARSE_PAIRS = 256


def coarse_groups(
    prob: InterfaceProblem,
) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]] | None:
    """Groups of the coarse problem: ``label`` (the group of every pair, -1 for pairs with
    infinite h0), ``rep`` (the middle pair of every group) and the runs ``[i0, i1)`` of pairs
    they are cut from, or None if the problem is small (at most COARSE_PAIRS reachable
    pairs).  A group is a run of at most k = ceil(n / COARSE_PAIRS) neighbouring pairs that
    never spans a pair with infinite h0 or a gap in x between candidate windows
    (``x[j+1] - x[j] > w[j] + w[j+1]``: between neighbouring interface nodes the spacing is
    less than the sum of their tributary lengths).
    """
    reach = np.isfinite(prob.h0)
    k = -(-int(np.count_nonzero(reach)) // COARSE_PAIRS)
    if k < 2:
        return None
    joined = reach[:-1] & reach[1:] & (np.diff(prob.x) <= prob.w[:-1] + prob.w[1:])
    label = np.full(prob.n, -1, np.int64)
    reps = []
    runs = index_runs_of(reach, joined)
    for i0, i1 in runs:
        for chunk in np.array_split(np.arange(i0, i1), -(-(i1 - i0) // k)):
            label[chunk] = len(reps)
            reps.append(chunk[chunk.size // 2])
    return label, np.array(reps, np.int64), runs


def index_runs_of(reach: np.ndarray, joined: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs ``[i0, i1)`` of reachable pairs each joined to the next (``joined[j]``:
    pairs j and j + 1 are reachable and neighbours)."""
    starts = np.flatnonzero(reach & ~np.r_[False, joined])
    ends = np.flatnonzero(reach & ~np.r_[joined, False]) + 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def coarse_problem(
    prob: InterfaceProblem, label: np.ndarray, rep: np.ndarray
) -> InterfaceProblem:
    """The interface problem on the pairs ``rep`` only, each carrying the tributary length of
    its whole group: their x and h0, between two groups the compliance of point forces at the
    two pairs (restricted from C), within one group the compliance averaged over the group
    for forces and displacements spread like w (the self-compliance of a point force on the
    fine mesh is larger, and the predicted zones wider: cattaneo rings levels 3 / 4 / 5 with
    point forces only 115 / 226 / 460 active pairs predicted for 111 / 222 / 442, then 3 / 3 /
    5 fine systems; averaged 109 / 216 / 433 and 2 / 3 / 4)."""
    n, m = prob.n, rep.size
    idx = np.r_[rep, rep + n]
    reach = label >= 0
    C = np.ascontiguousarray(prob.C[np.ix_(idx, idx)])
    size = np.bincount(label[reach], minlength=m)
    first = np.r_[0, np.cumsum(size)[:-1]]
    order = np.flatnonzero(reach)[np.argsort(label[reach], kind="stable")]
    slot = np.arange(size.max())
    inside = slot[None, :] < size[:, None]
    member = order[np.minimum(first[:, None] + slot[None, :], order.size - 1)]
    f = np.where(inside, prob.w[member], 0.0)
    f /= f.sum(axis=1, keepdims=True)
    g = np.arange(m)
    for a in range(2):
        for b in range(2):
            block = prob.C[(member + a * n)[:, :, None], (member + b * n)[:, None, :]]
            C[g + a * m, g + b * m] = np.einsum("gi,gij,gj->g", f, block, f)
    return InterfaceProblem(
        C=C,
        x=prob.x[rep],
        w=np.bincount(label[reach], weights=prob.w[reach], minlength=m),
        h0=prob.h0[rep],
        mu=prob.mu,
        k_n=prob.k_n,
        k_t=prob.k_t,
        lock_theta=prob.lock_theta,
    )


def coarse_guess(
    prob: InterfaceProblem, old: ContactState, load: Load, pbar: np.ndarray, tol: float,
    max_iter: int,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Status and slip sign for an increment from a state with no active pair (the first
    loaded increment): the same increment solved on every k-th pair (:func:`coarse_groups`,
    :func:`coarse_problem`, from the elastic predictor there), brought to every pair by
    :func:`prolong`.  From the first-touch pair(s) alone the fine iteration overshoots (one
    pair carrying P penetrates almost the whole window) and shrinks the set by ~25 % per
    system, each a new reference factorisation (cattaneo rings level 6: 13 systems, 2687,
    1999, 1545 and 1087 active pairs factorised, 5.5 s CPU, for 883 converged; from this
    guess, 873 pairs: 5 systems, 1 factorisation, 0.38 s).  None if some pair was active, the
    problem is small, or the coarse iteration fails."""
    groups = coarse_groups(prob) if not np.any(old.status) else None
    if groups is None:
        return None
    label, rep, runs = groups
    coarse = coarse_problem(prob, label, rep)
    m, n = rep.size, prob.n
    reach = label >= 0

    def summed(v: np.ndarray) -> np.ndarray:
        return np.bincount(label[reach], weights=v[reach], minlength=m)

    start = replace(
        old,
        lam=np.r_[summed(old.lam[:n]), summed(old.lam[n:])],
        d=np.r_[old.d[rep], old.d[rep + n]],
        status=old.status[rep],
        pbar=old.pbar[rep],
    )
    try:
        state = iterate(
            coarse, start, load, pbar[rep], tol, max_iter, ActiveSetSolver(coarse),
            first_guess(coarse, start, load), np.sign(start.lam[:m]),
        )
    except NotConverged:
        return None
    return prolong(prob, old, pbar, label, rep, runs, state)


def prolong(
    prob: InterfaceProblem, old: ContactState, pbar: np.ndarray, label: np.ndarray,
    rep: np.ndarray, runs: list[tuple[int, int]], coarse: ContactState,
) -> tuple[np.ndarray, np.ndarray] | None:
    """Fine status and slip sign from the coarse state: a pair is active where its trial
    pressure is positive for the coarse normal displacement interpolated linearly in x
    between the representatives of its run (smooth, unlike h0: a pair beside a sharp punch
    corner whose group's representative touches stays open; given its group's status, one
    such pair pulled the plate into a penetration of the whole window, punch_and_cylinder:
    13 fine systems instead of 7), sticking unless its group slips; slip sign its group's.
    None if no pair would be active."""
    m = rep.size
    d_n = np.zeros(prob.n)
    for i0, i1 in runs:
        r = rep[(rep >= i0) & (rep < i1)]
        d_n[i0:i1] = np.interp(prob.x[i0:i1], prob.x[r], coarse.d[m:][label[r]])
    d = np.r_[old.d[: prob.n], d_n]
    p_tr, _ = trial(prob, old, d, pbar)
    active = (label >= 0) & (p_tr > 0)
    if not np.any(active):
        return None
    group = coarse.status[np.maximum(label, 0)]
    status = np.where(active, np.maximum(group, STICK), OPEN).astype(np.int8)
    sign = np.where(active, np.sign(coarse.lam[:m])[np.maximum(label, 0)], 0.0)
    return status, sign


#: Two load increments are parallel (the secant predictor applies) when the newer one differs
#: from a multiple of the older one by at most this fraction of the loads (blend() of one
#: target is parallel to rounding, ~1e-16; a change of stage or a reversal differs by O(1)).
PARALLEL_TOL = 1e-9


def load_ratio(before: Load, old: Load, load: Load) -> float | None:
    """``s > 0`` if the increment old -> load is s times before -> old (same direction),
    else None (nothing loaded before, change of stage, reversal)."""
    def vec(a: Load) -> np.ndarray:
        return np.array([a.P, a.Q, 0.0 if a.M is None else a.M])

    prev, new = vec(old) - vec(before), vec(load) - vec(old)
    scale = np.maximum.reduce([np.abs(vec(before)), np.abs(vec(old)), np.abs(vec(load))])
    if not np.any(prev) or not np.any(new):
        return None
    k = np.argmax(np.abs(prev) / np.maximum(scale, 1e-300))
    s = new[k] / prev[k]
    if s <= 0 or np.any(np.abs(new - s * prev) > PARALLEL_TOL * scale):
        return None
    return float(s)


def secant_guess(
    prob: InterfaceProblem, before: ContactState, old: ContactState, load: Load
) -> tuple[np.ndarray, np.ndarray] | None:
    """Status and slip sign extrapolated along the secant of the last two converged states
    (None if the load increments are not parallel, :func:`load_ratio`; ``s``: their ratio).
    The contact and slip fronts move by a few pairs per increment; the elastic predictor
    (:func:`first_guess`) restarts the slip zone from nothing, and the fronts then move by
    about one pair per Newton system (cattaneo level 3: 4-6 systems per increment).

    - an active pair stays active if its extrapolated pressure ``p + s (p - p_before)`` is
      positive; an open pair becomes active if ``G + s (G - G_before)`` is not positive, with
      ``G = sign(g) |g|^(2/3)``: near a smooth contact edge the gap grows like ``r^(3/2)`` in
      the distance r from the edge, so G is linear in r and its extrapolation moves the edge
      by s times its last step (the gap itself would overshoot, by 1.7 times at s = 1);
    - a slipping pair keeps slipping the same way (the load keeps its direction); a sticking
      one slips, the way its shear moved (``v = sign(tau - tau_before)``), if
      ``F + s (F - F_before)`` is negative, ``F = sign(e) e^2`` of its margin
      ``e = mu p - v tau``, which near a stick edge grows like ``r^(1/2)`` (Cattaneo-Mindlin;
      after a reversal the shear of the pairs that start to slip back still has the old sign).
    """
    s = load_ratio(before.load, old.load, load)
    if s is None:
        return None
    n, mu = prob.n, prob.mu

    def ahead(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return a + s * (a - b)

    way = np.sign(old.lam[:n] - before.lam[:n])

    def margin(st: ContactState) -> np.ndarray:
        e = mu * st.lam[n:] - way * st.lam[:n]
        return np.sign(e) * e**2

    def gap(st: ContactState) -> np.ndarray:
        g = np.where(np.isfinite(prob.h0), prob.h0 + st.d[n:], 1.0)
        return np.sign(g) * np.abs(g) ** (2.0 / 3.0)

    was = old.status > OPEN
    pressed = ahead(old.lam[n:], before.lam[n:]) > 0
    active = np.where(was, pressed, ahead(gap(old), gap(before)) <= 0)
    status = np.where(active, STICK, OPEN).astype(np.int8)
    slips = old.status == SLIP
    start = active & was & ~slips & (way != 0) & (ahead(margin(old), margin(before)) < 0)
    status[active & slips] = SLIP
    status[start] = SLIP
    return status, np.where(slips, np.sign(old.lam[:n]), way)


def solve_increment(
    prob: InterfaceProblem,
    old: ContactState,
    load: Load,
    pbar: np.ndarray,
    tol: float,
    max_iter: int,
    solver: ActiveSetSolver | None = None,
    before: ContactState | None = None,
) -> ContactState:
    """Semi-smooth Newton (active-set) iteration for one load increment (``solver``: the
    history's reference factorisations, a fresh one if None).  The first sets are the secant
    predictor's (:func:`secant_guess`, from ``before``, the converged state before ``old``) when
    the load keeps its direction, else, if no pair was active, the coarse predictor's
    (:func:`coarse_guess`), else the elastic predictor's (:func:`first_guess`); if the
    iteration from the secant or coarse guess fails, it is repeated from the elastic one (its
    iterations are counted too), so neither guess adds a failure.  (The coarse problem's own
    Newton systems are not counted: they are solves of at most COARSE_PAIRS pairs.)"""
    solver = solver or ActiveSetSolver(prob)
    guess = None if before is None else secant_guess(prob, before, old, load)
    secant = guess is not None
    if not secant:
        guess = coarse_guess(prob, old, load, pbar, tol, max_iter)
    spent = 0
    if guess is not None:
        try:
            return iterate(prob, old, load, pbar, tol, max_iter, solver, *guess, guessed=secant)
        except NotConverged as exc:
            spent = exc.iterations
    state = iterate(
        prob, old, load, pbar, tol, max_iter, solver, first_guess(prob, old, load),
        np.sign(old.lam[: prob.n]),
    )
    return replace(state, iterations=state.iterations + spent)


def iterate(
    prob: InterfaceProblem,
    old: ContactState,
    load: Load,
    pbar: np.ndarray,
    tol: float,
    max_iter: int,
    solver: ActiveSetSolver,
    status: np.ndarray,
    sign: np.ndarray,
    guessed: bool = False,
) -> ContactState:
    """The active-set iteration from the sets (status, slip sign): stops when the sets repeat
    and the law residual is <= tol; NotConverged (with its ``iterations``) if the sets cycle
    or max_iter systems do not converge.  ``guessed``: the first sets are the secant guess,
    and a slipping pair that the system finds slipping the other way sticks in the next sets
    instead (the guess moved a slip front too far: at the end of stage 3 the returning front
    meets the front of stage 2, where the margin's extrapolation overshoots; reversing those
    pairs sent the iteration to full sliding and a cycle: cattaneo level 3, full_slip_first).
    The sets are accepted only when the classification itself repeats them, so this changes
    the path, not the converged state."""
    seen = set()
    for it in range(1, max_iter + 1):
        lam, z, d = solve_sets(solver, old, status, sign, load, pbar)
        new_status, new_sign = classify(prob, old, d, pbar)
        if guessed:
            new_status[(status == SLIP) & (new_status == SLIP) & (new_sign != sign)] = STICK
        if not np.any(new_status):
            new_status[np.argmin(prob.h0 + d[prob.n :])] = STICK
        key = (new_status.tobytes(), (new_sign * (new_status == SLIP)).tobytes())
        same = np.array_equal(new_status, status) and np.array_equal(
            new_sign[status == SLIP], sign[status == SLIP]
        )
        residual = law_residual(prob, old, lam, d, load, pbar)
        if same and residual <= tol:
            return ContactState(
                lam=lam, d=d, z=z, status=status, pbar=pbar, load=load, iterations=it
            )
        if key in seen and not same:
            raise NotConverged(f"active set cycles after {it} iterations", it)
        seen.add(key)
        status, sign = new_status, new_sign
    raise NotConverged(
        f"no convergence in {max_iter} iterations (law residual {residual:.3e})", max_iter
    )


def penetration(prob: InterfaceProblem, state: ContactState) -> float:
    """Largest penetration -g over the candidate pairs (0 if none)."""
    return float(max(0.0, -np.min(prob.h0 + state.d[prob.n :])))


def solve_augmented(
    prob: InterfaceProblem,
    old: ContactState,
    load: Load,
    settings,
    solver: ActiveSetSolver | None = None,
    before: ContactState | None = None,
) -> ContactState:
    """One increment; with ``settings.augmented`` Uzawa updates until penetration <= pen_tol
    (``solver``, ``before``: as in :func:`solve_increment`)."""
    solver = solver or ActiveSetSolver(prob)
    pbar = old.lam[prob.n :] / prob.w if settings.augmented else np.zeros(prob.n)
    state = solve_increment(
        prob, old, load, pbar, settings.newton_tol, settings.max_newton, solver, before
    )
    if not settings.augmented:
        return state
    its = state.iterations  # the increment's Newton systems, summed over the Uzawa updates
    for _ in range(settings.max_uzawa):
        if penetration(prob, state) <= settings.pen_tol:
            return replace(state, iterations=its)
        pbar = state.lam[prob.n :] / prob.w
        state = solve_increment(
            prob, old, load, pbar, settings.newton_tol, settings.max_newton, solver, before
        )
        its += state.iterations
    if penetration(prob, state) <= settings.pen_tol:
        return replace(state, iterations=its)
    raise NotConverged(
        f"Uzawa: penetration {penetration(prob, state):.3e} > pen_tol="
        f"{settings.pen_tol:.3e} after {settings.max_uzawa} updates"
    )
