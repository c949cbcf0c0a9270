"""Continuation in the load P at fixed rotation theta, with the contact topology kept
admissible.

:func:`solve_fixed` solves at one load (Newton from the overlap guess, else continuation from
the first touch); :func:`continue_to` follows the load in geometric steps, predicting the edges
by extrapolation in log P through earlier states of the same topology, halving a failed step
or merging two zones about to meet.  :func:`converge` solves one step: Newton
(:mod:`analytic._newton`), then pins, admissibility checks and topology events until the state
is admissible; it raises :class:`StepFailed` when the topology does not settle.
"""

from __future__ import annotations

import math

import numpy as np

from analytic._admissibility import find_event
from analytic._first_touch import initial_state
from analytic._guess import centred, overlap_guess
from analytic._newton import Mode, NewtonFailed, State, beta_for, feasible, fresh_state, newton
from analytic._sie import Layout, System
from analytic._topology import (
    PIN_DISTANCE,
    VERTICAL_LANDING,
    Event,
    apply_event,
    pin_nearest,
    shrunk_new_zone,
)
from analytic.errors import ConvergenceError, TableEndError
from analytic.profiles import Profile

MAX_TOPOLOGY_CHANGES = 12
TARGET_RETRIES = 10
"""The continuation gives up when the step to its target load failed this often, from ever
closer loads (each retry comes from a state at least half the log-distance closer): a phantom
overlap at the target (a tabulated spline's gap, issue 29 item 4) made it retry for minutes,
one 0.2-s failure at a time, until its 400-step guard."""


class StepFailed(Exception):
    """A continuation step found no admissible state (its caller shortens the step, merges
    zones, or gives up with a :class:`analytic.errors.ConvergenceError`)."""


def solve_fixed(profile: Profile, P: float, A: float, theta: float) -> tuple[State, System]:
    """Newton straight from the overlap guess at P; full continuation from the first touch if
    that fails (the admissibility checks decide either way)."""
    return solve_from_guess(profile, P, A, theta) or solve_from_first_touch(profile, P, A, theta)


def solve_from_guess(profile: Profile, P: float, A: float, theta: float
                     ) -> tuple[State, System] | None:
    """Newton from the overlap guess at P, then from its zones re-centred; None if both fail.
    Re-centred zones that cross a neighbour (edges not increasing) are no start: Newton from
    such a layout took 3.3 s to find no descent (audit seed 101132, a bi-quadratic punch whose
    inner edges were re-centred past each other)."""
    guess = overlap_guess(profile, theta, P, A)
    if guess is not None:
        for layout in (guess, centred(guess, profile, theta)):
            if np.any(np.diff(layout.edges) <= 0):
                continue
            st = fresh_state(layout, theta, P)
            st.beta = beta_for(st, A, P)
            try:
                return converge(st, profile, A, None)
            except StepFailed:
                pass
    return None


def solve_from_first_touch(profile: Profile, P: float, A: float, theta: float
                           ) -> tuple[State, System]:
    """Continuation in the load from the first touch to P."""
    st = initial_state(profile, A, theta, P)
    st, sys_, _ = continue_to(st, P, profile, A)
    return st, sys_


def continue_to(st: State, P_target: float, profile: Profile, A: float,
                prev: tuple[State, ...] = ()) -> tuple[State, System, tuple[State, ...]]:
    ratio = 4.0
    sys_ = None
    guard = retries = 0
    while True:
        guard += 1
        if guard > 400:
            raise ConvergenceError("continuation did not reach the load", {"P": st.P})
        P_next = P_target if st.P * ratio >= P_target else st.P * ratio
        try:
            trial = _predict(st, prev, P_next, profile)
            new, sys_ = converge(trial, profile, A, None)
        except StepFailed as exc:
            merged = _try_merge(st, P_next, profile, A)
            if merged is not None:
                prev, (st, sys_) = (), merged
                if P_next == P_target:
                    return st, sys_, prev
                continue
            retries += P_next == P_target
            if retries >= TARGET_RETRIES:
                _refuse_at_table_end(st, P_target, profile, exc)
                raise ConvergenceError(
                    f"continuation cannot reach P={P_target:.6g}: the step to it failed "
                    f"{retries} times, the last from P={st.P:.6g}: {exc}",
                    {"P_reached": st.P, "P_target": P_target,
                     "zones": st.layout.zones()}) from exc
            ratio = np.sqrt(P_next / st.P)  # half the failed step (in log P), not of ratio
            if ratio < 1 + 1e-7:
                _refuse_at_table_end(st, P_target, profile, exc)
                raise ConvergenceError(f"continuation stalled at P={st.P:.6g}: {exc}",
                                       {"P_reached": st.P, "P_target": P_target,
                                        "zones": st.layout.zones()}) from exc
            continue
        prev, st = (st, *prev[:PREDICTOR_POINTS - 2]), new
        if P_next == P_target:
            return st, sys_, prev
        ratio = min(ratio * ratio, 16.0)


