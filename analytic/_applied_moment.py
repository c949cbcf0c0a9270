"""Applied-moment mode: the rigid rotation theta is found so that ``int x p dx = M``.

The fixed-rotation problem is the vertical-indentation problem of the tilted profile
``h0(x) - theta x``; its moment grows monotonically with theta.  We first try Newton on all
unknowns (edges and theta, with the topology events) from the fixed-rotation solution at the
initial rotation (or from cheaper starts beside it, :func:`_search_starts`); where that fails
we bracket theta with fixed-rotation solves, refine it with
Brent's method, then polish all unknowns together with Newton so that the moment equation
holds to the solver tolerance.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from analytic._continuation import (
    MAX_TOPOLOGY_CHANGES,
    StepFailed,
    converge,
    solve_from_first_touch,
    solve_from_guess,
)
from analytic._newton import State, beta_for, fresh_state
from analytic._roots import brentq
from analytic._sie import Layout, System
from analytic.errors import ConvergenceError, InputError, TableEndError
from analytic.profiles import Profile

THETA_XTOL = 1e-13
THETA_COARSE = 1e-8  # the bracket's first root (relative to the rotation scale): from there the
                     # polish (edges and theta by Newton) converges; THETA_XTOL only if it fails
MOMENT_SETTLED = 1e-13  # |M(theta0) - M| / (P * span) at rounding level: no search (M = 0 on
                        # a symmetric profile; its secant steps went to theta ~ 1e-11 and failed)


def check_tipping(profile: Profile, P: float, M: float) -> float:
    """The load centre ``x = M/P`` must lie inside the profile's support, else the body tips."""
    xe = M / P
    lo, hi = profile.support
    if not lo < xe < hi:
        raise InputError(f"M={M!r} tips the body off: the load centre M/P={xe:.6g} must lie "
                         f"inside the profile's support ({lo:.6g}, {hi:.6g})")
    return xe


