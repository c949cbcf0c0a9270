"""Stick and slip zones under tangential loading: paper Section 5 and Table 1, stages 2-3.

The Jager-Ciavarella principle (paper Section 5, generalised) turns every stick-zone problem into
a normal problem at a reduced load, solved at the *rotation* of stage 1 (not its moment).

Conventions (docs/conventions.md): ``p >= 0`` compressive; ``q`` is the shear on body 1 in the
direction of ``Q`` with ``int q dx = Q``; the relative slip ``s`` is the tangential displacement
of body 1 relative to body 2 accumulated in the current stage (positive along +x).

Derivation and signs (done once, here).  With ``u[f](x) = -(A/pi) int f(s) ln|x - s| ds`` and
``h = h0 - theta x``, the stage-1 solution satisfies ``u[p] = delta - h`` on the contact set ``L``,
and the reduced solution ``p_S`` at load ``P_S`` (same ``theta``) satisfies
``u[p_S] = delta_S - h + g_S`` everywhere, ``g_S`` its deformed gap (0 on its zones ``S``).  For
similar materials the tangential problem is uncoupled and uses the same kernel: the slip of a
shear increment ``dq`` is ``s = lam - u[dq]`` (``lam`` the rigid shift of body 1), and Coulomb's
law reads ``s = 0, |q| <= mu p`` (stick) or ``q = mu p sign(s)`` (slip: the shear body 1
transmits points along its slip).

* Stage 2 (``Q: 0 -> Q``, ``sigma = sign(Q)``): ``dq = sigma mu (p - p_S)`` with
  ``P* = P - |Q|/mu`` (``int dq = Q``; the paper's ``P* = P - Q/mu`` for ``Q > 0``).  On ``L``,
  ``u[dq] = sigma mu (delta - delta_S) - sigma mu g_S``; with ``lam = sigma mu (delta - delta_S)``
  the slip is ``s = sigma mu g_S``: zero on ``S`` and of sign ``sigma`` on ``L - S``, where
  ``q = sigma mu p`` -- Coulomb holds.  Paper Table 1 / Eq. (15) with ``q = -mu p + q*``
  (sign-flipped, ``q* = mu p_S``).
* Stage 3 (after ``0 -> Q0``, ``Q: Q0 -> Q``, ``sigma = sign(Q0)``): ``dq = -2 sigma mu (p - p_S)``
  with ``P** = P - |Q0 - Q|/(2 mu)``; the same algebra gives ``s = -2 sigma mu g_S``.  Outside
  ``S**`` the shear is ``q0 - 2 sigma mu p = -sigma mu p`` because ``S0 = S(P*)`` lies inside
  ``S** = S(P**)`` (``P** >= P*``; checked through (ii) below).  At ``Q = -Q0``, ``P** = P*``
  and ``q = -q0``.

The stick-zone side conditions -- consistency (paper Eq. 16) and rigid interconnection
(Eqs. 19-20) -- are the normal problem's Eqs. (14) and (17) at the reduced load with the same
``h' = h0' - theta``, so :func:`analytic.load_curve` at fixed ``theta`` enforces them exactly.

Both are exact only if (i) ``S`` lies inside ``L``, (ii) ``|q| <= mu p`` on ``S`` (i.e.
``0 <= p_S <= 2 p`` in stage 2) and (iii) the slip grows monotonically in its direction as the
stage proceeds (``g_S`` non-increasing in the reduced load).  (i) and (ii) are checked for every
solution, (iii) along every :func:`analytic.fretting.cycle`; a violation raises
:class:`ConvergenceError`.

A contact zone that holds no contact of the reduced problem is in *full slip*.  The paper's claim
that all zones reach full slip together (Section 5) holds only if all zones start touching at
the same load of the reduced problem ``h0 - theta x``; unequal lifts, or an applied moment
(``theta != 0``), make one zone slip fully before the others.

The loading cycle and its dissipation: :mod:`analytic.fretting`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from analytic import _validate as check
from analytic._breakpoints import breakpoints
from analytic._vectorise import elementwise
from analytic.errors import ConvergenceError, InputError
from analytic.normal import NormalSolution, load_curve

FRICTION_TOL = 1e-8
"""Allowed ``|q| - mu p`` relative to ``mu P / extent`` (the normal solutions are ~1e-12 exact)."""
EQUILIBRIUM_TOL = 1e-9
"""Allowed ``|int q dx - Q|`` relative to ``mu P`` (zone loads are exact to ~1e-13)."""
CONTAIN_TOL = 1e-9
"""How far (relative to the contact extent) a stick zone may poke out of its contact zone."""
GROSS_SLIP_REL = 1e-12
"""``|Q|`` within this fraction of ``mu P`` counts as ``mu P`` (gross sliding)."""
SAME_LOAD_REL = 1e-14
"""A reduced load this close to P reuses the stage-1 solution (the reduced problem is stage 1)."""
QUAD_NODES = 32
"""Gauss-Legendre nodes per sub-interval in the cosine map, cut at edges and kinks (W of the
double wedge, log-singular pressure at a kink end, agrees to 1e-14 from 24 nodes)."""
CHECK_NODES = 24
"""Nodes per sub-interval at which ``|q| <= mu p`` is checked (clustered at the ends)."""


# ---------------------------------------------------------------------------------------------
# results
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StickSolution:
    """Partial-slip state at tangential load ``Q`` (paper Table 1, stages 2-3; Section 5).

    Attributes
    ----------
    normal : the stage-1 solution the shear lives on.
    mu : Coulomb friction coefficient.
    Q : tangential force on body 1 per unit width.
    Q0 : ``None`` in stage 2; in stage 3 the turning load of the preceding stage 2.
    stage : 2 or 3.
    direction : sign of the shear in the slip zones that grow in this stage (and of the slip):
        ``sign(Q)`` in stage 2, ``-sign(Q0)`` in stage 3.
    P_reduced : the reduced load ``P* = P - |Q|/mu`` (stage 2) or ``P** = P - |Q0 - Q|/(2 mu)``.
    reduced : the normal solution at ``P_reduced`` and the rotation ``normal.theta`` (its zones
        are the stick zones); ``None`` when ``P_reduced`` is zero (gross sliding).
    stick_zones : per contact zone ``(c, d)`` or ``None`` for a zone in full slip.  Should the
        reduced problem split one contact zone into several stick intervals (outside the
        paper's theory), this is their hull: ``stick_intervals`` holds them all.
    stick_intervals : per contact zone, all stick intervals ``((c, d), ...)``.
    slip_zones : per contact zone, the slip intervals of this stage (``L_k`` minus stick).
    full_slip_zones : indices into ``normal.zones`` of the zones without stick.
    previous : stage 3: the stage-2 end state at ``Q0`` (``q0``); ``None`` in stage 2.
    residuals : self-checks: ``friction`` (max ``(|q| - mu p)`` / ``(mu P/extent)``),
        ``equilibrium`` (``|int q - Q| / (mu P)``), ``containment`` (how far stick zones poke
        out of their contact zones, relative to the extent).
    """

    normal: NormalSolution = field(repr=False)
    mu: float
    Q: float
    Q0: float | None
    stage: int
    direction: float
    P_reduced: float
    reduced: NormalSolution | None = field(repr=False)
    stick_zones: tuple[tuple[float, float] | None, ...]
    stick_intervals: tuple[tuple[tuple[float, float], ...], ...]
    slip_zones: tuple[tuple[tuple[float, float], ...], ...]
    full_slip_zones: tuple[int, ...]
    previous: StickSolution | None = field(repr=False)
    residuals: dict[str, float]

    @property
    def factor(self) -> float:
        """Signed multiple of ``mu (p - p_S)`` added in this stage: ``direction * (1 or 2)``."""
        return self.direction * (1.0 if self.stage == 2 else 2.0)

    @elementwise
    def shear(self, x: np.ndarray | float) -> np.ndarray:
        """Shear ``q(x)`` on body 1 along +x (vectorised; 0 outside the contact zones).

        Stage 2: ``sigma mu [p(x; P) - p_S(x; P*)]``;
        stage 3: ``q0 - 2 sigma mu [p(x; P) - p_S(x; P**)]``.
        """
        return self.pressure_and_shear(x)[1]

    def pressure_and_shear(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``p(x)`` and ``q(x)`` at the points of the array ``x`` (``q`` summed over the stages
        of this state's history; the stage-1 pressure is evaluated once for all of them)."""
        p = self.normal.pressure(x)
        q = np.zeros(x.shape)
        s: StickSolution | None = self
        while s is not None:
            p_s = s.reduced.pressure(x) if s.reduced is not None else 0.0
            q += s.factor * s.mu * (p - p_s)
            s = s.previous
        return p, q

    @elementwise
    def slip(self, x: np.ndarray | float) -> np.ndarray:
        """Relative slip of body 1 w.r.t. body 2 accumulated in this stage (vectorised).

        ``sigma mu g_S(x)`` (stage 2) or ``-2 sigma mu g_S(x)`` (stage 3) in the contact zones,
        zero in the stick zones; 0 outside the contact zones.  ``nan`` in gross sliding, where
        the rigid slip is unbounded.
        """
        inside = _inside(x, self.normal.zones)
        out = np.zeros(x.shape)
        if self.reduced is None:
            out[inside] = np.nan
        elif np.any(inside):
            out[inside] = self.factor * self.mu * self.reduced.gap(x[inside])
        return out


# ---------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------
def check_normal(normal: NormalSolution) -> None:
    check.instance("normal", normal, NormalSolution, "an analytic.NormalSolution")


def check_mu(mu: float) -> float:
    return check.positive("mu", mu, "friction coefficient")


def _check_tangential(name: str, value: float, limit: float, allow_full_slip: bool) -> float:
    """``|value| < limit = mu P``; ``= limit`` only with ``allow_full_slip``; never above."""
    value = check.real(name, value, "a finite force")
    if abs(value) > limit * (1 + GROSS_SLIP_REL):
        raise InputError(f"{name}={value!r} is not allowed: need |{name}| <= mu P = {limit:.6g} "
                         "(beyond it the interface cannot hold the body: no static state)")
    if abs(value) >= limit * (1 - GROSS_SLIP_REL) and not allow_full_slip:
        raise InputError(f"{name}={value!r} is not allowed: |{name}| = mu P = {limit:.6g} is gross"
                         " sliding (no stick zone); pass allow_full_slip=True for that state")
    return float(np.clip(value, -limit, limit))


def _check_stage3_load(Q: float, Q0: float) -> float:
    lo, hi = sorted((-Q0, Q0))
    return check.real("Q", Q, f"Q between -Q0 and Q0 = {Q0!r} in stage 3 (the load comes back "
                      "from Q0 towards -Q0)", lambda v: lo <= v <= hi)


# ---------------------------------------------------------------------------------------------
# reduced (stick-zone) problems
# ---------------------------------------------------------------------------------------------
def reduced_solutions(normal: NormalSolution, loads: np.ndarray) -> list[NormalSolution | None]:
    """Normal solutions at the reduced loads and the rotation of stage 1 (one continuation)."""
    P = normal.P
    out: list[NormalSolution | None] = [None] * loads.size
    same = np.abs(loads - P) <= SAME_LOAD_REL * P
    zero = loads <= GROSS_SLIP_REL * P
    todo = np.flatnonzero(~same & ~zero)
    for i in np.flatnonzero(same):
        out[i] = normal
    if todo.size:
        sols = load_curve(normal.profile, loads[todo], normal.A, theta=normal.theta)
        for i, s in zip(todo, sols, strict=True):
            out[i] = s
    return out


def _stage2_load(P: float, mu: float, Q: float) -> float:
    """``P* = P - |Q|/mu`` (paper Section 5, stage 2)."""
    return max(P - abs(Q) / mu, 0.0)


def _stage3_load(P: float, mu: float, Q: float, Q0: float) -> float:
    """``P** = P - |Q0 - Q|/(2 mu)`` (paper Section 5, stage 3)."""
    return max(P - abs(Q0 - Q) / (2 * mu), 0.0)


# ---------------------------------------------------------------------------------------------
# zones
# ---------------------------------------------------------------------------------------------
def _inside(x: np.ndarray, zones: list[tuple[float, float]]) -> np.ndarray:
    z = np.asarray(zones, float).reshape(-1, 2)
    return np.any((x[:, None] >= z[:, 0]) & (x[:, None] <= z[:, 1]), axis=1)


def _assign_stick(normal: NormalSolution, reduced: NormalSolution | None
                  ) -> tuple[list[list[tuple[float, float]]], float]:
    """Stick intervals per contact zone (clipped), and the worst poke-out (relative)."""
    per: list[list[tuple[float, float]]] = [[] for _ in normal.zones]
    if reduced is None:
        return per, 0.0
    tol = CONTAIN_TOL * normal.extent
    worst = 0.0
    for c, d in reduced.zones:
        k = next((k for k, (a, b) in enumerate(normal.zones) if a - tol <= c and d <= b + tol),
                 None)
        if k is None:
            raise ConvergenceError(
                f"stick zone ({c:.12g}, {d:.12g}) at the reduced load P_S={reduced.P:.6g} lies "
                "outside every contact zone: the Jager-Ciavarella state is not admissible",
                {"contact_zones": normal.zones, "reduced_zones": reduced.zones,
                 "P_reduced": reduced.P})
        a, b = normal.zones[k]
        worst = max(worst, (a - c) / normal.extent, (d - b) / normal.extent)
        per[k].append((max(c, a), min(d, b)))
    return per, worst


def _slip_intervals(zone: tuple[float, float], stick: list[tuple[float, float]]
                    ) -> tuple[tuple[float, float], ...]:
    a, b = zone
    cuts = [a] + [v for cd in stick for v in cd] + [b]
    tiny = 1e-13 * (b - a)
    return tuple((lo, hi) for lo, hi in zip(cuts[0::2], cuts[1::2], strict=True) if hi - lo > tiny)


# ---------------------------------------------------------------------------------------------
# quadrature: Gauss-Legendre in the angle of x = lo + (hi - lo)(1 - cos t)/2
# ---------------------------------------------------------------------------------------------
@lru_cache(maxsize=8)
def _legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def cosine_rule(lo: float, hi: float, n: int = QUAD_NODES) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on ``[lo, hi]`` for integrands with ``sqrt`` or ``1/sqrt`` end behaviour.

    With ``x = lo + (hi - lo)(1 - cos t)/2``, ``t in [0, pi]``, both ``sqrt(x - lo)`` and
    ``dx/sqrt(x - lo)`` are smooth in t, so Gauss-Legendre in t converges spectrally for the
    pressures, shears and gaps of this problem (contact and stick edges of either type).
    """
    u, w = _legendre(int(n))
    t = 0.5 * np.pi * (u + 1.0)
    half = 0.5 * (hi - lo)
    return lo + half * (1.0 - np.cos(t)), w * 0.5 * np.pi * half * np.sin(t)


def zone_rule(pts: np.ndarray, n: int = QUAD_NODES) -> tuple[np.ndarray, np.ndarray]:
    rules = [cosine_rule(lo, hi, n) for lo, hi in zip(pts[:-1], pts[1:], strict=True) if hi > lo]
    return np.concatenate([r[0] for r in rules]), np.concatenate([r[1] for r in rules])


# ---------------------------------------------------------------------------------------------
# building a state and checking it
# ---------------------------------------------------------------------------------------------
def checked_state(normal: NormalSolution, mu: float, Q: float, Q0: float | None,
           reduced: NormalSolution | None, P_red: float,
           previous: StickSolution | None) -> StickSolution:
    """The checked state (see :func:`unchecked_state`, :func:`check_states`)."""
    return check_states([unchecked_state(normal, mu, Q, Q0, reduced, P_red, previous)])[0]


def unchecked_state(normal: NormalSolution, mu: float, Q: float, Q0: float | None,
                     reduced: NormalSolution | None, P_red: float,
                     previous: StickSolution | None) -> StickSolution:
    if Q0 is None:
        stage, direction = 2, (1.0 if Q >= 0 else -1.0)
    else:
        stage, direction = 3, (-1.0 if Q0 >= 0 else 1.0)
    per, poke = _assign_stick(normal, reduced)
    return StickSolution(
        normal=normal, mu=mu, Q=Q, Q0=Q0, stage=stage, direction=direction, P_reduced=P_red,
        reduced=reduced,
        stick_zones=tuple((s[0][0], s[-1][1]) if s else None for s in per),
        stick_intervals=tuple(tuple(s) for s in per),
        slip_zones=tuple(_slip_intervals(z, s) for z, s in zip(normal.zones, per, strict=True)),
        full_slip_zones=tuple(k for k, s in enumerate(per) if not s),
        previous=previous, residuals={"containment": poke})


def _chain(sol: StickSolution) -> list[StickSolution]:
    out, s = [], sol
    while s is not None:
        out.append(s)
        s = s.previous
    return out


def check_states(states: list[StickSolution]) -> list[StickSolution]:
    """Self-check states sharing one stage-1 solution, each pressure evaluated once per batch.

    Coulomb's bound ``|q| <= mu p`` on nodes clustered at every edge and kink, and
    ``int q dx = Q`` from the zone loads of the normal solutions (exact contour integrals).
    """
    nrm = states[0].normal
    xs = [np.concatenate([zone_rule(breakpoints(s, k), CHECK_NODES)[0]
                          for k in range(nrm.n_zones)]) for s in states]
    cut = np.cumsum([0] + [x.size for x in xs])
    X = np.concatenate(xs)
    p = nrm.pressure(X)
    q = np.zeros(X.size)
    groups: dict[int, tuple[NormalSolution, list[tuple[slice, float]]]] = {}
    for i, s in enumerate(states):
        part = slice(cut[i], cut[i + 1])
        for m in _chain(s):
            q[part] += m.factor * m.mu * p[part]
            if m.reduced is not None:
                groups.setdefault(id(m.reduced), (m.reduced, []))[1].append((part, m.factor * m.mu))
    for red, parts in groups.values():
        p_s = red.pressure(np.concatenate([X[part] for part, _ in parts]))
        at = np.cumsum([0] + [part.stop - part.start for part, _ in parts])
        for j, (part, coef) in enumerate(parts):
            q[part] -= coef * p_s[at[j]:at[j + 1]]
    return [_verdict(s, p[cut[i]:cut[i + 1]], q[cut[i]:cut[i + 1]]) for i, s in enumerate(states)]


def _verdict(sol: StickSolution, p: np.ndarray, q: np.ndarray) -> StickSolution:
    nrm = sol.normal
    scale = sol.mu * nrm.P
    total = sum(m.factor * m.mu * (sum(nrm.zone_loads) -
                                   (sum(m.reduced.zone_loads) if m.reduced is not None else 0.0))
                for m in _chain(sol))
    res = {"friction": float(np.max(np.abs(q) - sol.mu * p)) / (scale / nrm.extent),
           "equilibrium": abs(total - sol.Q) / scale}
    if res["friction"] > FRICTION_TOL or res["equilibrium"] > EQUILIBRIUM_TOL:
        raise ConvergenceError(
            f"the Jager-Ciavarella state at Q={sol.Q:.6g} (stage {sol.stage}) violates "
            f"|q| <= mu p by {res['friction']:.3e} mu P/extent or int q = Q by "
            f"{res['equilibrium']:.3e} mu P: the reduced problem is not a stick state",
            {"residuals": res, "stick_zones": sol.stick_zones, "contact_zones": nrm.zones,
             "P_reduced": sol.P_reduced})
    return replace(sol, residuals={**sol.residuals, **res})


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------
def solve_stick(normal: NormalSolution, mu: float, Q: float, Q0: float | None = None, *,
                allow_full_slip: bool = False) -> StickSolution:
    """Stick zones, shear and slip at tangential load Q (paper Table 1 stages 2-3, Section 5).

    ``Q0=None``: stage 2, Q rose monotonically from 0 (``|Q| < mu P``).  ``Q0`` given: stage 3,
    Q rose to ``Q0`` (``|Q0| <= mu P``) and came back to ``Q`` (between ``-Q0`` and ``Q0``).
    ``|Q| = mu P`` (or ``Q = -Q0`` with ``|Q0| = mu P``) is gross sliding: an :class:`InputError`
    unless ``allow_full_slip=True``, which returns the full-slip state (all zones in
    ``full_slip_zones``, ``q = +-mu p``, slip ``nan``).  Raises :class:`ConvergenceError` if the
    state violates ``|q| <= mu p`` or ``int q = Q`` (see the module docstring).
    """
    check_normal(normal)
    mu = check_mu(mu)
    allow_full_slip = check.flag("allow_full_slip", allow_full_slip)
    limit = mu * normal.P
    if Q0 is None:
        Q = _check_tangential("Q", Q, limit, allow_full_slip)
        P_red = _stage2_load(normal.P, mu, Q)
        reduced = reduced_solutions(normal, np.array([P_red]))[0]
        return checked_state(normal, mu, Q, None, reduced, P_red, None)
    Q0 = _check_tangential("Q0", Q0, limit, True)
    Q = _check_stage3_load(Q, Q0)
    loads = np.array([_stage2_load(normal.P, mu, Q0), _stage3_load(normal.P, mu, Q, Q0)])
    if loads[1] <= GROSS_SLIP_REL * normal.P and not allow_full_slip:
        raise InputError(f"Q={Q!r} is not allowed: with |Q0| = mu P = {limit:.6g}, Q = -Q0 is "
                         "gross sliding (no stick zone); pass allow_full_slip=True for that state")
    red0, red = reduced_solutions(normal, loads)
    q0 = checked_state(normal, mu, Q0, None, red0, float(loads[0]), None)
    return checked_state(normal, mu, Q, Q0, red, float(loads[1]), q0)
