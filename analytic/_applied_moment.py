"""Applied-moment mode: the rigid rotation theta is found so that ``int x p dx = M``.

The fixed-rotation problem is the vertical-indentation problem of the tilted profile
``h0(x) - theta x``; its moment grows monotonically with theta.  We first bracket theta with
fixed-rotation solves, refine it with Brent's method, then polish all unknowns (edges and theta)
together with Newton so that the moment equation holds to the solver tolerance.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from analytic._continuation import StepFailed, converge, solve_fixed
from analytic._newton import State
from analytic._sie import System
from analytic.errors import ConvergenceError, InputError
from analytic.profiles import Profile

THETA_XTOL = 1e-13
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


def _moment_at(profile: Profile, P: float, A: float, theta: float):
    if not profile.admits_tilt(theta):  # h0 - theta x flat or falling out to infinity
        return None
    try:
        st, sys_ = solve_fixed(profile, P, A, theta)
    except ConvergenceError:
        return None
    return st, sys_, sys_.load_and_moment()[1]


def _bracket(profile, P, A, M, theta0, step):
    first = _moment_at(profile, P, A, theta0)
    if first is None:
        raise ConvergenceError("fixed-rotation solve failed at the initial rotation",
                               {"theta": theta0})
    f0 = first[2] - M
    if abs(f0) <= MOMENT_SETTLED * P * first[0].ell:  # theta0 carries M already (symmetry)
        return (theta0, theta0), first
    direction = -np.sign(f0) if f0 != 0 else 1.0
    lo_t, lo_f = theta0, f0
    for _ in range(60):
        t = lo_t + direction * step
        trial = _moment_at(profile, P, A, t)
        if trial is None:
            step *= 0.5
            continue
        f = trial[2] - M
        if np.sign(f) != np.sign(lo_f):
            return (lo_t, t) if lo_t < t else (t, lo_t), trial
        lo_t, lo_f = t, f
        step *= 2.0
    raise InputError(f"M={M!r} cannot be carried: no rotation gives that moment "
                     "(the body tips off its contact)")


def solve_with_moment(profile: Profile, P: float, A: float, M: float) -> tuple[State, System]:
    xe = check_tipping(profile, P, M)
    theta0 = _initial_rotation(profile, xe)
    scale = abs(theta0) + A * P / profile.scale + 1e-12
    (t_lo, t_hi), _ = _bracket(profile, P, A, M, theta0, 0.25 * scale)
    try:
        theta = t_lo if t_lo == t_hi else brentq(
            lambda t: _moment_or_nan(profile, P, A, t) - M, t_lo, t_hi,
            xtol=THETA_XTOL * max(scale, 1.0), rtol=1e-14)
    except ValueError as exc:  # a re-solve at a bracket end gave M - M(theta) the other sign
        raise ConvergenceError(f"moment search lost its bracket: {exc}",
                               {"theta_bracket": (t_lo, t_hi)}) from exc
    st, sys_ = solve_fixed(profile, P, A, theta)
    try:
        return converge(st, profile, A, M)
    except StepFailed as exc:
        if abs(sys_.load_and_moment()[1] - M) <= 1e-10 * P * st.ell:
            return st, sys_
        raise ConvergenceError(f"moment polish failed: {exc}", {"theta": theta}) from exc


def _initial_rotation(profile: Profile, xe: float) -> float:
    """The rotation that puts the minimum of ``h0 - theta x`` at the load centre ``xe``: the
    slope there where h0 is curved, else 0.  On a straight piece that slope would make the piece
    flat: out to infinity for a wedge's face (the tilt limit; the first-touch zone then grows
    without bound and exhausted the memory after ~50 s), or a flat facet beyond the tilt limits
    of a double wedge whose inner faces are steeper than the outer ones (no solution)."""
    x = np.array([xe])
    slope, curvature = float(profile.dh0(x)[0]), float(profile.d2h0(x)[0])
    if np.isfinite(slope) and curvature != 0.0 and profile.admits_tilt(slope):
        return slope
    return 0.0


def _moment_or_nan(profile: Profile, P: float, A: float, theta: float) -> float:
    r = _moment_at(profile, P, A, theta)
    if r is None:
        raise ConvergenceError("fixed-rotation solve failed inside the rotation bracket",
                               {"theta": theta})
    return r[2]
