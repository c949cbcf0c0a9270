"""Tangential loading stages of the independent discretised solver (:mod:`compare.bem`).

On a fixed discrete normal solution (:class:`compare.bem.BemNormal`, same panels and log
kernel) a monotonic tangential load is applied: stage 2 from zero shear, stage 3 from the
stage-2 end shear.

Tangential problem (uncoupled for similar materials), shear ``q`` on body 1 in the
direction of ``Q`` with ``∫ q dx = Q``::

    v(x) = -(A/pi) ∫ dq(s) ln(|x - s| / L) ds         elastic part of the relative slip
    s(x) = lam - v(x)                                 relative slip increment (body 1 - body 2)
    stick: s = 0, |q| <= mu p;   slip: q = mu p sign(s)

Solver: the box-constrained QP
``min 1/2 dq^T K dq  s.t.  |q0 + dq| <= mu p, dx sum dq = Q - Q0`` on the contact panels,
solved by the primal-dual active-set iteration of the normal problem (free set = stick, bound
sets = forward / backward slip). Stick edges come sub-panel from :func:`compare.bem.sqrt_edge`
on the margin ``mu p - |q| ~ sqrt(distance)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from compare.bem import MAX_ITER, BemNormal, check_positive, sqrt_edge

SLIP_TOL = 1e-11
"""Slip and friction-bound tolerance relative to ``A mu P`` and ``mu max p`` (roundoff of the
dense solve is ~1e-13 of these, as for ``compare.bem.GAP_TOL``)."""


@dataclass(frozen=True)
class BemShear:
    """Discrete tangential solution at the end of a loading stage (stage 2 or 3).

    Attributes:
        normal: the normal solution the shear lives on.
        mu: Coulomb friction coefficient.
        Q, Q_start: tangential force at the end / start of the stage (``Q_start = 0``
            and ``q_start = 0`` for stage 2).
        q: shear on body 1 in the direction of Q, ``dx sum q = Q``, ``|q| <= mu p``.
        stick: panels in stick during the stage (contact panels not at the bound).
        stick_zones: per contact zone ``(c, d)`` or None if the zone is in full slip.
        full_slip_zones: indices into ``normal.zones`` of zones without stick.
        slip: relative slip increment of body 1 w.r.t. body 2 accumulated during the
            stage, ``lam - K (q - q_start)``; 0 in stick and outside contact.
        shift: rigid tangential displacement increment ``lam`` of body 1 (log reference
            length ``L``).
        iterations: active-set iterations.
    """

    normal: BemNormal
    mu: float
    Q: float
    Q_start: float
    q: np.ndarray
    stick: np.ndarray
    stick_zones: tuple[tuple[float, float] | None, ...]
    full_slip_zones: tuple[int, ...]
    slip: np.ndarray
    shift: float
    iterations: int


def solve_tangential_bem(
    normal: BemNormal,
    mu: float,
    Q: float,
    *,
    q_start: np.ndarray | None = None,
    Q_start: float = 0.0,
) -> BemShear:
    """Solve one monotonic tangential loading stage on a fixed normal solution.

    Stage 2: ``q_start=None`` (zero shear), ``Q_start=0``, load to ``Q``. Stage 3: pass the
    stage-2 end shear ``q_start = q0`` and ``Q_start = Q0``. The increment ``dq = q - q0``
    solves ``min 1/2 dq^T K dq  s.t.  |q0 + dq| <= mu p,  dx sum dq = Q - Q_start``.
    Its optimality conditions are Coulomb's law for the stage: with the relative slip
    increment ``s = lam - K dq`` (``lam`` the multiplier of the force constraint = rigid
    shift), stick panels have ``s = 0`` and ``|q| <= mu p``; slip panels have
    ``q = mu p sign(s)`` (the shear carried by body 1 points along its slip, i.e. the
    friction on body 1 opposes it). Only the contact panels (``p > 0``) take part.

    Raises ValueError for ``mu <= 0``, ``|Q| >= mu P`` (gross sliding), an inadmissible
    or inconsistent ``q_start``; RuntimeError if the active set does not converge.
    """
    check_positive("mu", mu)
    if not (np.isfinite(Q) and abs(Q) < mu * normal.P):
        raise ValueError(
            f"Q={Q} is not allowed: need |Q| < mu P = {mu * normal.P:.6g} (gross sliding)"
        )
    q0 = _check_start(normal, mu, q_start, Q_start)
    idx = np.flatnonzero(normal.active)
    K = normal.grid.influence(normal.A)[np.ix_(idx, idx)]
    bound = mu * normal.p[idx]
    dq, stick, lam, iterations = _shear_active_set(
        K, normal.dx, bound, q0[idx], Q - Q_start, normal.A * mu * normal.P
    )
    return _assemble_shear(normal, mu, Q, Q_start, q0, idx, K, dq, stick, lam, iterations)


def _check_start(
    normal: BemNormal, mu: float, q_start: np.ndarray | None, Q_start: float
) -> np.ndarray:
    if q_start is None:
        if Q_start != 0.0:
            raise ValueError(f"Q_start={Q_start} is not allowed without q_start: need 0.0")
        return np.zeros(normal.grid.n)
    q0 = np.asarray(q_start, dtype=float)
    if q0.shape != (normal.grid.n,):
        raise ValueError(f"q_start has shape {q0.shape}: need ({normal.grid.n},)")
    excess = np.abs(q0) - mu * normal.p
    if np.any(excess > SLIP_TOL * mu * normal.p.max()):
        raise ValueError(f"q_start violates |q| <= mu p by {excess.max():.3e}")
    total = normal.dx * q0.sum()
    if abs(total - Q_start) > 1e-9 * mu * normal.P:
        raise ValueError(f"Q_start={Q_start} is not dx sum q_start = {total:.12g}")
    return q0


def _shear_active_set(
    K: np.ndarray, dx: float, bound: np.ndarray, q0: np.ndarray, dQ: float, scale: float
) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Active set for the box QP on the contact panels.

    Sets: stick (free), forward slip (``q = +bound``), backward slip (``q = -bound``).
    Stick panels whose shear exceeds the bound move to slip; slip panels whose slip
    increment ``s = lam - K dq`` has the wrong sign move to stick.
    """
    state = np.zeros(bound.size, dtype=np.int8)  # 0 stick, +1 / -1 slip at +-bound
    seen: set[bytes] = set()
    qtol = SLIP_TOL * bound.max()
    stol = SLIP_TOL * scale
    for iteration in range(1, MAX_ITER + 1):
        dq, lam = _shear_equality_solve(K, dx, bound, q0, dQ, state)
        q = q0 + dq
        s = lam - K @ dq
        new = state.copy()
        new[(state == 0) & (q > bound + qtol)] = 1
        new[(state == 0) & (q < -bound - qtol)] = -1
        new[(state == 1) & (s < -stol)] = 0
        new[(state == -1) & (s > stol)] = 0
        if not np.any(new == 0):
            new[np.argmax(bound)] = 0
        if np.array_equal(new, state):
            return dq, state == 0, lam, iteration
        key = new.tobytes()
        if key in seen:
            raise RuntimeError(f"tangential active set cycles at iteration {iteration}")
        seen.add(key)
        state = new
    raise RuntimeError(f"tangential active set did not converge in MAX_ITER={MAX_ITER}")