class _Rotations:
    """Fixed-rotation solves at one load, remembered per rotation; a new rotation starts Newton
    from the solved state of the nearest one (the continuation from the first touch only if that
    fails): the moment search visits ~10 rotations close together, and each full solve took
    0.3-0.9 s on a sharp punch beside a cylinder (16 s in all, issue 29).

    A warm start that failed from a rotation is not tried from there in that direction again
    (the nearest rotation on the other side is, then the full solve): across a change of
    topology (the load passing from one cylinder of a union to another) Brent's steps fall
    between the bracket's ends, and every warm start from the far side's topology failed
    (0.1-0.5 s each, 1.6 s of the 3.3 s of audit seed 100836).  Where the solved rotations
    either side differ in topology, Newton from the overlap guess comes first (it needs no
    topology; 0.012 s against 0.1-0.2 s per failed warm start on audit seed 101038)."""

    def __init__(self, profile: Profile, P: float, A: float) -> None:
        self.profile, self.P, self.A = profile, P, A
        self.solved: dict[float, tuple[State, System, float]] = {}
        self.failed: list[tuple[float, float]] = []  # (from, to) of failed warm starts
        self.joined: set[tuple] = set()  # topologies the joint Newton started from
        self.no_guess: set[float] = set()  # rotations where Newton from the guess failed
        self.table_ends: dict[float, TableEndError] = {}  # rotations whose contact left the table
        self.no_full: set[float] = set()  # rotations where the solve from the first touch failed

    def at(self, theta: float, full: bool = True) -> tuple[State, System, float] | None:
        """``(state, system, moment)`` at ``theta``, or None where the solve fails or the body
        tips (h0 - theta x flat or falling out to infinity).  Without ``full`` only the cheap
        starts are tried (the warm start and the overlap guess), not the continuation from the
        first touch."""
        theta = float(theta)
        if theta in self.solved:
            return self.solved[theta]
        if not self.profile.admits_tilt(theta):
            return None
        solvers = [lambda: self._warm(theta), lambda: self._guess(theta)]
        if self._straddles(theta):
            solvers.reverse()
        try:
            found = next((r for r in (f() for f in solvers) if r is not None), None)
            if found is None and (not full or theta in self.no_full):
                return None  # the full solve depends on the rotation alone: it failed before
            st, sys_ = found or self._full(theta)
        except (TableEndError, ConvergenceError):  # remembered by _full when it failed there
            return None
        out = (st, sys_, sys_.load_and_moment()[1])
        self.solved[theta] = out
        return out

    def _full(self, theta: float) -> tuple[State, System]:
        """The continuation from the first touch at ``theta``; its failure is remembered
        (``no_full``; a contact that left the table also in ``table_ends``)."""
        try:
            return solve_from_first_touch(self.profile, self.P, self.A, theta)
        except TableEndError as exc:  # this rotation runs the contact off the table
            self.table_ends[theta] = exc
            self.no_full.add(theta)
            raise
        except ConvergenceError:
            self.no_full.add(theta)
            raise

    def warm(self, theta: float) -> tuple[State, System, float] | None:
        """:meth:`at` by the warm start only (Newton from the nearest solved rotations)."""
        theta = float(theta)
        if theta not in self.solved and self.profile.admits_tilt(theta):
            found = self._warm(theta)
            if found is not None:
                self.solved[theta] = (*found, found[1].load_and_moment()[1])
        return self.solved.get(theta)

    def _guess(self, theta: float) -> tuple[State, System] | None:
        """Newton from the overlap guess at ``theta`` (:func:`solve_from_guess`), tried once
        per rotation (it depends on nothing else)."""
        if theta in self.no_guess:
            return None
        found = solve_from_guess(self.profile, self.P, self.A, theta)
        if found is None:
            self.no_guess.add(theta)
        return found

    def _warm(self, theta: float) -> tuple[State, System] | None:
        for t in self._starts(theta):
            near = self.solved[t][0]
            start = State(near.layout, near.beta.copy(), theta, self.P, near.xc, near.ell)
            try:
                return converge(start, self.profile, self.A, None)
            except StepFailed:
                self.failed.append((t, theta))
        return None

    def _neighbours(self, theta: float) -> list[float]:
        """The nearest solved rotation below and above ``theta`` (where there is one)."""
        below = [t for t in self.solved if t < theta]
        above = [t for t in self.solved if t > theta]
        return ([max(below)] if below else []) + ([min(above)] if above else [])

    def _starts(self, theta: float) -> list[float]:
        """The :meth:`_neighbours`, nearest first, without those a warm start already failed
        from in the direction of ``theta``."""
        ends = [t for t in self._neighbours(theta)
                if not any(f == t and (to - t) * (theta - t) > 0 for f, to in self.failed)]
        return sorted(ends, key=lambda t: abs(t - theta))

    def _straddles(self, theta: float) -> bool:
        """Whether the solved rotations either side of ``theta`` differ in topology."""
        ends = self._neighbours(theta)
        return len(ends) == 2 and not _same_topology(*(self.solved[t][0] for t in ends))

    def moment(self, theta: float) -> float:
        r = self.at(theta)
        if r is None:
            raise ConvergenceError("fixed-rotation solve failed inside the rotation bracket",
                                   {"theta": theta})
        return r[2]

    def topology(self, theta: float) -> tuple:
        """The solved state's singular flags and the profile piece under each zone."""
        lay = self.solved[theta][0].layout
        mids = lay.edges.reshape(-1, 2).mean(axis=1)
        return lay.pinned.tobytes(), tuple(self.profile.piece_index(mids).tolist())


class _Found(Exception):  # noqa: N818 (a result, not an error)
    """The joint Newton solved the moment problem during the search (carries the result)."""

    def __init__(self, result: tuple[State, System]) -> None:
        super().__init__()
        self.result = result


def _same_topology(a: State, b: State) -> bool:
    """Same zones (count, singular edges, each zone overlapping its counterpart)."""
    la, lb = a.layout, b.layout
    if la.n != lb.n or la.pinned.tobytes() != lb.pinned.tobytes():
        return False
    za, zb = la.edges.reshape(-1, 2), lb.edges.reshape(-1, 2)
    return bool(np.all((za[:, 0] < zb[:, 1]) & (zb[:, 0] < za[:, 1])))


def _bracket(rot: _Rotations, M: float, theta0: float, step: float):
    P = rot.P
    first = rot.at(theta0)
    if first is None:
        raise rot.table_ends.get(theta0) or ConvergenceError(
            "fixed-rotation solve failed at the initial rotation", {"theta": theta0})
    f0 = first[2] - M
    if abs(f0) <= MOMENT_SETTLED * P * first[0].ell:  # theta0 carries M already (symmetry)
        return (theta0, theta0), first
    direction = -np.sign(f0) if f0 != 0 else 1.0
    lo_t, lo_f = theta0, f0
    for _ in range(60):
        t = lo_t + direction * step
        trial = rot.at(t)
        if trial is None:
            step *= 0.5
            continue
        _joint_at(rot, t, M)
        f = trial[2] - M
        if np.sign(f) != np.sign(lo_f):
            return (lo_t, t) if lo_t < t else (t, lo_t), trial
        lo_t, lo_f = t, f
        step *= 2.0
    raise InputError(f"M={M!r} cannot be carried: no rotation gives that moment "
                     "(the body tips off its contact)")


