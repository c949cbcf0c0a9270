"""Stage-1 (normal) problem for any number of contact zones: paper Sections 2-4.

Public entry points: :func:`solve_normal`, :func:`load_curve` and the result
:class:`NormalSolution`.  The equations (consistency Eq. 12/14, rigid interconnection Eq. 17,
equilibrium, moment) are assembled in :mod:`analytic._sie`; this module solves them by Newton's
method with continuation in the load from the first touch, and keeps the contact topology
admissible (zones appear, merge, split; singular edges pin at corners or release).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq

from analytic import _validate as check
from analytic._guess import overlap_guess
from analytic._sie import Batch, Layout, System
from analytic._vectorise import elementwise
from analytic.errors import ConvergenceError, InputError
from analytic.profiles import Profile

NEWTON_TOL = 1e-13          # scaled residual; edges then agree to ~1e-12 relative
NEWTON_MAXIT = 40
STEP_TOL = 1e-12            # ... and the next Newton step moves no unknown (edges / span) more
POLISH_STEPS = 3            # steps allowed beyond NEWTON_TOL to meet STEP_TOL
FLOOR_TOL = 1e-10          # accepted when rounding stalls Newton (zones ~1e-6 of the span)
ULP_FLOOR = 64.0            # ... or below the residual change of this many ulps of the edges
REFRESH_RATIO = 0.1         # a reused Jacobian gaining less than this per step is refreshed
FD_STEP = 1e-7              # relative finite-difference step for the Jacobian
FD_ULPS = 64.0              # ... and the smallest step of an edge in units in the last place
ADMISSIBLE_TOL = 1e-9       # relative tolerance of the p >= 0 and g >= 0 checks
MAX_TOPOLOGY_CHANGES = 12
START_FRACTION = 2e-3       # first-touch zone size relative to the local feature size
FIRST_TOUCH_TRIES = 12      # ... divided by 10 per try while its load exceeds the target
FIRST_LOAD_FRACTION = 1e-3  # first-touch load of a zone pinned at both ends (x target):
                            # the continuation then meets the next zones at small overlap


# ---------------------------------------------------------------------------------------------
# result
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class NormalSolution:
    """Solution of the normal problem (paper Table 1, stage 1; p >= 0 compressive).

    Attributes
    ----------
    zones : list of ``(a, b)`` contact zones, ordered by x.
    singular : list of ``(left, right)`` flags per zone: True where the edge is singular (a
        sharp corner; pressure ~ 1/sqrt), False where nonsingular (pressure -> 0).
    zone_loads : load carried by each zone (force per unit width).
    P, M : total load and moment ``M = int x p dx`` about x = 0.
    theta : rigid rotation of body 1 (``h = h0 - theta x``); 0 in vertical indentation.
    mode : ``"vertical"`` (rotation locked, M output) or ``"moment"`` (M given, theta output).
    A : composite compliance ``4 (1 - nu^2)/E``.
    residuals : the scaled residuals of the equations solved and the self-checks (equilibrium
        from the integrated pressure, min pressure, min gap).
    """

    zones: list[tuple[float, float]]
    singular: list[tuple[bool, bool]]
    zone_loads: list[float]
    P: float
    M: float
    theta: float
    mode: str
    A: float
    residuals: dict[str, float]
    profile: Profile = field(repr=False)
    _system: System = field(repr=False, compare=False)

    @property
    def n_zones(self) -> int:
        return len(self.zones)

    @property
    def extent(self) -> float:
        """Sum of the zone widths."""
        return float(sum(b - a for a, b in self.zones))

    @elementwise
    def pressure(self, x: np.ndarray | float) -> np.ndarray:
        """Contact pressure ``p(x) >= 0`` (vectorised; 0 outside the zones)."""
        out = np.zeros(x.shape)
        inside = _inside(x, self._system.layout.edges)
        if np.any(inside):
            out[inside] = self._system.pressure_inside(x[inside])
        return out

    @elementwise
    def gap(self, x: np.ndarray | float) -> np.ndarray:
        """Deformed gap ``g(x) >= 0`` (0 in the zones; ``+inf`` where the profile is undefined)."""
        return deformed_gap(self._system, x)


def _inside(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    z = edges.reshape(-1, 2)
    return np.any((x[:, None] > z[:, 0]) & (x[:, None] < z[:, 1]), axis=1)


# ---------------------------------------------------------------------------------------------
# deformed gap outside the zones
# ---------------------------------------------------------------------------------------------
def deformed_gap(sys_: System, x: np.ndarray) -> np.ndarray:
    """``g(x) = h(x) - h(edge) + int_edge^x w'`` from the nearest edge on the same side."""
    edges = sys_.layout.edges
    out = np.zeros(x.shape)
    inside = _inside(x, edges) | np.isin(x, edges)
    h = sys_.profile.h0(x) - sys_.theta * x
    nearest = _nearest_outer_edge(x, edges)
    out[~inside & ~np.isfinite(h)] = np.inf
    todo = ~inside & np.isfinite(h)
    if np.any(todo):
        i = nearest[todo]
        out[todo] = sys_.gaps_from_edges(i, x[todo], h[todo])
    return out


