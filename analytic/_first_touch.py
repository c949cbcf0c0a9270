"""The first state of a continuation in the load: tiny zones at the first touch.

Where ``h0 - theta x`` is lowest (its lowest local minima: points, flat faces, corners) the
bodies touch first.  A zone a small fraction of the local feature size is started there and
solved with one free edge held (the load is then an output, like displacement control); the
zone is made smaller until its load is below the target, from where the continuation of
:mod:`analytic._continuation` takes over.
"""

from __future__ import annotations

import numpy as np

from analytic._guess import centred
from analytic._newton import Mode, NewtonFailed, State, beta_for, fresh_state, newton
from analytic._sie import Layout, System
from analytic.errors import ConvergenceError, InputError, TableEndError
from analytic.profiles import Profile

START_FRACTION = 2e-3       # first-touch zone size relative to the local feature size
FIRST_TOUCH_TRIES = 12      # ... divided by 10 per try while its load exceeds the target


FIRST_LOAD_FRACTION = 1e-3  # first-touch load of a zone pinned at both ends (x target):
                            # the continuation then meets the next zones at small overlap


def initial_state(profile: Profile, A: float, theta: float, P_target: float) -> State:
    touches = _touch_set(profile, theta)
    frac = START_FRACTION
    for _ in range(FIRST_TOUCH_TRIES):
        edges, pinned = [], []
        for lo, hi, _v in touches:
            size = frac * _feature_size(profile, 0.5 * (lo + hi), touches)
            e2, p2 = _start_zone(profile, lo, hi, size, theta)
            edges += e2
            pinned += p2
        layout = Layout(np.asarray(edges, float), np.asarray(pinned, bool))
        st = _first_solve(layout, profile, A, theta, P_target)
        if st.P <= P_target:
            return st
        frac *= 0.1
    raise ConvergenceError("could not find a first-touch state below the requested load",
                           {"P_target": P_target})


def _first_solve(layout: Layout, profile: Profile, A: float, theta: float, P_target: float
                 ) -> State:
    """The first-touch solve of :func:`_solve_driver`; when it fails, again from the zones
    shifted to their own consistency (:func:`analytic._guess.centred`: a wedge's zone started
    symmetric about its apex beside a cylinder's, issue 29)."""
    try:
        return _solve_driver(fresh_state(layout, theta, P_target), profile, A, P_target)
    except ConvergenceError:
        moved = centred(layout, profile, theta)
        if np.array_equal(moved.edges, layout.edges):
            raise
    return _solve_driver(fresh_state(moved, theta, P_target), profile, A, P_target)


def _touch_set(profile: Profile, theta: float) -> list[tuple[float, float, float]]:
    """The lowest local minima of ``h0 - theta x`` (within a rounding tolerance; a level run is
    one interval, ``Profile.local_minima``).  A table end at that level
    (:attr:`Profile.open_ends`) is refused: the contact would leave the table."""
    mins = profile.local_minima(theta)
    ends = [(q, float(profile.h0(np.array([q]))[0] - theta * q)) for q in profile.open_ends]
    if not mins and not ends:
        raise InputError(f"the profile {profile.name} never touches: h0(x) - theta x has no minimum"
                         f" (theta={theta!r})")
    low = min([m[2] for m in mins] + [v for _, v in ends])
    tol = 1e-12 * (profile.scale + abs(low))
    at_end = [q for q, v in ends if v <= low + tol]
    if at_end:
        raise TableEndError(_table_end_message(profile, theta, at_end, bool(mins)))
    return [m for m in mins if m[2] <= low + tol]


def _table_end_message(profile: Profile, theta: float, at_end: list[float], interior: bool
                       ) -> str:
    ends = ", ".join(f"x={q!r}" for q in at_end)
    what = "lowest set of h0(x) - theta x reaches" if interior else \
        "minimum of h0(x) - theta x is at"
    return (f"profile={profile.name} is not allowed: the {what} the end of its table at {ends} "
            f"(theta={theta!r}); h0 is unknown beyond, so the contact would leave the table: "
            "need a longer table (extend it so that its lowest points lie inside and h0 rises "
            "towards both ends)")


def _start_zone(profile: Profile, lo: float, hi: float, size: float, theta: float = 0.0
                ) -> tuple[list, list]:
    """Tiny zone around a first-touch point / flat face: edges and singular flags."""
    corners = profile.pin_points
    at_lo, at_hi = lo in corners, hi in corners
    if lo == hi:
        if at_lo:
            # a corner touches first: pinned corner, free edge inwards, on the lower side (beside
            # a punch in a union, h0 is finite but higher beyond the corner: the zone was started
            # there and the first-touch load came out negative)
            x = np.array([lo - size, lo + size])
            h = profile.h0(x) - theta * x
            inward = 1.0 if h[1] < h[0] else -1.0
            pair = sorted([lo, lo + inward * size])
            return pair, [pair[0] == lo, pair[1] == lo]
        return [lo - size, hi + size], [False, False]
    a = lo if at_lo else lo - size
    b = hi if at_hi else hi + size
    return [a, b], [at_lo, at_hi]


def _feature_size(profile: Profile, x: float, touches: list) -> float:
    marks = [m[0] for m in touches] + [m[1] for m in touches] + list(profile.kinks)
    marks += list(profile.pin_points)
    d = [abs(x - q) for q in marks if abs(x - q) > 1e-12 * profile.scale]
    return min([profile.scale, *d])


def _solve_driver(st: State, profile: Profile, A: float, P_target: float) -> State:
    """First state: one free edge held, the load is an output (displacement-like control)."""
    lay = st.layout
    free = np.flatnonzero(~lay.pinned)
    if free.size == 0:  # every edge at a corner: the load is free, start low
        st.P = FIRST_LOAD_FRACTION * P_target
        st.beta = beta_for(st, A, st.P)
        st, _ = newton(st, Mode(st.P, None), profile, A)
        return st
    mode = Mode(None, None, driver=int(free[-1]))
    if lay.e < lay.n:
        st.beta[-1] = -A * P_target * 1e-6
    try:
        st, _ = newton(st, mode, profile, A)
    except NewtonFailed as exc:
        raise ConvergenceError(f"first-touch solve failed: {exc}", exc.diag) from exc
    sys_ = System.build(st.layout, profile, A, st.theta, st.xc, st.beta)
    st.P = sys_.load_and_moment()[0]
    if not st.P > 0:
        raise ConvergenceError("first-touch state has a non-positive load", {"P": st.P})
    return st
