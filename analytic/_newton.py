"""Newton's method on the equations of one contact topology (paper Sections 2-4).

A topology is a :class:`analytic._sie.Layout`: the zones' edges and which of them are singular.
The unknowns (:class:`State`) are its free edges, the free coefficients ``beta`` of the
polynomial T of the inversion formula and, in applied-moment mode, the rigid rotation theta;
:class:`Mode` says which of them are solved for.  The residual rows are the consistency
conditions (Eq. 12/14), equilibrium, the rigid interconnections (Eq. 17) and the moment, each
scaled; :func:`newton` solves them by damped Newton with a finite-difference Jacobian evaluated
in one batch, reused between continuation steps (Broyden updates), and accepts a residual at
the rounding floor of the edges' positions once the consistency conditions also hold in
physical units (CONSISTENCY_TOL: the closed-form load and moment assume them).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, replace

import numpy as np

from analytic._sie import Batch, Layout, System
from analytic.profiles import Profile
from analytic.selfcheck import h0_steps

NEWTON_TOL = 1e-13          # scaled residual; edges then agree to ~1e-12 relative
NEWTON_MAXIT = 40
STEP_TOL = 1e-12            # ... and the next Newton step moves no unknown (edges / span) more
POLISH_STEPS = 3            # steps allowed beyond NEWTON_TOL to meet STEP_TOL
FLOOR_TOL = 1e-10          # accepted when rounding stalls Newton (zones ~1e-6 of the span)
ULP_FLOOR = 64.0            # ... or below the residual change of this many ulps of the edges
REFRESH_RATIO = 0.1         # a reused Jacobian gaining less than this per step is refreshed
FD_STEP = 1e-7              # relative finite-difference step for the Jacobian
FD_ULPS = 64.0              # ... and the smallest step of an edge in units in the last place
CONSISTENCY_TOL = 1e-10     # |mu_j| ell^(e-n) / (A P) a solve may end with (or one ulp of the
                            # edges' effect, if larger): 1/10 of the moment self-check's 1e-9,
                            # which it bounds (moment 0.4-0.5 of it: seeds 100797 / 100836 left
                            # at 2.6e-9 / 2.1e-8 by FLOOR_TOL were refused, issue 29)
CONSISTENCY_STEPS = 3       # full Newton steps allowed at the rounding floor to meet it
STALL_STEPS = 8             # Newton fails when this many accepted steps in a row (above the
STALL_GAIN = 0.05           # rounding floor) reduce the residual by less than this in all:
                            # 1983 solves of 274 audit cases: converging ones reduced it by
                            # >= 26 % over any 8 steps, 177 of 290 failing ones crawled at
                            # < 5 % for 10-40 steps (0.2-1 s each; issue 29)
WALL_HALVINGS = 4           # a line search that halved this often to stay feasible (an edge
WALL_STEPS = 6              # at a ridge it may not cross) this many steps in a row, gaining
                            # < STALL_GAIN in all, fails (audit seed 103644, theta = 0: an
                            # edge crawled onto the ridge 2.0049 for 20-37 iterations, 0.5-1.1 s,
                            # before "no descent"). 1110 converging solves of audit seeds
                            # 0-299 took at most 5 such steps in a row, then escaped with an
                            # uncut step and converged (3 would cut those of 9 seeds)


@dataclass(frozen=True)
class Mode:
    """Which quantities are unknown: edges (free ones), beta, theta; driver = fixed free edge."""

    P: float | None           # None: P is an output (driver mode)
    M: float | None           # None: theta fixed
    driver: int | None = None
    notches: tuple[tuple[int, float, float], ...] = ()
    """(position among the packed edges, ridge q, side) of every edge solved for as
    ``ln(|x - q| / ell)`` (:func:`notch_edges`); side -1: the edge lies left of q."""


@dataclass
class State:
    """One topology's unknowns at load ``P``: the edges (``layout``), the coefficients ``beta``
    of T and the rotation ``theta``; ``xc``, ``ell``: centre and length of the edge span (the
    scales of the packed unknowns); ``jac``: the last Jacobian (reused by the next solve);
    ``checks``: the admissibility figures of the accepted state."""

    layout: Layout
    beta: np.ndarray
    theta: float
    P: float
    xc: float
    ell: float
    jac: np.ndarray | None = None
    checks: dict | None = None
    F: np.ndarray | None = None  # scaled residuals of the last Newton solve of this state
    system: System | None = None  # the System its residual was evaluated with (reused)
    jac_notches: tuple = ()  # Mode.notches of the unknowns ``jac`` was taken in


def fresh_state(layout: Layout, theta: float, P: float) -> State:
    """An unsolved state on ``layout``: beta zero, scales from the edge span."""
    e = layout.edges
    ell = max(float(e[-1] - e[0]), 1e-300)
    return State(layout, np.zeros(max(layout.n - layout.e, 0)), theta, P,
                 float(0.5 * (e[0] + e[-1])), ell)


def beta_for(st: State, A: float, P: float) -> np.ndarray:
    """``st.beta`` with its last coefficient ``-A P`` (the one the total load fixes)."""
    beta = st.beta.copy()
    if beta.size:
        beta[-1] = -A * P
    return beta


def _free_edges(layout: Layout, mode: Mode) -> np.ndarray:
    free = layout.free
    return free[free != mode.driver] if mode.driver is not None else free


def _n_beta_free(layout: Layout, mode: Mode) -> int:
    nb = max(layout.n - layout.e, 0)
    return nb if mode.P is None else max(nb - 1, 0)


NOTCH_GAP = 0.1
"""A gap between two zones narrower than this times the narrower zone, around one ridge of h0,
has its two edges solved for as ``ln(distance to the ridge)``.  Such a gap closes only
exponentially in the load (the merged zone's pressure would be -log-singular at the ridge, so
the gap is where that log term would cross zero): the equations depend on its edges like
ln(d), and Newton in x overshot across the ridge, crawled at 1/512 steps and failed ("too many
iterations", "stalled") from predictions within 30 % of d (audit seed 103644 vertical: the gap
2.7e-5 at the ridge 2.2304 of a punch beside two cylinders, zones 0.22 and 0.43 wide; it
solves with 0.01 and with 0.1, whose wider reach saves a few of its failed steps).  Audit seeds
103000-103599 (normal solves): results bit-identical but one, 9e-14 off (103558)."""


def notch_edges(st: State, mode: Mode, profile: Profile) -> tuple[tuple[int, float, float], ...]:
    """:attr:`Mode.notches` of ``st``: both free edges of every gap narrower than NOTCH_GAP times
    its narrower neighbour that holds exactly one ridge."""
    e = st.layout.edges
    free = _free_edges(st.layout, mode).tolist()
    ridges = profile.ridges
    out = []
    for m in range(st.layout.n - 1):
        b, a = 2 * m + 1, 2 * m + 2
        gap = e[a] - e[b]
        width = min(e[b] - e[b - 1], e[a + 1] - e[a])
        inside = [q for q in ridges if e[b] < q < e[a]]
        if b in free and a in free and len(inside) == 1 and gap < NOTCH_GAP * width:
            out += [(free.index(b), inside[0], -1.0), (free.index(a), inside[0], 1.0)]
    return tuple(out)


def _pack(st: State, mode: Mode) -> np.ndarray:
    free = _free_edges(st.layout, mode)
    x = (st.layout.edges[free] - st.xc) / st.ell
    for j, q, side in mode.notches:
        x[j] = math.log(side * (st.layout.edges[free[j]] - q) / st.ell)
    z = [x, st.beta[: _n_beta_free(st.layout, mode)]]
    if mode.M is not None:
        z.append(np.array([st.theta]))
    return np.concatenate(z)


def _unpack(z: np.ndarray, st: State, mode: Mode, A: float) -> State:
    free = _free_edges(st.layout, mode)
    edges = st.layout.edges.copy()
    edges[free] = st.xc + st.ell * z[: free.size]
    for j, q, side in mode.notches:
        d = max(st.ell * math.exp(min(float(z[j]), 700.0)), 4.0 * math.ulp(q))
        edges[free[j]] = q + side * d
    nbf = _n_beta_free(st.layout, mode)
    beta = st.beta.copy()
    beta[:nbf] = z[free.size: free.size + nbf]
    nb = max(st.layout.n - st.layout.e, 0)
    if mode.P is not None and nb > 0:
        beta[nb - 1] = -A * mode.P
    theta = float(z[-1]) if mode.M is not None else st.theta
    return State(st.layout.with_edges(edges), beta, theta, st.P, st.xc, st.ell, st.jac,
                 jac_notches=st.jac_notches)


def residual(st: State, mode: Mode, profile: Profile, A: float) -> tuple[np.ndarray, System]:
    """The scaled residual rows of ``st`` (:func:`_rows`) and the System that gave them."""
    sys_ = System.build(st.layout, profile, A, st.theta, st.xc, st.beta)
    return _rows(sys_.batch, st, mode)[0], sys_


def _rows(batch: Batch, st: State, mode: Mode) -> np.ndarray:
    """Scaled residuals ``(K, equations)`` of every member of ``batch`` (``st`` gives the load
    and length scales): consistency (Eq. 12/14), equilibrium, interconnection (Eq. 17), moment."""
    lay, A = batch.layout, batch.A
    n, e = lay.n, lay.e
    P_ref = mode.P if mode.P is not None else max(abs(st.P), 1e-300)
    slope = np.abs(batch.sq.dh).sum(axis=1) / batch.sq.dh.shape[1]
    g_scale = A * P_ref + slope * st.ell + 1e-300
    rows = []
    if e > n:
        mu, norm = batch.consistency()
        rows.append(mu / (norm + 1e-300))
    if mode.P is not None and e >= n:
        rows.append(batch.load()[:, None] / mode.P - 1.0)
    rows.append(batch.interconnections() / g_scale[:, None])
    if mode.M is not None:
        rows.append((batch.load_and_moment()[1][:, None] - mode.M) / (P_ref * st.ell))
    return np.concatenate(rows, axis=1)


def feasible(st: State, profile: Profile) -> bool:
    """Edges finite, strictly increasing, inside the support, free edges where h0 is finite,
    and no zone spanning a ridge or a corner where h0 steps (a sharp punch beside a cylinder:
    a released corner edge crossed onto the cylinder's flank, 13 higher; scalar checks: this
    runs at every trial point)."""
    e = st.layout.edges.tolist()
    tol = 1e-14 * st.ell
    if not all(math.isfinite(v) for v in e) or \
            any(b - a <= tol for a, b in zip(e, e[1:], strict=False)):
        return False
    lo, hi = profile.support
    if e[0] < lo - tol or e[-1] > hi + tol:
        return False
    if profile.pieces_have_gaps:
        inner = profile.h0(st.layout.edges[~st.layout.pinned])
        if not np.all(np.isfinite(inner)):
            return False
    inside = [q for q in (*profile.ridges, *profile.corners)
              if any(a < q < b for a, b in zip(e[::2], e[1::2], strict=True))]
    return not any(q in profile.ridges or h0_steps(profile, q) for q in inside)


_EVENTS: ContextVar[Counter | None] = ContextVar("analytic_solver_events", default=None)


@contextmanager
def counted_events() -> Iterator[Counter]:
    """Count the solver's exceptional events (e.g. ``jacobian_nonfinite_columns``) inside the
    block; the counter is yielded (nested blocks count into their own)."""
    counter: Counter = Counter()
    token = _EVENTS.set(counter)
    try:
        yield counter
    finally:
        _EVENTS.reset(token)


def count_event(name: str, k: int = 1) -> None:
    """Add ``k`` to the event ``name`` of the innermost :func:`counted_events` block."""
    counter = _EVENTS.get()
    if counter is not None:
        counter[name] += k


class NewtonFailed(Exception):
    def __init__(self, msg: str, diag: dict) -> None:
        super().__init__(msg)
        self.diag = diag


def newton(st: State, mode: Mode, profile: Profile, A: float) -> tuple[State, np.ndarray]:
    """Damped Newton; a Jacobian carried over from the previous continuation step is reused
    (chord iterations) until the contraction slows, then refreshed by finite differences."""
    mode = replace(mode, notches=notch_edges(st, mode, profile))
    z = _pack(st, mode)
    F, st.system = residual(st, mode, profile, A)
    if z.size != F.size:
        raise AssertionError(f"unknowns {z.size} != equations {F.size}")
    if z.size == 0:
        return st, F
    norm = float(np.max(np.abs(F)))
    if not np.isfinite(norm):
        raise NewtonFailed("non-finite residual at the start", {"residual": norm})
    J = st.jac if st.jac is not None and st.jac.shape == (F.size, z.size) \
        and st.jac_notches == mode.notches else None
    fresh, polish, floor = False, 0, FLOOR_TOL
    crawl: list[float] = []  # the residual before each accepted step above the floor
    wall: list[float] = []  # ... before each step in a row cut by the feasible set
    for it in range(NEWTON_MAXIT):
        if norm < NEWTON_TOL:
            dz = _polish_step(J, F) if polish < POLISH_STEPS else None
            if dz is None:
                break
            polish += 1
        else:
            if J is None:
                J, fresh = _jacobian(z, F, st, mode, profile, A), True
                floor = _rounding_floor(J, st, mode)
            try:
                dz = np.linalg.solve(J, -F)
            except np.linalg.LinAlgError as exc:
                if not fresh:
                    J = None
                    continue
                raise NewtonFailed("singular Jacobian",
                                   {"residual": norm, "iteration": it}) from exc
        chord = None if polish or fresh else _chord_step(st, z, dz, norm, mode, profile, A)
        if not (polish or fresh) and chord is None:
            J = None  # stale Jacobian: refresh and retry from the same point
            continue
        trial, zt, Ft, nt, cut = chord + (0,) if chord else _line_search(st, z, dz, norm, mode,
                                                                         profile, A)
        if polish and not nt < NEWTON_TOL:
            break  # the polishing step would leave the converged set: keep the state
        if not polish and nt > 0.5 * norm and np.all(np.abs(F) < floor):
            break  # rounding floor reached with a fresh Jacobian: accept
        if nt >= norm and not np.all(np.abs(Ft) < floor):
            raise NewtonFailed("no descent", {"residual": norm, "iteration": it})
        _check_stall(crawl, norm, nt, F, floor, it)
        _check_wall(wall, cut, norm, nt, F, floor, it)
        step = zt - z
        if step @ step > 0:  # Broyden's rank-one update keeps the reused Jacobian current
            J = J + np.outer(Ft - F - J @ step, step) / (step @ step)
        st, z, F, fresh = trial, zt, Ft, False
        if np.max(np.abs(dz)) < 1e-15 and np.all(np.abs(Ft) < floor):
            norm = nt
            break
        norm = nt
    else:
        if not np.all(np.abs(F) < floor):
            raise NewtonFailed("too many iterations", {"residual": norm,
                                                       "iteration": NEWTON_MAXIT})
    st, F, J = _settle_consistency(st, z, F, J, mode, profile, A, floor)
    st.jac, st.jac_notches = J, mode.notches
    return st, F


def _consistency_error(st: State, mode: Mode, profile: Profile,
                       A: float) -> tuple[np.ndarray, np.ndarray]:
    """The consistency residuals (paper Eq. 12) of ``st`` in physical units,
    ``|mu_j| ell^(e-n) / (A P)``, and the absolute sums that scale Newton's rows in the same
    units (both empty without consistency conditions).

    The load and the moment are closed forms (:meth:`analytic._sie.Batch.load_and_moment`) that
    hold once consistency holds: ``A P`` is the integral of the monic degree-(e - n)
    polynomial on the zones' centres times ``h' omega``, and ``s^(e-n)`` differs from it by
    ``sum_j c_j^(e-n) L_j(s)`` (``|c_j| <= ell``), so a residual ``mu_j`` (Lagrange basis
    ``L_j``) moves the closed-form load by ~``|mu_j| ell^(e-n) / A`` and the moment about the
    centre by that times ``ell``: relative to ``P`` and ``P ell`` (the self-check's lever arm is
    at least ``ell / 2``).  Newton's rows divide ``mu_j`` by their absolute sums instead, which
    are 300-1800 times ``A P / ell^(e-n)`` for narrow zones far apart at small loads (seeds
    100797, 100836), so rows at FLOOR_TOL's 1e-11 left 2.6e-9 and 2.1e-8 there."""
    lay = st.layout
    if lay.e <= lay.n:
        return np.zeros(0), np.zeros(0)
    mu, sums = _system(st, profile, A).batch.consistency()
    P_ref = mode.P if mode.P is not None else max(abs(st.P), 1e-300)
    k = lay.e - lay.n
    error = np.abs(mu[0]) * (st.ell ** k / (A * P_ref))
    return error, (sums[0] + 1e-300) * st.ell ** k / (A * P_ref)


