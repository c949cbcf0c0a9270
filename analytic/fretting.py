"""The fretting cycle ``0 -> Q0 -> -Q0 -> Q0``: its stick-slip map and the dissipated energy.

Every state of the cycle is a stick state of :mod:`analytic.stick` (paper Table 1, stages 2-3,
by the Jager-Ciavarella principle of Section 5); :func:`cycle` computes all of them from one
continuation of the reduced problems and checks condition (iii) of that module -- the slip grows
monotonically in its direction -- along the whole path.

Dissipation per steady cycle ``Q0 -> -Q0 -> Q0``: a point that slips in stage 3 keeps slipping
with ``q = -sigma mu p`` (condition iii) from ``s = 0`` to ``s = -2 sigma mu g_S(x; P*)``, so the
friction work there is ``2 mu^2 p g_S(x; P*)``; the return half is its mirror image.  Per zone

    W_k = oint int_{L_k} q ds dx = 4 mu^2 int_{L_k} p(x) g_S(x; P - Q0/mu) dx.

For Hertz (``c = a sqrt(1 - Q0/(mu P))``, ``g_S = (|x| sqrt(x^2 - c^2) - c^2 acosh(|x|/c))/(2R)``)
the slip zones have width ``eps = a Q0/(2 mu P)``, ``p ~ sqrt(eps)`` and ``g_S ~ eps^(3/2)`` there,
so ``W = 4 mu^2 * 2 * (4/3)(p0/R) B(3/2, 5/2) eps^3 = A Q0^3 / (3 pi mu P) (1 + O(Q0/(mu P)))``
(with ``p0 = a/(A R)``, ``a^2 = 2 A P R/pi``): the classic cubic law of Mindlin's dissipation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from analytic import _validate as check
from analytic._breakpoints import split_at_kinks
from analytic.errors import ConvergenceError
from analytic.normal import NormalSolution
from analytic.stick import (
    GROSS_SLIP_REL,
    StickSolution,
    check_mu,
    check_normal,
    check_states,
    checked_state,
    cosine_rule,
    reduced_solutions,
    unchecked_state,
    zone_rule,
)

RATE_TOL = 1e-9
"""Allowed rise of ``g_S`` with the reduced load between cycle samples, relative to ``A P``
(condition iii; a rise means a point slips backwards against its shear)."""
RATE_NODES = 8
"""Nodes per slip interval at which the monotonic-slip condition is checked along a cycle."""


@dataclass(frozen=True)
class CycleResult:
    """The cycle ``0 -> Q0 -> -Q0 -> Q0`` sampled at ``n`` loads: stick-slip map and dissipation.

    Attributes
    ----------
    normal, mu, Q0 : the stage-1 solution, friction coefficient and amplitude (``Q0 > 0``).
    Q : (n,) tangential loads along the path.  Stage 2 ``0 -> Q0`` and the half cycles
        ``Q0 -> -Q0`` and ``-Q0 -> Q0`` get the same number ``m`` of load steps (stage 2 twice as
        dense in Q), so all samples share the ``m + 1`` reduced loads ``P - k Q0 / (m mu)``.
    stage : (n,) 2, 3 (``Q0 -> -Q0``) or 4 (``-Q0 -> Q0``, the mirror image of stage 3).
    P_reduced : (n,) reduced load of each sample.
    stick_edges : (n, n_zones, 2) stick edges ``(c, d)`` per sample and zone; ``nan`` in full slip.
    full_slip : (n, n_zones) True where a zone is in full slip.
    states : the :class:`StickSolution` of each sample (stage 4 samples are stage-3 solutions
        started from ``-Q0``: ``solve_stick(normal, mu, Q, -Q0)``).
    W : dissipated energy per steady cycle per zone (energy per unit width),
        ``4 mu^2 int_{L_k} p g_S(x; P - Q0/mu) dx`` (module docstring).
    residuals : worst self-checks over all samples, and ``rate`` (largest rise of ``g_S`` with
        the reduced load, relative to ``A P``; <= RATE_TOL, else the loop integral fails).
    """

    normal: NormalSolution = field(repr=False)
    mu: float
    Q0: float
    Q: np.ndarray
    stage: np.ndarray
    P_reduced: np.ndarray
    stick_edges: np.ndarray
    full_slip: np.ndarray
    states: tuple[StickSolution, ...] = field(repr=False)
    W: tuple[float, ...]
    residuals: dict[str, float]

    @property
    def W_total(self) -> float:
        """Dissipated energy per steady cycle, all zones."""
        return float(sum(self.W))


def _cycle_loads(Q0: float, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Path samples (Q, stage, k): stage 2 has ``m + r`` steps, the half cycles ``m`` each."""
    m = (n - 1) // 3
    m2 = n - 1 - 2 * m
    Q2 = Q0 * np.arange(m2 + 1) / m2
    k = np.arange(1, m + 1)
    Q3 = Q0 - 2 * Q0 * k / m
    Q = np.concatenate([Q2, Q3, -Q3])
    stage = np.concatenate([np.full(m2 + 1, 2), np.full(m, 3), np.full(m, 4)])
    return Q, stage, np.concatenate([np.arange(m2 + 1) / m2, k / m, k / m])