def _nearest_outer_edge(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Index of the edge bounding the gap (or outer region) that holds each x, nearest side."""
    k = np.searchsorted(edges, x)  # x in (edges[k-1], edges[k])
    idx = np.where(k == 0, 0, np.where(k >= edges.size, edges.size - 1, k))
    gap = (k > 0) & (k < edges.size) & (k % 2 == 0)  # between b_{m} (k-1) and a_{m+1} (k)
    left_nearer = gap & (np.abs(x - edges[np.maximum(k - 1, 0)])
                         <= np.abs(edges[np.minimum(k, edges.size - 1)] - x))
    return np.where(left_nearer, k - 1, idx)


# ---------------------------------------------------------------------------------------------
# unknowns and residuals
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Mode:
    """Which quantities are unknown: edges (free ones), beta, theta; driver = fixed free edge."""

    P: float | None           # None: P is an output (driver mode)
    M: float | None           # None: theta fixed
    driver: int | None = None


@dataclass
class _State:
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


def _free_edges(layout: Layout, mode: _Mode) -> np.ndarray:
    free = layout.free
    return free[free != mode.driver] if mode.driver is not None else free


def _n_beta_free(layout: Layout, mode: _Mode) -> int:
    nb = max(layout.n - layout.e, 0)
    return nb if mode.P is None else max(nb - 1, 0)


def _pack(st: _State, mode: _Mode) -> np.ndarray:
    free = _free_edges(st.layout, mode)
    z = [(st.layout.edges[free] - st.xc) / st.ell, st.beta[: _n_beta_free(st.layout, mode)]]
    if mode.M is not None:
        z.append(np.array([st.theta]))
    return np.concatenate(z)


def _unpack(z: np.ndarray, st: _State, mode: _Mode, A: float) -> _State:
    free = _free_edges(st.layout, mode)
    edges = st.layout.edges.copy()
    edges[free] = st.xc + st.ell * z[: free.size]
    nbf = _n_beta_free(st.layout, mode)
    beta = st.beta.copy()
    beta[:nbf] = z[free.size: free.size + nbf]
    nb = max(st.layout.n - st.layout.e, 0)
    if mode.P is not None and nb > 0:
        beta[nb - 1] = -A * mode.P
    theta = float(z[-1]) if mode.M is not None else st.theta
    return _State(st.layout.with_edges(edges), beta, theta, st.P, st.xc, st.ell, st.jac)


def _residual(st: _State, mode: _Mode, profile: Profile, A: float) -> tuple[np.ndarray, System]:
    sys_ = System.build(st.layout, profile, A, st.theta, st.xc, st.beta)
    return _rows(sys_.batch, st, mode)[0], sys_


def _rows(batch: Batch, st: _State, mode: _Mode) -> np.ndarray:
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


def _feasible(st: _State, profile: Profile) -> bool:
    """Edges finite, strictly increasing, inside the support, free edges where h0 is finite,
    and no zone spanning a ridge (scalar checks: this runs at every trial point)."""
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
    return not any(a < q < b for q in profile.ridges for a, b in zip(e[::2], e[1::2], strict=True))


class _NewtonFailed(Exception):
    def __init__(self, msg: str, diag: dict) -> None:
        super().__init__(msg)
        self.diag = diag


def _newton(st: _State, mode: _Mode, profile: Profile, A: float) -> tuple[_State, np.ndarray]:
    """Damped Newton; a Jacobian carried over from the previous continuation step is reused
    (chord iterations) until the contraction slows, then refreshed by finite differences."""
    z = _pack(st, mode)
    F, st.system = _residual(st, mode, profile, A)
    if z.size != F.size:
        raise AssertionError(f"unknowns {z.size} != equations {F.size}")
    if z.size == 0:
        return st, F
    norm = float(np.max(np.abs(F)))
    if not np.isfinite(norm):
        raise _NewtonFailed("non-finite residual at the start", {"residual": norm})
    J = st.jac if st.jac is not None and st.jac.shape == (F.size, z.size) else None
    fresh, polish, floor = False, 0, FLOOR_TOL
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
                raise _NewtonFailed("singular Jacobian",
                                    {"residual": norm, "iteration": it}) from exc
        trial, zt, Ft, nt = _line_search(st, z, dz, norm, mode, profile, A)
        if polish and not nt < NEWTON_TOL:
            break  # the polishing step would leave the converged set: keep the state
        if not polish and nt > REFRESH_RATIO * norm and not fresh:
            J = None  # stale Jacobian: refresh and retry from the same point
            continue
        if not polish and nt > 0.5 * norm and np.all(np.abs(F) < floor):
            break  # rounding floor reached with a fresh Jacobian: accept
        if nt >= norm and not np.all(np.abs(Ft) < floor):
            raise _NewtonFailed("no descent", {"residual": norm, "iteration": it})
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
            raise _NewtonFailed("too many iterations", {"residual": norm,
                                                        "iteration": NEWTON_MAXIT})
    st.jac = J
    return st, F


def _rounding_floor(J: np.ndarray, st: _State, mode: _Mode) -> np.ndarray:
    """Residual level of each equation below which Newton may stop: FLOOR_TOL, or the change of
    that residual when every free edge moves by ULP_FLOOR units in the last place of its
    absolute position, if larger.  Edges are stored as x, so an edge a distance d past a kink
    (a rounded corner's start at a small load, d ~ P^(2/3)) carries a relative load error
    ~ eps |x| / d."""
    free = _free_edges(st.layout, mode)
    ulp = np.zeros(J.shape[1])
    ulp[: free.size] = np.spacing(np.abs(st.layout.edges[free])) / st.ell
    floor = np.maximum(FLOOR_TOL, ULP_FLOOR * (np.abs(J) @ ulp))
    # not the interconnections: scaled by A P + |h'| span, not by the gaps' own size A P, they
    # would accept a wrong load split between narrow zones far apart (double wedge, P = 1e-8)
    lay = st.layout
    first = max(lay.e - lay.n, 0) + int(mode.P is not None and lay.e >= lay.n)
    floor[first: first + lay.n - 1] = FLOOR_TOL
    return floor


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


def _fd_steps(z: np.ndarray, st: _State, mode: _Mode, profile: Profile) -> np.ndarray:
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
    return h


def _jacobian(z, F, st, mode, profile, A) -> np.ndarray:
    """Forward differences, all columns in one batch evaluation with the discretisation frozen
    on the current layout (the base point is evaluated in the same batch)."""
    steps = _fd_steps(z, st, mode, profile)
    states = [st]
    for j in range(z.size):
        zp = z.copy()
        zp[j] += steps[j]
        trial = _unpack(zp, st, mode, A)
        if not _feasible(trial, profile):
            steps[j] = -steps[j]
            zp[j] = z[j] + steps[j]
            trial = _unpack(zp, st, mode, A)
        states.append(trial)
    batch = Batch.build(st.layout, profile, A, st.xc, np.array([q.layout.edges for q in states]),
                        np.array([q.theta for q in states]), np.array([q.beta for q in states]))
    R = _rows(batch, st, mode)
    return ((R[1:] - R[0]) / steps[:, None]).T


def _line_search(st, z, dz, norm, mode, profile, A):
    lam = 1.0
    for _ in range(30):
        zt = z + lam * dz
        trial = _unpack(zt, st, mode, A)
        if _feasible(trial, profile):
            Ft, trial.system = _residual(trial, mode, profile, A)
            nt = float(np.max(np.abs(Ft)))
            if np.isfinite(nt) and (nt < (1 - 1e-4 * lam) * norm or nt < NEWTON_TOL):
                return trial, zt, Ft, nt
        lam *= 0.5
    return st, z, _residual(st, mode, profile, A)[0], norm


# ---------------------------------------------------------------------------------------------
# first touch
# ---------------------------------------------------------------------------------------------
def _touch_set(profile: Profile, theta: float) -> list[tuple[float, float, float]]:
    mins = profile.local_minima(theta)
    if not mins:
        raise InputError(f"the profile {profile.name} never touches: h0(x) - theta x has no minimum"
                         f" (theta={theta!r})")
    low = min(m[2] for m in mins)
    tol = 1e-12 * (profile.scale + abs(low))
    return [m for m in mins if m[2] <= low + tol]


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


def _initial_state(profile: Profile, A: float, theta: float, P_target: float) -> _State:
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
        st = _fresh_state(layout, theta, P_target)
        st = _solve_driver(st, profile, A, P_target)
        if st.P <= P_target:
            return st
        frac *= 0.1
    raise ConvergenceError("could not find a first-touch state below the requested load",
                           {"P_target": P_target})


def _fresh_state(layout: Layout, theta: float, P: float) -> _State:
    e = layout.edges
    ell = max(float(e[-1] - e[0]), 1e-300)
    return _State(layout, np.zeros(max(layout.n - layout.e, 0)), theta, P,
                  float(0.5 * (e[0] + e[-1])), ell)


def _solve_driver(st: _State, profile: Profile, A: float, P_target: float) -> _State:
    """First state: one free edge held, the load is an output (displacement-like control)."""
    lay = st.layout
    free = np.flatnonzero(~lay.pinned)
    if free.size == 0:  # every edge at a corner: the load is free, start low
        st.P = FIRST_LOAD_FRACTION * P_target
        st.beta = _beta_for(st, A, st.P)
        st, _ = _newton(st, _Mode(st.P, None), profile, A)
        return st
    mode = _Mode(None, None, driver=int(free[-1]))
    if lay.e < lay.n:
        st.beta[-1] = -A * P_target * 1e-6
    try:
        st, _ = _newton(st, mode, profile, A)
    except _NewtonFailed as exc:
        raise ConvergenceError(f"first-touch solve failed: {exc}", exc.diag) from exc
    sys_ = System.build(st.layout, profile, A, st.theta, st.xc, st.beta)
    st.P = sys_.load_and_moment()[0]
    if not st.P > 0:
        raise ConvergenceError("first-touch state has a non-positive load", {"P": st.P})
    return st


def _beta_for(st: _State, A: float, P: float) -> np.ndarray:
    beta = st.beta.copy()
    if beta.size:
        beta[-1] = -A * P
    return beta


# ---------------------------------------------------------------------------------------------
# admissibility and topology updates
# ---------------------------------------------------------------------------------------------
_SCAN = np.linspace(0.0, 1.0, 401)        # profile scan for pressure dips inside a zone
_OUTER_RUN = np.geomspace(1e-4, 3.0, 24)  # gap-slope samples beyond the outer edges (x span)


@lru_cache(maxsize=8)
def _cheb_unit(n: int) -> np.ndarray:
    """Chebyshev points of the first kind mapped to (0, 1)."""
    return 0.5 * (1 - np.cos(np.pi * (np.arange(n) + 0.5) / n))


def _check_points_inside(edges: np.ndarray, n_pts: int = 49,
                         profile: Profile | None = None, theta: float = 0.0) -> np.ndarray:
    """Chebyshev points of every zone plus, when a profile is given, the local maxima of
    ``h0 - theta x`` inside the zones (where the pressure dips first when zones separate)."""
    z = edges.reshape(-1, 2)
    t = _cheb_unit(n_pts)
    pts = [(z[:, :1] + (z[:, 1:] - z[:, :1]) * t[None, :]).ravel()]
    if profile is not None:  # one scan of all zones at once, zone by zone in the output
        x = z[:, :1] + (z[:, 1:] - z[:, :1]) * _SCAN[None, 1:-1]
        h = profile.h0(x) - theta * x
        peak = (h[:, 1:-1] >= h[:, :-2]) & (h[:, 1:-1] >= h[:, 2:])
        pts.append(x[:, 1:-1][peak])
    return np.concatenate(pts)


def _gap_runs(st: _State, profile: Profile) -> tuple[list[np.ndarray], list[bool]]:
    """The runs of g' samples: across every gap (from its left edge) and beyond the right and
    the left outer edge, inside the support and where h0 is finite; per run whether it ends at
    the next zone's edge (an untruncated run across a gap)."""
    e = st.layout.edges
    span = max(e[-1] - e[0], profile.scale)
    d = span * _OUTER_RUN
    t = _cheb_unit(24)
    runs = [e[2 * m + 1] + (e[2 * m + 2] - e[2 * m + 1]) * t for m in range(st.layout.n - 1)]
    runs += [e[-1] + d, e[0] - d]
    starts = [*e[1:-1:2], e[-1], e[0]]
    runs = [_with_kink_sides(x, x0, profile) for x, x0 in zip(runs, starts, strict=True)]
    lo, hi = profile.support
    full = [x.size for x in runs]
    runs = [x[(x >= lo) & (x <= hi)] for x in runs]
    if profile.pieces_have_gaps:
        runs = [x[np.isfinite(profile.h0(x))] for x in runs]
    closed = [x.size == m for x, m in zip(runs[:-2], full, strict=False)] + [False, False]
    return runs, closed


KINK_SIDE = 1e-9  # the g' samples either side of a kink, relative to max(scale, |kink|)


def _with_kink_sides(x: np.ndarray, x0: float, profile: Profile) -> np.ndarray:
    """The run ``x`` (ordered away from its edge ``x0``) with a sample just before and just
    after every kink of h0 that it crosses.  g' jumps at a kink: at a ridge (the slope drops,
    e.g. where two members of a union meet) g rises into the kink and falls beyond it, so a
    minimum of g just before the ridge leaves no sign change of g' between the samples on either
    side of it (stress case: a new zone's overlap 4.8e-4 deep went unseen next to a ridge)."""
    lo, hi = sorted((x0, float(x[-1])))
    q = np.array([k for k in profile.kinks if lo < k < hi], float)
    if not q.size:
        return x
    dq = KINK_SIDE * np.maximum(profile.scale, np.abs(q))
    sides = np.concatenate([q - dq, q + dq])
    sides = sides[(sides > lo) & (sides < hi)]
    out = np.concatenate([x, sides])
    return out[np.argsort(np.abs(out - x0), kind="stable")]


def _gap_candidates(st: _State, profile: Profile, runs: list[np.ndarray], closed: list[bool],
                    gp: np.ndarray) -> np.ndarray:
    """Where the deformed gap can be smallest outside the zones, given ``g'`` on the
    concatenated :func:`_gap_runs`.

    ``g = 0`` at every edge and ``g' = W B/pi`` is cheap (no integral), so the minima of g are
    found from sign changes of ``g'`` on a grid in every gap and on geometric grids beyond the
    outer edges; the profile's own local minima, kinks and corners are added (new zones touch
    there).  Only these few points need the integral for g itself.
    """
    e = st.layout.edges
    ends = list(itertools.accumulate(x.size for x in runs))
    slopes = [gp[hi - x.size:hi] for x, hi in zip(runs, ends, strict=True)]
    slopes[-1] = -slopes[-1]  # the last run goes leftwards: the slope along it is -g'
    cands = [np.asarray([0.5 * (m[0] + m[1]) for m in profile.local_minima(st.theta)]
                        + list(profile.pin_points) + list(profile.kinks), float)]
    cands += [_slope_minima(x, s, end_at_edge)
              for x, s, end_at_edge in zip(runs, slopes, closed, strict=True) if x.size]
    x = np.concatenate(cands)
    lo, hi = profile.support
    x = x[(x >= lo) & (x <= hi)]
    return x[~_inside(x, e) & ~np.any(x[:, None] == e[None, :], axis=1)]


def _slope_minima(x: np.ndarray, gp: np.ndarray, end_at_edge: bool = False) -> np.ndarray:
    """Points of a run ``x`` (ordered away from its edge) where the slope of g along the run,
    ``gp``, turns from negative to positive, the first point if g already falls there, and the
    last point if g still falls there - unless the run ends at the next zone's edge
    (``end_at_edge``): g = 0 there, so g falling into it is positive before it."""
    out = [x[0]] if gp[0] < 0 else []
    for i in np.flatnonzero((gp[:-1] < 0) & (gp[1:] >= 0)):
        f = gp[i] / (gp[i] - gp[i + 1])
        out.append(x[i] + f * (x[i + 1] - x[i]))
    if gp[-1] < 0 and not end_at_edge:
        out.append(x[-1])
    return np.asarray(out, float)


REFINE_STEPS = 4     # Newton steps on g' from every gap candidate
REFINE_FD = 1e-6     # their finite-difference step for g'' (x scale, at most 1/4 of the clearance)


def _refined_minima(sys_: System, x: np.ndarray, profile: Profile) -> np.ndarray:
    """The candidates moved by Newton steps on ``g'`` (``g''`` by central differences, steps
    only where ``g'' > 0`` and at most half-way to the nearest edge), kept where they stay outside
    the zones on finite h0.  A candidate is a minimum of ``h0 - theta x`` or a linear
    interpolation of a sign change of ``g'`` on a coarse run; the minimum of g lies off it by
    ``u'/h''`` (the elastic slope from the zones), and just before a zone is born g there is still
    positive while the true minimum is not (g = -2.2e-7 = -1.4e-5 A P accepted on a union of
    cylinders).  The originals are kept, so a stray step only costs a sample."""
    e = sys_.layout.edges
    if not x.size:
        return x
    for _ in range(REFINE_STEPS):
        clear = np.min(np.abs(x[:, None] - e[None, :]), axis=1)
        d = np.minimum(REFINE_FD * profile.scale, 0.25 * clear)
        _, gp = sys_.pressure_and_slope(np.zeros(0), np.concatenate([x - d, x + d]))
        lo, hi = gp[:x.size], gp[x.size:]
        curv = (hi - lo) / (2 * d)
        step = np.where(curv > 0, -0.5 * (lo + hi) / np.where(curv > 0, curv, 1.0), 0.0)
        x = x + np.clip(step, -0.5 * clear, 0.5 * clear)
    lo_s, hi_s = profile.support
    keep = (x > lo_s) & (x < hi_s) & ~_inside(x, e) & np.isfinite(x)
    x = x[keep]
    return x[np.isfinite(profile.h0(x))]


@dataclass(frozen=True)
class _Event:
    kind: str       # "add", "merge", "grow", "split", "shrink", "release", "pin"
    where: float
    index: int = -1
    interval: tuple[float, float] | None = None


def _find_event(st: _State, sys_: System, profile: Profile, A: float) -> _Event | None:
    P_scale = st.P / max(st.layout.edges[1::2].sum() - st.layout.edges[0::2].sum(), 1e-300)
    xi = _check_points_inside(st.layout.edges, profile=profile, theta=st.theta)
    runs, closed = _gap_runs(st, profile)
    p, gp = sys_.pressure_and_slope(xi, np.concatenate(runs))
    st.checks = {"min_pressure": float(np.min(p)), "min_gap": 0.0}
    if np.min(p) < -ADMISSIBLE_TOL * P_scale:
        return _pressure_event(st, xi, p)
    xo = _gap_candidates(st, profile, runs, closed, gp)
    xo = np.concatenate([xo, _refined_minima(sys_, xo, profile)])
    if xo.size:
        g = deformed_gap(sys_, xo)
        st.checks["min_gap"] = float(np.min(g))
        g_scale = A * st.P + 1e-300
        if np.min(g) < -ADMISSIBLE_TOL * g_scale:
            return _gap_event(st, float(xo[int(np.argmin(g))]), sys_, profile)
    return None


def _pressure_event(st: _State, xi: np.ndarray, p: np.ndarray) -> _Event:
    x = float(xi[int(np.argmin(p))])
    e = st.layout.edges
    k = int(np.searchsorted(e, x) // 2)
    a, b = e[2 * k], e[2 * k + 1]
    near = min(x - a, b - x) < 0.05 * (b - a)
    i_edge = 2 * k if x - a < b - x else 2 * k + 1
    if near and st.layout.pinned[i_edge]:
        return _Event("release", float(e[i_edge]), i_edge)
    if near:
        return _Event("shrink", x, i_edge)
    return _Event("split", x, k)


def _gap_event(st: _State, x: float, sys_: System, profile: Profile) -> _Event:
    """Classify a negative deformed gap at x by the extent of ``{g < 0}`` around it: touching
    both neighbouring edges -> merge; one edge -> that edge grows to the end of the overlap;
    neither -> a new zone on the overlap interval (the Section 6 guess)."""
    lo, hi = _negative_gap_interval(sys_, x, profile)
    e = st.layout.edges
    k = int(np.searchsorted(e, x))
    left = k - 1 if k > 0 else None        # index of the edge bounding the gap on the left
    right = k if k < e.size else None
    at_left = left is not None and lo <= e[left]
    at_right = right is not None and hi >= e[right]
    if at_left and at_right:
        return _Event("merge", x, k // 2 - 1)
    if at_left:
        return _Event("grow", hi, left)
    if at_right:
        return _Event("grow", lo, right)
    return _Event("add", x, interval=(lo, hi))


def _apply_event(st: _State, ev: _Event, sys_: System, profile: Profile) -> _State:
    edges = list(st.layout.edges)
    pinned = list(st.layout.pinned)
    if ev.kind == "merge":
        m = ev.index
        del edges[2 * m + 1: 2 * m + 3]
        del pinned[2 * m + 1: 2 * m + 3]
    elif ev.kind == "grow":
        edges[ev.index] = ev.where
    elif ev.kind == "add":
        lo, hi = ev.interval
        k = int(np.searchsorted(edges, ev.where))
        edges[k:k] = [lo, hi]
        pinned[k:k] = [lo in profile.pin_points, hi in profile.pin_points]
    elif ev.kind == "split":
        k = ev.index
        a, b = edges[2 * k], edges[2 * k + 1]
        w = 0.02 * (b - a)
        edges[2 * k + 1: 2 * k + 1] = [ev.where - w, ev.where + w]
        pinned[2 * k + 1: 2 * k + 1] = [False, False]
    elif ev.kind == "release":
        i = ev.index
        a, b = edges[i - (i % 2)], edges[i - (i % 2) + 1]
        edges[i] += (0.02 if i % 2 == 0 else -0.02) * (b - a)
        pinned[i] = False
    elif ev.kind == "shrink":
        i = ev.index
        a, b = edges[i - (i % 2)], edges[i - (i % 2) + 1]
        edges[i] += (0.05 if i % 2 == 0 else -0.05) * (b - a)
    layout = Layout(np.asarray(edges, float), np.asarray(pinned, bool))
    new = _fresh_state(layout, st.theta, st.P)
    return new


def _negative_gap_interval(sys_: System, x: float, profile: Profile) -> tuple[float, float]:
    """The overlap ``{g < 0}`` around x: the free-interpenetration guess of the new zone."""
    def g(t: float) -> float:
        return float(deformed_gap(sys_, np.array([t]))[0])

    e = sys_.layout.edges
    k = int(np.searchsorted(e, x))
    left_wall = e[k - 1] if k > 0 else profile.support[0]
    right_wall = e[k] if k < e.size else profile.support[1]
    ridges = np.asarray(profile.ridges)  # a zone cannot span a ridge: stop there
    left_wall = max([left_wall, *ridges[ridges < x]])
    right_wall = min([right_wall, *ridges[ridges > x]])
    span = max(e[-1] - e[0], profile.scale)
    lo = _walk(g, x, max(left_wall, x - 2 * span), profile)
    hi = _walk(g, x, min(right_wall, x + 2 * span), profile)
    if hi - lo < 1e-9 * span:
        lo, hi = x - 1e-6 * span, x + 1e-6 * span
    return lo, hi


def _walk(g, x: float, wall: float, profile: Profile) -> float:
    ts = np.linspace(x, wall, 65)[1:]
    prev = x
    for t in ts:
        gt = g(t) if np.isfinite(profile.h0(np.array([t]))[0]) else np.inf
        if gt >= 0:
            if not np.isfinite(gt):
                corner = [c for c in profile.pin_points if min(prev, t) <= c <= max(prev, t)]
                return corner[0] if corner else prev
            return brentq(g, prev, t, xtol=1e-14 * max(1.0, abs(t)))
        prev = t
    return prev


# ---------------------------------------------------------------------------------------------
# continuation in P at fixed theta
# ---------------------------------------------------------------------------------------------
class _StepFailed(Exception):
    pass


PREDICTOR_POINTS = 8  # states of one topology the predictor may extrapolate through


def _predict(st: _State, prev: tuple[_State, ...], P_next: float, profile: Profile) -> _State:
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
    new = _State(trial, beta, st.theta, P_next, st.xc, st.ell, st.jac)
    if np.any(np.diff(edges) <= 0) or not _feasible(new, profile):
        new = _State(st.layout, beta, st.theta, P_next, st.xc, st.ell, st.jac)
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


def _converge(st: _State, profile: Profile, A: float, M: float | None) -> tuple[_State, System]:
    history: list[_Event] = []
    starts: set[bytes] = set()
    for _ in range(MAX_TOPOLOGY_CHANGES):
        st = _recentre(st)
        _check_cycle(st.layout, starts, history)
        try:
            st, F = _newton(st, _Mode(st.P, M), profile, A)
        except _NewtonFailed as exc:
            pinned = _pin_nearest(st, profile, A, PIN_DISTANCE * st.layout.edge_widths())
            if pinned is None:
                raise _StepFailed(str(exc)) from exc
            history.append(_Event("pin", pinned[1]))
            st = pinned[0]
            continue
        landed = _pin_nearest(st, profile, A, np.full(st.layout.edges.size, 1e-10 * st.ell))
        if landed is not None:  # a free edge converged onto a corner: re-solve it as singular
            history.append(_Event("pin", landed[1]))
            st = landed[0]
            continue
        sys_ = st.system or System.build(st.layout, profile, A, st.theta, st.xc, st.beta)
        ev = _find_event(st, sys_, profile, A)
        if ev is None:
            st.F = F
            return st, sys_
        history.append(ev)
        st = _apply_event(st, ev, sys_, profile)
        st.beta = _beta_for(st, A, st.P)
    raise _StepFailed(f"topology did not settle: {history}")


def _check_cycle(layout: Layout, starts: set[bytes], history: list[_Event]) -> None:
    """Fail the step at once when a Newton solve would restart from a layout (edges and
    singular flags) already tried in this step: the solve and the events after it are
    deterministic, so the topology would only cycle until MAX_TOPOLOGY_CHANGES (e.g. pin at a
    ridge, negative pressure, release, Newton fails, pin at the same ridge again)."""
    key = layout.edges.tobytes() + layout.pinned.tobytes()
    if key in starts:
        raise _StepFailed(f"topology cycles: {history}")
    starts.add(key)


def _recentre(st: _State) -> _State:
    e = st.layout.edges
    xc = float(0.5 * (e[0] + e[-1]))
    ell = max(float(e[-1] - e[0]), 1e-300)
    beta = _shift_poly(st.beta, xc - st.xc)
    return _State(st.layout, beta, st.theta, st.P, xc, ell, st.jac)


def _shift_poly(beta: np.ndarray, d: float) -> np.ndarray:
    """Coefficients of T in the coordinate shifted by d: T(x) = sum b_k (x - xc_old)^k."""
    if beta.size <= 1 or d == 0.0:
        return beta.copy()
    p = np.polynomial.Polynomial(beta)
    return np.polynomial.Polynomial(p(np.polynomial.Polynomial([d, 1.0])).coef).coef[: beta.size]


PIN_DISTANCE = 0.05  # a free edge this close to a corner (fraction of its zone) may pin there


def _pin_nearest(st: _State, profile: Profile, A: float, limits: np.ndarray
                 ) -> tuple[_State, float] | None:
    """The free edge nearest a pin point (corner or ridge), if within its limit, becomes
    singular there: the new (unsolved) state and the pin position, or None."""
    e, pinned = st.layout.edges.copy(), st.layout.pinned.copy()
    best = None
    for i in np.flatnonzero(~pinned):
        for c in profile.pin_points:
            d = abs(e[i] - c)
            if d <= limits[i] and (best is None or d < best[0]):
                best = (d, i, c)
    if best is None:
        return None
    _, i, c = best
    e[i], pinned[i] = c, True
    new = _fresh_state(Layout(e, pinned), st.theta, st.P)
    new.beta = _beta_for(new, A, st.P)
    return new, float(c)


def _continue(st: _State, P_target: float, profile: Profile, A: float,
              prev: tuple[_State, ...] = ()) -> tuple[_State, System, tuple[_State, ...]]:
    ratio = 4.0
    sys_ = None
    guard = 0
    while True:
        guard += 1
        if guard > 400:
            raise ConvergenceError("continuation did not reach the load", {"P": st.P})
        P_next = P_target if st.P * ratio >= P_target else st.P * ratio
        try:
            trial = _predict(st, prev, P_next, profile)
            new, sys_ = _converge(trial, profile, A, None)
        except _StepFailed as exc:
            merged = _try_merge(st, P_next, profile, A)
            if merged is not None:
                prev, (st, sys_) = (), merged
                if P_next == P_target:
                    return st, sys_, prev
                continue
            ratio = np.sqrt(P_next / st.P)  # half the failed step (in log P), not of ratio
            if ratio < 1 + 1e-7:
                raise ConvergenceError(f"continuation stalled at P={st.P:.6g}: {exc}",
                                       {"P_reached": st.P, "P_target": P_target,
                                        "zones": st.layout.zones()}) from exc
            continue
        prev, st = (st, *prev[:PREDICTOR_POINTS - 2]), new
        if P_next == P_target:
            return st, sys_, prev
        ratio = min(ratio * ratio, 16.0)


# on a failed step, try merging two zones whose gap is below this fraction of their widths
MERGE_GAP = 0.5


def _try_merge(st: _State, P_next: float, profile: Profile, A: float):
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
    trial = _fresh_state(layout, st.theta, P_next)
    trial.beta = _beta_for(trial, A, P_next)
    try:
        return _converge(trial, profile, A, None)
    except _StepFailed:
        return None


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------
def _validate(profile: Profile, P: float, A: float) -> tuple[float, float]:
    """Refuse a non-profile, or P, A not finite and > 0 (:mod:`analytic._validate`)."""
    check.instance("profile", profile, Profile, "an analytic.profiles.Profile")
    A = check.positive("A", A, "compliance A = 4(1 - nu^2)/E")
    return check.positive("P", P, "load"), A


def _validate_theta(profile: Profile, theta: float) -> None:
    if not profile.admits_tilt(theta):
        lo, hi = profile.tilt_limits
        raise InputError(f"theta={theta!r} is not allowed: h0 - theta x must rise towards both "
                         f"ends, need {lo:.6g} < theta < {hi:.6g} (the body tips off)")


def solve_normal(profile: Profile, P: float, A: float, M: float | None = None
                 ) -> NormalSolution:
    """Solve the normal contact problem at load P (paper Sections 2-4, any number of zones).

    ``M=None``: vertical indentation (rotation locked; the moment is an output).  ``M`` given:
    applied moment about x = 0; the rigid rotation ``theta`` is an output.
    """
    P, A = _validate(profile, P, A)
    M = check.optional_real("M", M, "a finite moment, or None for vertical indentation")
    if M is None:
        st, sys_ = _solve_fixed(profile, P, A, 0.0)
        return _finish(st, sys_, profile, A, "vertical")
    from analytic._moment import solve_with_moment

    st, sys_ = solve_with_moment(profile, P, A, float(M))
    return _finish(st, sys_, profile, A, "moment")


def _solve_fixed(profile: Profile, P: float, A: float, theta: float) -> tuple[_State, System]:
    """Newton straight from the overlap guess at P; full continuation from the first touch if
    that fails (the admissibility checks decide either way)."""
    guess = overlap_guess(profile, theta, P, A)
    if guess is not None:
        st = _fresh_state(guess, theta, P)
        st.beta = _beta_for(st, A, P)
        try:
            return _converge(st, profile, A, None)
        except _StepFailed:
            pass
    st = _initial_state(profile, A, theta, P)
    st, sys_, _ = _continue(st, P, profile, A)
    return st, sys_


def solve_normal_fixed_rotation(profile: Profile, P: float, A: float, theta: float
                                ) -> NormalSolution:
    """Normal problem with the rigid rotation prescribed (the stick-zone reduced problem)."""
    P, A = _validate(profile, P, A)
    theta = check.real("theta", theta)
    _validate_theta(profile, theta)
    st, sys_ = _solve_fixed(profile, P, A, theta)
    return _finish(st, sys_, profile, A, "fixed-rotation")


def load_curve(profile: Profile, loads: Sequence[float], A: float, M: float | None = None,
               theta: float | None = None) -> list[NormalSolution]:
    """Solutions at several loads, reusing one continuation from the first touch.

    ``M`` given: applied moment at every load (solved load by load).  ``theta`` given: the rigid
    rotation is prescribed (the stick-zone problems of stage 2/3).  Otherwise vertical indentation.
    Results are returned in the order of ``loads``.
    """
    loads = check.vector("loads", loads, 1, lambda v: bool(np.all(v > 0)),
                         "a non-empty 1-D sequence of finite loads > 0")
    _, A = _validate(profile, loads[0], A)
    M, theta = check.optional_real("M", M), check.optional_real("theta", theta)
    if M is not None and theta is not None:
        raise InputError("give either M (applied moment) or theta (prescribed rotation), not both")
    order = np.argsort(loads)
    out: list[NormalSolution | None] = [None] * loads.size
    if M is not None:
        for i in order:
            out[i] = solve_normal(profile, loads[i], A, M)
        return out  # type: ignore[return-value]
    th = 0.0 if theta is None else float(theta)
    _validate_theta(profile, th)
    mode = "vertical" if theta is None else "fixed-rotation"
    st, _ = _solve_fixed(profile, float(loads[order[0]]), A, th)
    prev: tuple[_State, ...] = ()
    for i in order:
        st, sys_, prev = _continue(st, float(loads[i]), profile, A, prev)
        out[i] = _finish(st, sys_, profile, A, mode)
    return out  # type: ignore[return-value]


def _finish(st: _State, sys_: System, profile: Profile, A: float, mode: str) -> NormalSolution:
    zl = zone_loads(sys_)
    P_calc, M_calc = sys_.load_and_moment()
    F = st.F if st.F is not None else _residual(st, _Mode(st.P, None), profile, A)[0]
    if st.checks is None and _find_event(st, sys_, profile, A) is not None:
        raise ConvergenceError("the final state is not admissible", {"zones": st.layout.zones()})
    checks = st.checks
    res = {
        "equations": float(np.max(np.abs(F))) if F.size else 0.0,
        "equilibrium": abs(sum(zl) - st.P) / st.P,
        "load_closed_form": abs(P_calc - st.P) / st.P,
        **checks,
    }
    singular = [tuple(bool(v) for v in pr) for pr in st.layout.pinned.reshape(-1, 2)]
    return NormalSolution(st.layout.zones(), singular, zl, st.P, M_calc, st.theta, mode, A,
                          res, profile, sys_)


# ---------------------------------------------------------------------------------------------
# per-zone loads and moments (contour integrals of Phi = W Psi)
# ---------------------------------------------------------------------------------------------
CONTOUR_START = 32        # nodes per ellipse of the coarsest rule (compared with twice as many)
CONTOUR_MAX = 2560        # give up doubling here (zones a few 1e-4 of their width apart)
CONTOUR_TOL = 1e-14       # accept when a doubling changes every zone integral by less (x total)


def zone_loads(sys_: System) -> list[float]:
    """``int_{L_k} p dx`` per zone.

    With ``Phi(z) = (1/2 pi i) int_L p(s)/(s - z) ds = W(z) Psi(z)`` analytic off L, the load of
    zone k is ``-oint_{C_k} Phi dz`` over an ellipse around that zone only.  The trapezoidal rule
    converges geometrically and never touches the kinks or edges on the real axis; the node count
    is doubled (reusing every node) until a doubling changes no zone load by more than
    ``CONTOUR_TOL`` times the total (close zones need squeezed ellipses and more nodes).
    """
    return [float(v.real) for v in _zone_contour_integrals(sys_, 0)]


def _zone_contour_integrals(sys_: System, power: int) -> list[complex]:
    """``-oint_{C_k} Phi z^power dz`` for every zone k (nested trapezoidal rules)."""
    ellipses = _zone_ellipses(sys_.layout)
    n = 2 * CONTOUR_START
    terms = _contour_terms(sys_, ellipses, power, 2 * np.pi * np.arange(n) / n)
    total = terms.sum(1)
    estimate = terms[:, ::2].sum(1) * (4 * np.pi / n)  # the coarse rule: every other node
    while True:
        refined = total * (2 * np.pi / n)
        change = np.max(np.abs(refined - estimate))
        if change <= CONTOUR_TOL * (np.sum(np.abs(refined)) + 1e-300) or n >= CONTOUR_MAX:
            return list(-refined)
        estimate = refined
        total = total + _contour_sums(sys_, ellipses, power, 2 * np.pi * (np.arange(n) + 0.5) / n)
        n *= 2


RHO_ISOLATED = 2.0 + math.sqrt(3.0)  # ellipse parameter around a zone without neighbours


def _zone_ellipses(lay: Layout) -> list[tuple[float, float, float]]:
    """Centre and semi-axes of an ellipse around each zone only: the Bernstein ellipse of the
    zone (foci at its edges) whose parameter ``rho`` is the geometric mean of 1 (the zone's own
    cut) and ``rho_out``, that of the nearest edge of a neighbouring zone.  Phi is analytic
    between the two, so the trapezoidal rule converges like ``sqrt(rho_out)^-n`` (the fastest
    rate for both sides at once)."""
    e = lay.edges.tolist()
    out = []
    for k in range(lay.n):
        a, b = e[2 * k], e[2 * k + 1]
        rx = 0.5 * (b - a)
        d = min(a - e[2 * k - 1] if k > 0 else math.inf,
                e[2 * k + 2] - b if k + 1 < lay.n else math.inf)
        rho = RHO_ISOLATED
        if d < math.inf:
            rho_out = (rx + d + math.sqrt(d * (2 * rx + d))) / rx
            rho = min(math.sqrt(rho_out), RHO_ISOLATED)
        out.append((0.5 * (a + b), 0.5 * rx * (rho + 1 / rho), 0.5 * rx * (rho - 1 / rho)))
    return out


def _contour_terms(sys_: System, ellipses: list, power: int, t: np.ndarray) -> np.ndarray:
    """``Phi z^power dz/dt`` at the parameters t on every ellipse, one row per zone."""
    cos, sin = np.cos(t), np.sin(t)
    z = np.concatenate([c + ax * cos + 1j * ay * sin for c, ax, ay in ellipses])
    dz = np.concatenate([-ax * sin + 1j * ay * cos for _, ax, ay in ellipses])
    return (_phi(sys_, z) * z**power * dz).reshape(len(ellipses), t.size)


def _contour_sums(sys_: System, ellipses: list, power: int, t: np.ndarray) -> np.ndarray:
    """Sum over the parameters t of ``Phi z^power dz/dt`` on every ellipse (one Phi call)."""
    return _contour_terms(sys_, ellipses, power, t).sum(1)


def _phi(sys_: System, z: np.ndarray) -> np.ndarray:
    """``Phi(z) = W(z) Psi(z)`` off the real axis (principal branches; analytic off L)."""
    lay = sys_.layout
    roots = np.sqrt(z[:, None] - lay.edges[None, :])
    W = np.prod(roots[:, ~lay.pinned], axis=1)
    if lay.e < lay.pinned.size:
        W /= np.prod(roots[:, lay.pinned], axis=1)
    sq = sys_.sq
    zh = z - sys_.xc
    # sum f/(s - z) in real arithmetic: 1/(s - z) = (s - x + i y)/((s - x)^2 + y^2), z = x + iy
    dx = sq.s[None, :] - zh.real[:, None]
    inv = dx * dx
    inv += (zh.imag**2)[:, None]
    np.reciprocal(inv, out=inv)
    f = sq.dh * sq.Omega
    dx *= inv
    cauchy = dx @ f + 1j * zh.imag * (inv @ f)
    T = np.polyval(sys_.beta[::-1], zh) if sys_.beta.size else 0.0
    return W * (cauchy + T) / (2j * np.pi * sys_.A)