def _system(st: State, profile: Profile, A: float) -> System:
    return st.system or System.build(st.layout, profile, A, st.theta, st.xc, st.beta)


def _settle_consistency(st: State, z: np.ndarray, F: np.ndarray, J: np.ndarray | None,
                        mode: Mode, profile: Profile, A: float, floor: np.ndarray | float
                        ) -> tuple[State, np.ndarray, np.ndarray | None]:
    """``st`` (every scaled row below its rounding floor) once each consistency residual
    (:func:`_consistency_error`) is below CONSISTENCY_TOL or below its change when every free
    edge moves by one unit in the last place (the rounding of the edges: 1-8e-9 at the notch
    of seed 103644, 5.6e-10 at seed 100836); a state that meets it is returned as it is (with
    ``J``).  Else up to CONSISTENCY_STEPS full Newton steps on a fresh Jacobian, each kept while
    every row stays below its floor and the largest consistency residual falls (the line
    search cannot: its merit, the largest scaled row, is then another row's rounding, e.g. the
    moment's at seed 100836).  A state that does not get there is returned as the steps left it
    (never worse): the self-check (analytic.selfcheck) judges it as before, so this polishes
    and never refuses (refusing put four of issue 29's wedge cases, tiny zones at their first
    touch, out of reach)."""
    error, sums = _consistency_error(st, mode, profile, A)
    if np.all(error < CONSISTENCY_TOL):
        return st, F, J
    m, J_in = error.size, J
    for step in range(CONSISTENCY_STEPS + 1):
        J = _jacobian(z, F, st, mode, profile, A)
        one_ulp = (np.abs(J[:m]) @ _edge_ulps(st, mode, J.shape[1])) * sums
        if np.all(error < np.maximum(CONSISTENCY_TOL, one_ulp)) or step == CONSISTENCY_STEPS:
            break
        try:
            zt = z + np.linalg.solve(J, -F)
        except np.linalg.LinAlgError:
            break
        trial = _unpack(zt, st, mode, A)
        if not feasible(trial, profile):
            break
        Ft, trial.system = residual(trial, mode, profile, A)
        et, st_sums = _consistency_error(trial, mode, profile, A)
        if not (np.all(np.abs(Ft) < floor) and et.max() < error.max()):
            break
        st, z, F, error, sums = trial, zt, Ft, et, st_sums
    return st, F, J if step else J_in  # unmoved: the Jacobian it came with (bit-identical)


