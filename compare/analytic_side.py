"""The analytic side of a case: normal solution at P and stick states at the sampled Q.

Stick zones come from ``analytic.solve_stick`` (Jaeger-Ciavarella with the stage-1 rotation
held fixed; a contact zone holding no zone of the reduced problem is in full slip).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

import analytic
from analytic import NormalSolution
from compare._memo import memo
from compare.cases import Case


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

    @property
    def samples(self) -> tuple[StickState, ...]:
        return self.stage2 + self.stage3


def solve_normal_case(case: Case) -> NormalSolution:
    """Stage-1 end state of the case (vertical indentation or applied moment)."""
    return analytic.solve_normal(case.profile, case.P, case.A, case.M)


def stick_solution(normal: NormalSolution, mu: float, Q: float, Q0: float | None = None
                   ) -> analytic.StickSolution:
    """``analytic.solve_stick(normal, mu, Q, Q0, allow_full_slip=True)``, solved once per normal
    solution and (mu, Q, Q0): the stress metrics need the same solutions as the stick states."""
    key = ("stick", float(mu), float(Q), None if Q0 is None else float(Q0))
    return memo(normal, key, lambda: analytic.solve_stick(normal, mu, Q, Q0,
                                                          allow_full_slip=True))


def stick_state(normal: NormalSolution, mu: float, Q: float, Q0: float | None = None
                ) -> StickState:
    """Analytic stick state at Q: stage 2 if ``Q0`` is None, else stage 3 coming from Q0."""
    sol = stick_solution(normal, mu, Q, Q0)
    sticks = tuple(None if z is None else (float(z[0]), float(z[1])) for z in sol.stick_zones)
    slip = tuple(i for i, s in enumerate(sticks) if s is None)
    return StickState(2 if Q0 is None else 3, float(Q), sticks, slip, sol.shear)


def solve_case(case: Case, normal: NormalSolution | None = None) -> AnalyticResult:
    """Normal solution and stick states at the case's sampled Q values."""
    normal = normal or solve_normal_case(case)
    s2 = tuple(stick_state(normal, case.mu, Q) for Q in case.stage2)
    s3 = tuple(stick_state(normal, case.mu, Q, case.Q0) for Q in case.stage3)
    return AnalyticResult(normal, s2, s3)