def cycle(normal: NormalSolution, mu: float, Q0: float, n: int = 100) -> CycleResult:
    """The loading cycle ``0 -> Q0 -> -Q0 -> Q0`` at ``n`` samples (paper Table 1, stages 2-3).

    Returns the stick-slip map (stick edges per zone vs Q), the states, and the dissipation per
    steady cycle per zone (module docstring).  All reduced problems come from one continuation.
    Needs ``0 < Q0 < mu P`` (at ``Q0 = mu P`` the gross-sliding slip, hence W, is unbounded)
    and ``n >= 7``.
    """
    check_normal(normal)
    mu = check_mu(mu)
    Q0 = check.real("Q0", Q0, f"0 < Q0 < mu P = {mu * normal.P:.6g} in a cycle (Q0 = mu P is "
                    "gross sliding, W unbounded)",
                    lambda v: 0 < v < mu * normal.P * (1 - GROSS_SLIP_REL))
    n = check.integer("n", n, 7)
    Q, stage, frac = _cycle_loads(Q0, int(n))
    P_red = normal.P - frac * Q0 / mu
    uniq, inv = np.unique(P_red, return_inverse=True)
    reds = reduced_solutions(normal, uniq)
    i_end = int(np.sum(stage == 2)) - 1
    end = checked_state(normal, mu, Q0, None, reds[inv[i_end]], P_red[i_end], None)
    mirror = _mirrored(end)
    states = []
    for i in range(Q.size):
        red = reds[inv[i]]
        if stage[i] == 2:
            states.append(end if Q[i] == Q0 else unchecked_state(normal, mu, Q[i], None, red,
                                                                  P_red[i], None))
        else:
            prev, start = (end, Q0) if stage[i] == 3 else (mirror, -Q0)
            states.append(unchecked_state(normal, mu, Q[i], start, red, P_red[i], prev))
    checked = check_states(states)
    return _cycle_result(normal, mu, Q0, Q, stage, P_red, tuple(checked), reds, inv)


def _mirrored(end: StickSolution) -> StickSolution:
    """The stage-2 end state at ``-Q0`` (shear ``-q0``): the start of the return half cycle."""
    return StickSolution(
        normal=end.normal, mu=end.mu, Q=-end.Q, Q0=None, stage=2, direction=-end.direction,
        P_reduced=end.P_reduced, reduced=end.reduced, stick_zones=end.stick_zones,
        stick_intervals=end.stick_intervals, slip_zones=end.slip_zones,
        full_slip_zones=end.full_slip_zones, previous=None, residuals=dict(end.residuals))


def _cycle_result(normal, mu, Q0, Q, stage, P_red, states, reds, inv) -> CycleResult:
    nz = normal.n_zones
    edges = np.full((Q.size, nz, 2), np.nan)
    for i, s in enumerate(states):
        for k, cd in enumerate(s.stick_zones):
            if cd is not None:
                edges[i, k] = cd
    end = states[int(np.sum(stage == 2)) - 1]
    residuals = {key: max(s.residuals[key] for s in states)
                 for key in ("friction", "equilibrium", "containment")}
    residuals["rate"] = _rate_check(end, [reds[j] for j in np.unique(inv)])
    return CycleResult(normal=normal, mu=mu, Q0=Q0, Q=Q, stage=stage, P_reduced=P_red,
                       stick_edges=edges, full_slip=np.isnan(edges[:, :, 0]), states=states,
                       W=_dissipation(end), residuals=residuals)


def _dissipation(end: StickSolution) -> tuple[float, ...]:
    """``W_k = 4 mu^2 int_{L_k} p g_S(x; P*) dx`` over the slip zones of the stage-2 end state."""
    W = []
    for k in range(end.normal.n_zones):
        total = 0.0
        for lo, hi in end.slip_zones[k]:
            x, w = zone_rule(split_at_kinks(end.normal.profile, lo, hi))
            total += float(w @ (end.normal.pressure(x) * end.reduced.gap(x)))
        W.append(4 * end.mu**2 * total)
    return tuple(W)


def _rate_check(end: StickSolution, reds: list[NormalSolution]) -> float:
    """Condition (iii): ``g_S`` at the slip-zone points must not grow with the reduced load.

    ``reds`` are ordered by increasing load.  Returns the largest increase of ``g_S`` between
    consecutive loads, relative to ``A P`` (times mu it is the slip lost); raises if > RATE_TOL.
    """
    pts = [cosine_rule(lo, hi, RATE_NODES)[0] for zs in end.slip_zones for lo, hi in zs]
    if not pts:
        return 0.0
    x = np.concatenate(pts)
    g = np.array([r.gap(x) for r in reds])
    worst = float(np.max(np.diff(g, axis=0), initial=0.0)) / (end.normal.A * end.normal.P)
    if worst > RATE_TOL:
        raise ConvergenceError(
            f"the slip does not grow monotonically along the cycle (g_S rises by {worst:.3e} A P"
            " with the reduced load): the Jager-Ciavarella loop integral does not hold",
            {"rate": worst, "P_reduced": [r.P for r in reds]})
    return worst