def _check_stall(crawl: list[float], norm: float, nt: float, F: np.ndarray,
                 floor: np.ndarray | float, it: int) -> None:
    """Record an accepted step from ``norm`` to ``nt``; raise :class:`NewtonFailed` when the
    last STALL_STEPS steps above the rounding floor reduced the residual by less than
    STALL_GAIN in all (a topology without a solution nearby: Newton crawls until
    NEWTON_MAXIT, refreshing its Jacobian at every step)."""
    _record_crawl(crawl, not np.all(np.abs(F) < floor), norm, nt, STALL_STEPS, "stalled", it)


def _check_wall(wall: list[float], cut: int, norm: float, nt: float, F: np.ndarray,
                floor: np.ndarray | float, it: int) -> None:
    """Record a step from ``norm`` to ``nt`` whose line search halved ``cut`` times to stay
    feasible; raise :class:`NewtonFailed` when the last WALL_STEPS steps were each cut at
    least WALL_HALVINGS times and reduced the residual by less than STALL_GAIN in all (Newton
    pushes an edge onto a ridge or corner it may not cross and crawls along it); not at the
    rounding floor (as :func:`_check_stall`)."""
    counts = cut >= WALL_HALVINGS and not np.all(np.abs(F) < floor)
    _record_crawl(wall, counts, norm, nt, WALL_STEPS, "against the feasible set", it)