def solve_with_moment(profile: Profile, P: float, A: float, M: float) -> tuple[State, System]:
    xe = check_tipping(profile, P, M)
    alone = _face_alone(profile, P, A, M, xe) or _from_level_face(profile, P, A, M, xe)
    if alone is not None:
        return alone
    theta0 = _initial_rotation(profile, xe)
    scale = abs(theta0) + A * P / profile.scale + 1e-12
    rot = _Rotations(profile, P, A)
    start, probes = theta0, None
    for start, changes in _search_starts(rot, M, theta0, 0.25 * scale):
        probes = _probe_bracket(rot, M, theta0, 0.25 * scale) if start == theta0 else None
        if probes is not None:
            break
        direct = _newton_from(rot, start, M, changes)
        if direct is not None:
            return direct
    try:
        (t_lo, t_hi) = probes or _bracket(rot, M, start, 0.25 * scale)[0]
        theta = _root(rot, M, t_lo, t_hi, THETA_COARSE * scale)
    except _Found as found:
        return found.result
    failed: StepFailed | None = None
    for xtol in (None, THETA_XTOL * max(scale, 1.0)):
        theta = theta if xtol is None else _root(rot, M, t_lo, t_hi, xtol, joint=False)
        st, sys_, _ = rot.at(theta) or _failed_at(theta)
        try:
            return converge(st, profile, A, M)
        except StepFailed as exc:
            failed = exc
    if abs(sys_.load_and_moment()[1] - M) <= 1e-10 * P * st.ell:
        return st, sys_
    raise ConvergenceError(f"moment polish failed: {failed}", {"theta": theta}) from failed


def _search_starts(rot: _Rotations, M: float, theta0: float, step: float
                   ) -> Iterator[tuple[float, int]]:
    """The rotations the joint Newton starts from in turn, with its number of Newton solves
    (:func:`_newton_from`); the last one is the bracket's start.  Just ``theta0`` where the
    overlap guess solves there.  Else, where the guess solves at one of the bracket's first
    steps ``t = theta0 -+ step`` and the moment there asks for a rotation towards ``theta0``:
    ``t`` (one Newton solve, no topology event), then the midpoint between ``t`` and
    ``theta0`` if the warm start from ``t`` solves it, else ``theta0``.  The full solve at
    ``theta0`` is the continuation from the first touch, which can cross the births of zones
    beside ridges: audit seed 103644 at theta = 0 (a rounded punch beside two cylinders) took
    6 s of the search's 11.6 s, and the joint Newton from it failed (2 s); the guess solves at
    -0.196 (0.02 s), the warm start at -0.098 (0.3 s) and the joint Newton from there converges
    to -0.04458 (0.6 s).  On audit seed 102166 the joint Newton from ``t`` converges (1.8 ->
    0.4 s).  A warm start at the midpoint that fails costs up to 0.5 s (audit seed 104766:
    0.96 -> 1.41 s); with the topology events the joint Newton from ``t`` failed after 0.8 s
    there, and the guess and the continuation at the midpoint took 2.7 s."""
    if rot.at(theta0, full=False) is None:
        for t in (theta0 - step, theta0 + step):
            probe = rot.at(t, full=False)
            if probe is not None and (probe[2] - M) * (t - theta0) > 0:
                yield t, 1
                mid = 0.5 * (t + theta0)
                if rot.warm(mid) is not None:
                    yield mid, MAX_TOPOLOGY_CHANGES
                    return
                break
    yield theta0, MAX_TOPOLOGY_CHANGES


def _probe_bracket(rot: _Rotations, M: float, theta0: float, step: float
                   ) -> tuple[float, float] | None:
    """``(theta0 - step, theta0 + step)`` where the cheap starts (warm, overlap guess) fail at
    ``theta0`` but solve at both, with moments either side of M: a bracket without the full
    solve at ``theta0`` (the continuation from the first touch, which can cross the births of
    zones: audit seed 112425, a rounded punch beside two cylinders, took 2.6 s there of the
    search's 4.4 s, and the joint Newton from it failed); else None."""
    if rot.at(theta0, full=False) is not None:
        return None
    ends = (theta0 - step, theta0 + step)
    found = [rot.at(t, full=False) for t in ends]
    if any(f is None for f in found) or (found[0][2] - M) * (found[1][2] - M) >= 0:
        return None
    return ends