def _shear_equality_solve(
    K: np.ndarray, dx: float, bound: np.ndarray, q0: np.ndarray, dQ: float, state: np.ndarray
) -> tuple[np.ndarray, float]:
    """Slip panels at their bound, stick panels from ``K_FF dq_F = lam - K_FB dq_B`` with
    ``dx sum dq = dQ``."""
    free = state == 0
    dq = np.where(free, 0.0, state * bound - q0)
    r = K[np.ix_(free, ~free)] @ dq[~free]
    factor = sla.cho_factor(K[np.ix_(free, free)], lower=True)
    z = sla.cho_solve(factor, np.column_stack([np.ones(int(free.sum())), r]))
    lam = (dQ / dx - dq[~free].sum() + z[:, 1].sum()) / z[:, 0].sum()
    dq[free] = lam * z[:, 0] - z[:, 1]
    return dq, float(lam)


def _assemble_shear(
    normal: BemNormal, mu: float, Q: float, Q_start: float, q0: np.ndarray, idx: np.ndarray,
    K: np.ndarray, dq: np.ndarray, stick_c: np.ndarray, lam: float, iterations: int,
) -> BemShear:
    n = normal.grid.n
    q = q0.copy()
    q[idx] += dq
    stick = np.zeros(n, dtype=bool)
    stick[idx] = stick_c
    slip = np.zeros(n)
    slip[idx] = np.where(stick_c, 0.0, lam - K @ dq)
    smooth = np.abs(q0) >= mu * normal.p * (1 - SLIP_TOL) if np.any(q0) else np.ones(n, bool)
    zones = tuple(
        _stick_zone(normal, k, stick, q, mu, smooth) for k in range(len(normal.zones))
    )
    return BemShear(
        normal=normal, mu=mu, Q=Q, Q_start=Q_start, q=q, stick=stick, stick_zones=zones,
        full_slip_zones=tuple(k for k, z in enumerate(zones) if z is None), slip=slip,
        shift=lam, iterations=iterations,
    )


def _stick_zone(
    normal: BemNormal, k: int, stick: np.ndarray, q: np.ndarray, mu: float, smooth: np.ndarray
) -> tuple[float, float] | None:
    """Stick zone ``(c, d)`` in contact zone ``k``: the hull of its stick panels.

    An edge whose stick panel is the zone's end panel is the contact edge. Otherwise
    :func:`sqrt_edge` on the margin ``mu p - sigma q``, ``sigma`` the slip direction of
    the neighbouring slip panel (equal to ``mu p - |q|`` near the edge, but smooth: in
    stage 3 ``|q|`` has a kink where ``q`` changes sign inside the stick zone). The fit
    uses only the panels from the edge inward on the same side of the old stick edge
    (``smooth`` = slipping at the start of the stage; the old stick edge puts a sqrt kink
    into ``q``).
    """
    i0, i1 = normal.zone_panels[k]
    where = np.flatnonzero(stick[i0:i1 + 1]) + i0
    if where.size == 0:
        return None
    j0, j1 = int(where[0]), int(where[-1])
    c = normal.zones[k][0] if j0 == i0 else _stick_edge(normal, q, mu, smooth, j0, j1)
    d = normal.zones[k][1] if j1 == i1 else _stick_edge(normal, q, mu, smooth, j1, j0)
    return (float(c), float(d))


def _stick_edge(
    normal: BemNormal, q: np.ndarray, mu: float, smooth: np.ndarray, edge: int, other: int
) -> float:
    """Stick edge next to panel ``edge`` (the run of stick panels goes to ``other``)."""
    step = 1 if other >= edge else -1
    run = np.arange(edge, other + step, step)
    cut = np.flatnonzero(smooth[run] != smooth[edge])
    run = run[: max(int(cut[0]) if cut.size else run.size, 1)]
    sigma = np.sign(q[edge - step])
    return sqrt_edge(normal.x[run], mu * normal.p[run] - sigma * q[run], normal.dx)