def _record_crawl(log: list[float], counts: bool, norm: float, nt: float, steps: int,
                  reason: str, it: int) -> None:
    """Append ``norm`` to ``log`` for a step that counts (else start the log again); raise
    :class:`NewtonFailed` (``reason``) when the last ``steps`` counted steps in a row reduced
    the residual by less than STALL_GAIN in all."""
    if not counts:
        log.clear()
        return
    log.append(norm)
    if len(log) >= steps and nt > (1.0 - STALL_GAIN) * log[-steps]:
        raise NewtonFailed(reason, {"residual": nt, "iteration": it,
                                    "residual_steps_before": log[-steps]})


def _rounding_floor(J: np.ndarray, st: State, mode: Mode) -> np.ndarray:
    """Residual level of each equation below which Newton may stop: FLOOR_TOL, or the change of
    that residual when every free edge moves by ULP_FLOOR units in the last place of its
    absolute position, if larger.  Edges are stored as x, so an edge a distance d past a kink
    (a rounded corner's start at a small load, d ~ P^(2/3)) carries a relative load error
    ~ eps |x| / d."""
    floor = np.maximum(FLOOR_TOL, ULP_FLOOR * (np.abs(J) @ _edge_ulps(st, mode, J.shape[1])))
    # not the interconnections: scaled by A P + |h'| span, not by the gaps' own size A P, they
    # would accept a wrong load split between narrow zones far apart (double wedge, P = 1e-8)
    lay = st.layout
    first = max(lay.e - lay.n, 0) + int(mode.P is not None and lay.e >= lay.n)
    floor[first: first + lay.n - 1] = FLOOR_TOL
    return floor