def _joint_at(rot: _Rotations, theta: float, M: float) -> None:
    """Raise :class:`_Found` if the joint Newton from the state solved at ``theta`` (a topology
    it has not started from yet) solves the moment problem.  Where M(theta) is a step (two
    small zones far apart, the load passing from one to the other) Brent took ~16
    fixed-rotation solves to resolve the step; the first state with both zones converges
    (audit seed 101125).  One Newton solve, no change of topology: a joint Newton through
    topology events from a state with four zones failed after 0.36 s (audit seed 101401)."""
    if rot.topology(theta) not in rot.joined:
        found = _newton_from(rot, theta, M, changes=1)
        if found is not None:
            raise _Found(found)


def _newton_from(rot: _Rotations, theta0: float, M: float,
                 changes: int = MAX_TOPOLOGY_CHANGES) -> tuple[State, System] | None:
    """Newton on every unknown (edges, beta and theta, with the topology events) from the
    fixed-rotation solution at ``theta0``, or None if it fails or ends beyond the tilt limits.
    Where the topology holds between ``theta0`` and the solution this is the whole search:
    the bracket's first step, a quarter of the rotation scale, crossed changes of topology
    that Brent's steps then had to resolve one fixed-rotation solve at a time (a union of
    cylinders: 0.3-0.6 s, the median moment case of the audit's cylinders, issue 29)."""
    first = rot.at(theta0)
    if first is None:
        return None
    rot.joined.add(rot.topology(theta0))
    try:
        st, sys_ = converge(first[0], rot.profile, rot.A, M, changes)
    except StepFailed:
        return None
    return (st, sys_) if rot.profile.admits_tilt(st.theta) else None


def _root(rot: _Rotations, M: float, t_lo: float, t_hi: float, xtol: float,
          joint: bool = True) -> float:
    """The rotation in ``[t_lo, t_hi]`` whose fixed-rotation moment is M, to ``xtol``; with
    ``joint``, :func:`_joint_at` at every new topology on the way (may raise :class:`_Found`)."""
    if t_lo == t_hi:
        return t_lo

    def f(t: float) -> float:
        m = rot.moment(t)
        if joint:
            _joint_at(rot, t, M)
        return m - M

    try:
        return brentq(f, t_lo, t_hi, xtol=xtol, rtol=1e-14)
    except ValueError as exc:  # a re-solve at a bracket end gave M - M(theta) the other sign
        raise ConvergenceError(f"moment search lost its bracket: {exc}",
                               {"theta_bracket": (t_lo, t_hi)}) from exc


def _failed_at(theta: float):
    raise ConvergenceError("fixed-rotation solve failed at the rotation found", {"theta": theta})


def _initial_rotation(profile: Profile, xe: float) -> float:
    """The rotation that puts the minimum of ``h0 - theta x`` at the load centre ``xe``: the
    slope there where h0 is curved and the tilted profile's lowest point is then at ``xe``,
    else 0.  On a straight piece that slope would make the piece flat: out to
    infinity for a wedge's face (the tilt limit; the first-touch zone then grows without bound
    and exhausted the memory after ~50 s), or a flat facet beyond the tilt limits of a double
    wedge whose inner faces are steeper than the outer ones (no solution).  On the flank of a
    union member beside the loaded one (a load centre between a punch and a cylinder) the slope
    there tilts another member down to first touch: the search started at theta = -2.55 for a
    solution at 1.6e-4 and took 16 s (issue 29).  The same on a tabulated spline of two
    cylinders (theta = -0.166 for a solution at 0.0022; the search took 0.8 s, now 0.2 s)."""
    x = np.array([xe])
    slope, curvature = float(profile.dh0(x)[0]), float(profile.d2h0(x)[0])
    if not (np.isfinite(slope) and curvature != 0.0 and profile.admits_tilt(slope)):
        return 0.0
    mins = profile.local_minima(slope)
    lowest = min(mins, key=lambda m: m[2]) if mins else None
    if lowest is None or abs(0.5 * (lowest[0] + lowest[1]) - xe) > 1e-6 * profile.scale:
        return 0.0
    return slope


