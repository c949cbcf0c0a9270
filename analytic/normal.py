"""Stage-1 (normal) problem for any number of contact zones: paper Sections 2-4.

Public entry points: :func:`solve_normal`, :func:`solve_normal_fixed_rotation`,
:func:`load_curve` and the result :class:`NormalSolution`; :func:`zone_loads` and
:func:`deformed_gap` evaluate a solved system.  The equations (consistency Eq. 12/14, rigid
interconnection Eq. 17, equilibrium, moment) are assembled in :mod:`analytic._sie` and solved by
Newton's method (:mod:`analytic._newton`) with continuation in the load from the first touch
(:mod:`analytic._continuation`, :mod:`analytic._first_touch`), keeping the contact topology
admissible (:mod:`analytic._admissibility`, :mod:`analytic._topology`: zones appear, merge,
split; singular edges pin at corners or release).  Applied-moment mode searches the rotation
(:mod:`analytic._applied_moment`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from analytic import _validate as check
from analytic._admissibility import find_event
from analytic._applied_moment import solve_with_moment
from analytic._continuation import continue_to, solve_fixed
from analytic._contour import zone_loads
from analytic._gap import deformed_gap, in_zones
from analytic._newton import Mode, State, counted_events, residual
from analytic._sie import System
from analytic._vectorise import elementwise
from analytic.errors import ConvergenceError, InputError
from analytic.profiles import Profile
from analytic.selfcheck import check_normal


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
        from the integrated pressure, min pressure, min gap), and the figures of the independent
        check of :mod:`analytic.selfcheck` (``selfcheck_*``: zone loads, moment, spread of the
        rigid approach, min p, min gap, from ``pressure(x)`` and h0 only).
    diagnostics : counts of the solver's exceptional events on the way to this solution
        (``jacobian_nonfinite_columns``: finite-difference Jacobian columns that came out
        non-finite and were recomputed with the step reversed; 0 normally).
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
    diagnostics: dict[str, int] = field(default_factory=dict, compare=False)

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
        inside = in_zones(x, self._system.layout.edges)
        if np.any(inside):
            out[inside] = self._system.pressure_inside(x[inside])
        return out

    @elementwise
    def gap(self, x: np.ndarray | float) -> np.ndarray:
        """Deformed gap ``g(x) >= 0`` (0 in the zones; ``+inf`` where the profile is undefined)."""
        return deformed_gap(self._system, x)


def solve_normal(profile: Profile, P: float, A: float, M: float | None = None
                 ) -> NormalSolution:
    """Solve the normal contact problem at load P (paper Sections 2-4, any number of zones).

    ``M=None``: vertical indentation (rotation locked; the moment is an output).  ``M`` given:
    applied moment about x = 0; the rigid rotation ``theta`` is an output.
    """
    P, A = check_problem(profile, P, A)
    M = check.optional_real("M", M, "a finite moment, or None for vertical indentation")
    with counted_events() as events:
        if M is None:
            st, sys_ = solve_fixed(profile, P, A, 0.0)
            return _finish(st, sys_, profile, A, "vertical", events=events)
        st, sys_ = solve_with_moment(profile, P, A, float(M))
        return _finish(st, sys_, profile, A, "moment", float(M), events)


def solve_normal_fixed_rotation(profile: Profile, P: float, A: float, theta: float
                                ) -> NormalSolution:
    """Normal problem with the rigid rotation prescribed (the stick-zone reduced problem)."""
    P, A = check_problem(profile, P, A)
    theta = check.real("theta", theta)
    _validate_theta(profile, theta)
    with counted_events() as events:
        st, sys_ = solve_fixed(profile, P, A, theta)
        return _finish(st, sys_, profile, A, "fixed-rotation", events=events)


def load_curve(profile: Profile, loads: Sequence[float], A: float, M: float | None = None,
               theta: float | None = None) -> list[NormalSolution]:
    """Solutions at several loads, reusing one continuation from the first touch.

    ``M`` given: applied moment at every load (solved load by load).  ``theta`` given: the rigid
    rotation is prescribed (the stick-zone problems of stage 2/3).  Otherwise vertical indentation.
    Results are returned in the order of ``loads``.
    """
    loads = check.vector("loads", loads, 1, lambda v: bool(np.all(v > 0)),
                         "a non-empty 1-D sequence of finite loads > 0")
    _, A = check_problem(profile, loads.min(), A)
    check.load_scale(A, float(loads.max()))
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
    with counted_events() as events:
        st, _ = solve_fixed(profile, float(loads[order[0]]), A, th)
        prev: tuple[State, ...] = ()
        for i in order:
            st, sys_, prev = continue_to(st, float(loads[i]), profile, A, prev)
            out[i] = _finish(st, sys_, profile, A, mode, events=events)
    return out  # type: ignore[return-value]


def _finish(st: State, sys_: System, profile: Profile, A: float, mode: str,
            M_target: float | None = None, events: Counter | None = None) -> NormalSolution:
    """The solution, checked by :func:`analytic.selfcheck.check_normal` (its figures join the
    residuals; ``M_target``: the applied moment, checked against ``int x p dx``; ``events``:
    the solver's event counts so far, see :attr:`NormalSolution.diagnostics`)."""
    zl = zone_loads(sys_)
    P_calc, M_calc = sys_.load_and_moment()
    F = st.F if st.F is not None else residual(st, Mode(st.P, None), profile, A)[0]
    if st.checks is None and find_event(st, sys_, profile, A) is not None:
        raise ConvergenceError("the final state is not admissible", {"zones": st.layout.zones()})
    checks = st.checks
    res = {
        "equations": float(np.max(np.abs(F))) if F.size else 0.0,
        "equilibrium": abs(sum(zl) - st.P) / st.P,
        "load_closed_form": abs(P_calc - st.P) / st.P,
        **checks,
    }
    singular = [tuple(bool(v) for v in pr) for pr in st.layout.pinned.reshape(-1, 2)]
    diagnostics = {"jacobian_nonfinite_columns": 0, **dict(events or {})}
    sol = NormalSolution(st.layout.zones(), singular, zl, st.P, M_calc, st.theta, mode, A,
                         res, profile, sys_, diagnostics)
    figs = check_normal(profile, sol.zones, singular, zl, st.P, M_target, st.theta, A,
                        sol.pressure)
    res.update(figs.as_residuals())
    return sol


def check_problem(profile: Profile, P: float, A: float) -> tuple[float, float]:
    """Refuse a non-profile, P, A not finite and > 0, or A P outside
    :data:`analytic._validate.AP_RANGE` (:mod:`analytic._validate`)."""
    check.instance("profile", profile, Profile, "an analytic.profiles.Profile")
    A = check.positive("A", A, "compliance A = 4(1 - nu^2)/E")
    P = check.positive("P", P, "load")
    check.load_scale(A, P)
    return P, A


def _validate_theta(profile: Profile, theta: float) -> None:
    if not profile.admits_tilt(theta):
        lo, hi = profile.tilt_limits
        raise InputError(f"theta={theta!r} is not allowed: h0 - theta x must rise towards both "
                         f"ends, need {lo:.6g} < theta < {hi:.6g} (the body tips off)")