TABLE_END_REACH = 1e-4
"""A continuation that fails with an edge this close to the end of a tabulated profile's table
(relative to the edges' span) stopped because the contact reached the end: h0 is unknown beyond
it (a Hertz zone of half-width 2.5 on a table of +-1 stalled with its edges 2e-8 from the ends,
"against the feasible set")."""


def _refuse_at_table_end(st: State, P_target: float, profile: Profile, exc: Exception) -> None:
    """Raise :class:`TableEndError` when an edge of ``st`` (the last state reached on the way
    to ``P_target``) lies within TABLE_END_REACH of an end of the table."""
    e = st.layout.edges
    ends = [q for q in profile.open_ends if np.min(np.abs(e - q)) <= TABLE_END_REACH * st.ell]
    if ends:
        where = ", ".join(f"x={q!r}" for q in ends)
        raise TableEndError(
            f"P={P_target!r} is not allowed on profile={profile.name}: the contact reaches the "
            f"end of its table at {where} near P={st.P:.6g}{_tilt_text(st)} (zones "
            f"{_zones_text(st)}), and h0 is unknown beyond it; need a load below that, or a "
            f"longer table (extend it beyond the contact at P={P_target!r})") from exc


def _tilt_text(st: State) -> str:
    return f" and theta={st.theta:.6g}" if st.theta != 0.0 else ""


def _zones_text(st: State) -> str:
    return ", ".join(f"[{a:.9g}, {b:.9g}]" for a, b in st.layout.zones())


PREDICTOR_POINTS = 8  # states of one topology the predictor may extrapolate through


def _predict(st: State, prev: tuple[State, ...], P_next: float, profile: Profile) -> State:
    """Edges at P_next extrapolated in log P through the current state and up to
    ``PREDICTOR_POINTS - 1`` earlier states of the same topology, with the degree chosen where
    the extrapolation's last correction is smallest (:func:`_extrapolate`); a square-root
    widening of every zone when there is no history."""
    edges = st.layout.edges.copy()
    free = ~st.layout.pinned
    same = [q for q in prev if q.P != st.P and _same_topology(q.layout, st.layout)]
    if same:
        pts = [st, *same[:PREDICTOR_POINTS - 1]]
        u = [math.log(q.P) for q in pts]
        if len(set(u)) < len(u):
            pts, u = pts[:2], u[:2]
        guess = _extrapolate(u, [q.layout.edges for q in pts], math.log(P_next))
    else:
        z = edges.reshape(-1, 2)
        mid = z.mean(1, keepdims=True)
        guess = (mid + (z - mid) * np.sqrt(P_next / st.P)).ravel()
    edges[free] = guess[free]
    trial = Layout(edges, st.layout.pinned)
    beta = st.beta * (P_next / st.P) if st.beta.size else st.beta
    new = State(trial, beta, st.theta, P_next, st.xc, st.ell, st.jac, jac_notches=st.jac_notches)
    if np.any(np.diff(edges) <= 0) or not feasible(new, profile):
        new = State(st.layout, beta, st.theta, P_next, st.xc, st.ell, st.jac,
                    jac_notches=st.jac_notches)
    return new


def _same_topology(a: Layout, b: Layout) -> bool:
    return a.pinned is b.pinned or a.pinned.tobytes() == b.pinned.tobytes()


def _extrapolate(u: list[float], y: list[np.ndarray], at: float) -> np.ndarray:
    """Polynomial extrapolation to ``at`` through ``(u_j, y_j)`` (nearest first) by Neville's
    table: the estimates of degree 0, 1, ... use the nearest points first, and the one whose
    correction over the degree below is smallest is returned (beyond it the corrections grow:
    the path's own singularities or the states' rounding take over)."""
    row = np.array(y, float)  # row i of level d: the estimate through points i .. i + d
    x = at - np.asarray(u, float)[:, None]
    best, best_change = row[0], math.inf
    for d in range(1, len(u)):
        row = (x[d:] * row[:-1] - x[:-d] * row[1:]) / (x[d:] - x[:-d])
        change = float(np.max(np.abs(row[0] - best)))
        if change >= best_change and d > 1:
            break
        best, best_change = row[0], change
    return best