def _face_alone(profile: Profile, P: float, A: float, M: float, xe: float
                ) -> tuple[State, System] | None:
    """The solution with the whole load on the sharp flat face under the load centre ``xe``
    (both edges at its corners), by the joint Newton from :func:`_face_rotation` with no change
    of topology; None where there is no such face or that state is not admissible (another
    zone, a lifted corner), and the search then runs as without it. Without it the search
    started at theta = 0 and solved the untilted union first: at P = 0.40 a cylinder beside
    the punch spread over two ridges (4.4 s of topology events) for a solution on the punch
    alone at theta = 0.208 (audit seed 102077: 7.6 s, now 0.2 s). Starting the search itself
    at the face rotation was slower where another zone shares the load (0.06 -> 0.7 s)."""
    theta = _face_rotation(profile, P, A, xe)
    if theta is None:
        return None
    pc = profile.pieces[int(profile.piece_index(np.array([xe]))[0])]
    st = fresh_state(Layout(np.array([pc.lo, pc.hi]), np.array([True, True])), theta, P)
    st.beta = beta_for(st, A, P)
    try:
        st, sys_ = converge(st, profile, A, M, 1)
    except StepFailed:
        return None
    return (st, sys_) if profile.admits_tilt(st.theta) else None


def _from_level_face(profile: Profile, P: float, A: float, M: float, xe: float
                     ) -> tuple[State, System] | None:
    """Where ``xe`` lies on a flat face whose ends are no pin points (a rounded punch), the
    joint Newton (edges, beta, theta, with the topology events) from the overlap guess at the
    face-alone rotation theta = 2 A P (xe - c) / (pi a^2) (:func:`_face_rotation`'s formula on
    the face's flat part); None if the guess or the Newton fails or the state is not
    admissible, and the search then runs as without it.  The search starts at theta = 0 there
    (h0 has no curvature at ``xe``), where the face is level: it touches along its whole length
    at once, and the continuation cycled through pins at the corners' vertical ends (audit seed
    105672: 3.2 s, now 0.4 s; seed 104494: 3.1 s, now 0.2 s).  Only the guess is tried: on the
    wrong side of the solution (cylinders beside the punch taking the moment) the full solve at
    that rotation took minutes (audit seed 103644, theta_face = +0.085 for -0.045)."""
    pc = _flat_face(profile, xe)
    pins = profile.pin_points
    if pc is None or (pc.lo in pins and pc.hi in pins):
        return None
    theta = _face_theta(pc, P, A, xe)
    if not profile.admits_tilt(theta):
        return None
    guess = solve_from_guess(profile, P, A, theta)
    if guess is None:
        return None
    try:
        st, sys_ = converge(guess[0], profile, A, M)
    except StepFailed:
        return None
    return (st, sys_) if profile.admits_tilt(st.theta) else None


def _face_rotation(profile: Profile, P: float, A: float, xe: float) -> float | None:
    """The rotation of a sharp flat face (both ends pin points) that carries the whole load
    about the load centre ``xe`` on it: p = P / (pi sqrt(a^2 - s^2)) + 2 theta s / (A pi
    sqrt(a^2 - s^2)) gives M - P c = pi a^2 theta / (2 A) (face centre c, half-width a). None
    where ``xe`` is not on such a face, the tilt is beyond the tilt limits, or the tilted
    profile is lowest elsewhere (another member touches first)."""
    pc = _flat_face(profile, xe)
    pins = profile.pin_points
    if pc is None or not (pc.lo in pins and pc.hi in pins and pc.lo < xe < pc.hi):
        return None
    theta = _face_theta(pc, P, A, xe)
    if not profile.admits_tilt(theta):
        return None
    mins = profile.local_minima(theta)
    lowest = min(mins, key=lambda m: m[2]) if mins else None
    if lowest is None or not pc.lo <= 0.5 * (lowest[0] + lowest[1]) <= pc.hi:
        return None
    return theta


def _flat_face(profile: Profile, xe: float):
    """The flat profile piece of finite extent holding ``xe``, or None."""
    k = int(profile.piece_index(np.array([xe]))[0])
    if k < 0:
        return None
    pc = profile.pieces[k]
    return pc if pc.flat and np.isfinite(pc.lo) and np.isfinite(pc.hi) else None


def _face_theta(pc, P: float, A: float, xe: float) -> float:
    """The rotation of the face ``pc`` carrying the whole load about ``xe``: M - P c = pi a^2
    theta / (2 A) (centre c, half-width a; :func:`_face_rotation`)."""
    c, a = 0.5 * (pc.lo + pc.hi), 0.5 * (pc.hi - pc.lo)
    return 2.0 * A * P * (xe - c) / (np.pi * a * a)
