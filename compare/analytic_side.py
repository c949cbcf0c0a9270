"""The analytic side of a case: normal solution at P and stick states at the sampled Q.

Stick zones use ``analytic.solve_stick`` when the analytic package provides it; otherwise the
Jaeger-Ciavarella superposition of DESIGN.md is built here from the normal solver with the
stage-1 rotation held fixed (``analytic.solve_normal_fixed_rotation``):

    stage 2:  q = mu [p(x; P0) - p_S(x; P*)],               P*  = P0 - Q / mu
    stage 3:  q = q0 - 2 mu [p(x; P0) - p_S(x; P**)],       P** = P0 - (Q0 - Q) / (2 mu)

with p_S the normal solution at the reduced load whose zones are the stick zones.  A contact
zone holding no zone of p_S is in full slip.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import analytic
from analytic import NormalSolution
from compare.cases import Case

#: Reduced loads below this fraction of P0 are treated as zero (the whole contact slips).
FULL_SLIP_FRACTION = 1e-9


@dataclass(frozen=True)
class StickState:
    """Analytic stick state at one sampled Q.

    stage: 2 or 3; Q: tangential load; stick_zones: one ``(c, d)`` or None (full slip) per
    contact zone of the normal solution; full_slip: indices of the zones in full slip;
    shear: callable ``q(x)`` (shear on body 1 in the direction of Q, ``int q dx = Q``).
    """

    stage: int
    Q: float
    stick_zones: tuple
    full_slip: tuple[int, ...]
    shear: Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class AnalyticResult:
    """Analytic solution of a case: the stage-1 end state and stick states at the samples."""

    normal: NormalSolution
    stage2: tuple[StickState, ...]
    stage3: tuple[StickState, ...]
    solver: str  # 'analytic.solve_stick' or 'compare (Jaeger-Ciavarella fallback)'

    @property
    def samples(self) -> tuple[StickState, ...]:
        return self.stage2 + self.stage3


def solve_normal_case(case: Case) -> NormalSolution:
    """Stage-1 end state of the case (vertical indentation or applied moment)."""
    return analytic.solve_normal(case.profile, case.P, case.A, case.M)


def _reduced(normal: NormalSolution, P_red: float) -> NormalSolution | None:
    if P_red <= FULL_SLIP_FRACTION * normal.P:
        return None
    if abs(P_red - normal.P) <= 1e-12 * normal.P:
        return normal
    return analytic.solve_normal_fixed_rotation(normal.profile, P_red, normal.A, normal.theta)


def _assign(normal: NormalSolution, reduced: NormalSolution | None) -> tuple:
    """One stick zone (or None) per contact zone: the reduced zones lying inside it."""
    out = []
    for a, b in normal.zones:
        inside = [] if reduced is None else [
            z for z in reduced.zones if z[0] >= a - 1e-9 * (b - a) and z[1] <= b + 1e-9 * (b - a)]
        out.append((min(z[0] for z in inside), max(z[1] for z in inside)) if inside else None)
    return tuple(out)


def _fallback_state(normal: NormalSolution, mu: float, Q: float, Q0: float | None,
                    stage: int) -> StickState:
    if stage == 2:
        red = _reduced(normal, normal.P - Q / mu)

        def shear(x, red=red):
            ps = 0.0 if red is None else red.pressure(x)
            return mu * (normal.pressure(x) - ps)
    else:
        end = _fallback_state(normal, mu, Q0, None, 2)
        red = _reduced(normal, normal.P - (Q0 - Q) / (2 * mu))

        def shear(x, red=red, q0=end.shear):
            ps = 0.0 if red is None else red.pressure(x)
            return q0(x) - 2 * mu * (normal.pressure(x) - ps)
    sticks = _assign(normal, red)
    slip = tuple(i for i, s in enumerate(sticks) if s is None)
    return StickState(stage, float(Q), sticks, slip, shear)


def _native_state(normal: NormalSolution, mu: float, Q: float, Q0: float | None,
                  stage: int) -> StickState:
    sol = analytic.solve_stick(normal, mu, Q, Q0, allow_full_slip=True)
    sticks = tuple(None if z is None else (float(z[0]), float(z[1])) for z in sol.stick_zones)
    slip = tuple(i for i, s in enumerate(sticks) if s is None)
    return StickState(stage, float(Q), sticks, slip, sol.shear)


def stick_state(normal: NormalSolution, mu: float, Q: float, Q0: float | None = None
                ) -> StickState:
    """Analytic stick state at Q: stage 2 if ``Q0`` is None, else stage 3 coming from Q0."""
    stage = 2 if Q0 is None else 3
    if hasattr(analytic, "solve_stick"):
        return _native_state(normal, mu, Q, Q0, stage)
    return _fallback_state(normal, mu, Q, Q0, stage)


def stick_solver_name() -> str:
    """Which implementation computes the stick zones."""
    return ("analytic.solve_stick" if hasattr(analytic, "solve_stick")
            else "compare (Jaeger-Ciavarella fallback)")


def solve_case(case: Case, normal: NormalSolution | None = None) -> AnalyticResult:
    """Normal solution and stick states at the case's sampled Q values."""
    normal = normal or solve_normal_case(case)
    s2 = tuple(stick_state(normal, case.mu, Q) for Q in case.stage2)
    s3 = tuple(stick_state(normal, case.mu, Q, case.Q0) for Q in case.stage3)
    return AnalyticResult(normal, s2, s3, stick_solver_name())


def stick_cycle(case: Case, normal: NormalSolution, n: int = 24) -> list[StickState]:
    """Stick states along the whole tangential cycle (n points per stage) for plots."""
    if case.Q0 == 0:
        return []
    q2 = np.linspace(0.0, case.Q0, n + 1)[1:]
    q3 = np.linspace(case.Q0, -case.Q0, 2 * n + 1)[1:]
    return ([stick_state(normal, case.mu, float(q)) for q in q2]
            + [stick_state(normal, case.mu, float(q), case.Q0) for q in q3])