def converge(st: State, profile: Profile, A: float, M: float | None,
             changes: int = MAX_TOPOLOGY_CHANGES) -> tuple[State, System]:
    """Newton on ``st``'s topology, then pins and topology events until the state is
    admissible, with at most ``changes`` Newton solves (one: no change of topology)."""
    history: list[Event] = []
    starts: set[bytes] = set()
    for _ in range(changes):
        st = _recentre(st)
        _check_cycle(st.layout, starts, history)
        try:
            st, F = newton(st, Mode(st.P, M), profile, A)
        except NewtonFailed as exc:
            pinned = pin_nearest(st, profile, A, PIN_DISTANCE * st.layout.edge_widths())
            if pinned is None:
                st = shrunk_new_zone(st, history, A, profile)
                if st is None:
                    raise StepFailed(str(exc)) from exc
                history.append(Event("reseed", history[-1].where))
                continue
            history.append(Event("pin", pinned[1]))
            st = pinned[0]
            continue
        landed = pin_nearest(st, profile, A, np.full(st.layout.edges.size, 1e-10 * st.ell)) \
            or pin_nearest(st, profile, A, np.full(st.layout.edges.size, VERTICAL_LANDING
                                                   * st.ell), profile.vertical_ends)
        if landed is not None:  # a free edge converged onto a corner: re-solve it as singular
            history.append(Event("pin", landed[1]))
            st = landed[0]
            continue
        sys_ = st.system or System.build(st.layout, profile, A, st.theta, st.xc, st.beta)
        ev = find_event(st, sys_, profile, A)
        if ev is None:
            st.F = F
            return st, sys_
        history.append(ev)
        st = apply_event(st, ev, sys_, profile)
        st.beta = beta_for(st, A, st.P)
    raise StepFailed(f"topology did not settle: {history}")


def _check_cycle(layout: Layout, starts: set[bytes], history: list[Event]) -> None:
    """Fail the step at once when a Newton solve would restart from a layout (edges and
    singular flags) already tried in this step: the solve and the events after it are
    deterministic, so the topology would only cycle until MAX_TOPOLOGY_CHANGES (e.g. pin at a
    ridge, negative pressure, release, Newton fails, pin at the same ridge again)."""
    key = layout.edges.tobytes() + layout.pinned.tobytes()
    if key in starts:
        raise StepFailed(f"topology cycles: {history}")
    starts.add(key)


def _recentre(st: State) -> State:
    e = st.layout.edges
    xc = float(0.5 * (e[0] + e[-1]))
    ell = max(float(e[-1] - e[0]), 1e-300)
    beta = _shift_poly(st.beta, xc - st.xc)
    return State(st.layout, beta, st.theta, st.P, xc, ell, st.jac, jac_notches=st.jac_notches)


def _shift_poly(beta: np.ndarray, d: float) -> np.ndarray:
    """Coefficients of T in the coordinate shifted by d: T(x) = sum b_k (x - xc_old)^k."""
    if beta.size <= 1 or d == 0.0:
        return beta.copy()
    p = np.polynomial.Polynomial(beta)
    return np.polynomial.Polynomial(p(np.polynomial.Polynomial([d, 1.0])).coef).coef[: beta.size]


# on a failed step, try merging two zones whose gap is below this fraction of their widths
MERGE_GAP = 0.5


def _try_merge(st: State, P_next: float, profile: Profile, A: float):
    """Merge the narrowest gap if it is closing and the step beyond it fails."""
    e = st.layout.edges
    if st.layout.n < 2:
        return None
    gaps = e[2::2] - e[1:-1:2]
    widths = np.minimum(e[1:-1:2] - e[0:-2:2], e[3::2] - e[2::2])
    m = int(np.argmin(gaps / widths))
    if gaps[m] > MERGE_GAP * widths[m]:
        return None
    keep = np.ones(e.size, bool)
    keep[[2 * m + 1, 2 * m + 2]] = False
    layout = Layout(e[keep], st.layout.pinned[keep])
    trial = fresh_state(layout, st.theta, P_next)
    trial.beta = beta_for(trial, A, P_next)
    try:
        return converge(trial, profile, A, None)
    except StepFailed:
        return None