def _edge_ulps(st: State, mode: Mode, size: int) -> np.ndarray:
    """One unit in the last place of every free edge's position, in the packed unknowns
    (``size`` of them; zero for the others)."""
    free = _free_edges(st.layout, mode)
    ulp = np.zeros(size)
    ulp[: free.size] = np.spacing(np.abs(st.layout.edges[free])) / st.ell
    for j, q, side in mode.notches:  # ln(d): an ulp of x is a relative 1 ulp / d of d
        ulp[j] = np.spacing(abs(st.layout.edges[free[j]])) / (side * (st.layout.edges[free[j]] - q))
    return ulp


def _polish_step(J: np.ndarray | None, F: np.ndarray) -> np.ndarray | None:
    """The Newton step from a state that meets NEWTON_TOL, when it would still move an unknown
    by more than STEP_TOL (an ill-conditioned system, e.g. zones about to merge); else None."""
    if J is None:
        return None
    try:
        dz = np.linalg.solve(J, -F)
    except np.linalg.LinAlgError:
        return None
    return dz if np.max(np.abs(dz)) > STEP_TOL else None


def _fd_steps(z: np.ndarray, st: State, mode: Mode, profile: Profile) -> np.ndarray:
    """Finite-difference steps: an edge moves by FD_STEP times the width of its own zone (zones
    may be many orders narrower than the span) or its distance to the nearest kink, if smaller
    (an edge just past a rounded corner's start at a small load), other unknowns relative to
    their size."""
    h = FD_STEP * np.maximum(1.0, np.abs(z))
    free = _free_edges(st.layout, mode)
    edges = st.layout.edges[free]
    smooth = np.minimum(st.layout.edge_widths()[free], profile.feature_distance(edges))
    # but by at least FD_ULPS units in the last place of x (the edges are stored as x): a zone
    # 4e-9 wide at x = 1 (a wedge apex at a small load) would step by 2 ulps
    h[: free.size] = np.maximum(FD_STEP * smooth, FD_ULPS * np.spacing(np.abs(edges))) / st.ell
    for j, q, side in mode.notches:  # ln(d): a relative step of d (x moves away from q)
        h[j] = max(FD_STEP, FD_ULPS * np.spacing(abs(edges[j])) / (side * (edges[j] - q)))
    return h


def _away_from_features(steps: np.ndarray, st: State, mode: Mode, profile: Profile
                        ) -> np.ndarray:
    """The steps with the sign of every edge's step turned where it would reach or cross a kink
    or corner, and no longer than the distance to it.  An edge a few ulps from a kink steps by
    FD_ULPS ulps; a member whose edge crossed a kink the quadrature plan grades towards, or
    moved away from it by several times its distance (the grading is planned on that distance:
    the outer graded panels then overshoot the segment), had panels of negative length, a NaN
    Jacobian column (issue 26: punch_and_cylinder, a free edge 13 ulps past a corner)."""
    free = _free_edges(st.layout, mode)
    out = steps.copy()
    edges = st.layout.edges[free]
    near = profile.feature_distance(edges)
    logs = {j for j, _, _ in mode.notches}  # ln(d): never reaches its ridge, steps 1e-7 of d
    for j, x in enumerate(edges.tolist()):
        if j in logs:
            continue
        if _crosses_feature(profile, x, x + out[j] * st.ell):
            out[j] = -out[j]
        if np.isfinite(near[j]) and abs(out[j]) * st.ell > near[j]:
            out[j] = math.copysign(near[j] / st.ell, out[j])
    return out


def _crosses_feature(profile: Profile, x: float, to: float) -> bool:
    """Whether a kink or corner lies in ``[x, to]`` (or ``[to, x]``) with ``to != x``."""
    features = profile.features
    return bool(features.size) and bool(np.any((features - x) * (features - to) <= 0.0))


def _batch_rows(st: State, states: list[State], mode: Mode, profile: Profile, A: float
                ) -> np.ndarray:
    """Scaled residual rows of ``states`` on the quadrature planned for ``st.layout``; a
    member whose panels turned inside out gives non-finite rows (counted by the caller)."""
    with np.errstate(invalid="ignore"):
        batch = Batch.build(st.layout, profile, A, st.xc,
                            np.array([q.layout.edges for q in states]),
                            np.array([q.theta for q in states]),
                            np.array([q.beta for q in states]))
        return _rows(batch, st, mode)


def _jacobian(z, F, st, mode, profile, A) -> np.ndarray:
    """Forward differences, all columns in one batch evaluation with the discretisation frozen
    on the current layout (the base point is evaluated in the same batch).  A non-finite
    column is an explicit event: counted (``jacobian_nonfinite_columns`` in the solution's
    ``diagnostics``), recomputed with the step reversed, and a column still not finite fails
    the Newton solve."""
    steps = _away_from_features(_fd_steps(z, st, mode, profile), st, mode, profile)
    states = [st] + [_fd_member(z, j, steps, st, mode, profile, A) for j in range(z.size)]
    R = _batch_rows(st, states, mode, profile, A)
    bad = np.flatnonzero(~np.all(np.isfinite(R[1:]), axis=1))
    if bad.size:
        count_event("jacobian_nonfinite_columns", int(bad.size))
        steps[bad] = -steps[bad]
        redo = [st] + [_unpack(_stepped(z, j, steps[j]), st, mode, A) for j in bad.tolist()]
        R[1 + bad] = _batch_rows(st, redo, mode, profile, A)[1:]
        if not np.all(np.isfinite(R[1 + bad])):
            raise NewtonFailed("non-finite Jacobian column", {"columns": bad.tolist()})
    return ((R[1:] - R[0]) / steps[:, None]).T


def _stepped(z: np.ndarray, j: int, step: float) -> np.ndarray:
    zp = z.copy()
    zp[j] += step
    return zp


def _fd_member(z, j, steps, st, mode, profile, A) -> State:
    """The state of column j; its step reversed (in ``steps``) when the forward one is not
    feasible, unless the reversed step would reach a kink or corner (a free edge ulps past a
    punch's corner, the zone not feasible itself: its step stays pointing away)."""
    trial = _unpack(_stepped(z, j, steps[j]), st, mode, A)
    if feasible(trial, profile):
        return trial
    back = _unpack(_stepped(z, j, -steps[j]), st, mode, A)
    moved = np.flatnonzero(back.layout.edges != st.layout.edges)
    if moved.size and _crosses_feature(profile, float(st.layout.edges[moved[0]]),
                                       float(back.layout.edges[moved[0]])):
        return trial
    steps[j] = -steps[j]
    return back


def _chord_step(st, z, dz, norm, mode, profile, A):
    """The full step of a reused (Broyden-updated) Jacobian, if it is feasible and gains at
    least a factor 1/REFRESH_RATIO; else None (the Jacobian is refreshed at once: halving such
    a step, up to 30 residual evaluations, never gave that gain on 274 audit cases and took
    half of all residual evaluations, issue 29)."""
    zt = z + dz
    trial = _unpack(zt, st, mode, A)
    if not feasible(trial, profile):
        return None
    Ft, trial.system = residual(trial, mode, profile, A)
    nt = float(np.max(np.abs(Ft)))
    return (trial, zt, Ft, nt) if nt <= REFRESH_RATIO * norm else None


def _line_search(st, z, dz, norm, mode, profile, A):
    """Backtracking from the full step: the accepted ``(state, z, F, norm)`` and how many
    halvings were for feasibility (trial points outside the feasible set)."""
    lam, cut = 1.0, 0
    for _ in range(30):
        zt = z + lam * dz
        trial = _unpack(zt, st, mode, A)
        if feasible(trial, profile):
            Ft, trial.system = residual(trial, mode, profile, A)
            nt = float(np.max(np.abs(Ft)))
            if np.isfinite(nt) and (nt < (1 - 1e-4 * lam) * norm or nt < NEWTON_TOL):
                return trial, zt, Ft, nt, cut
        else:
            cut += 1
        lam *= 0.5
    return st, z, residual(st, mode, profile, A)[0], norm, cut
