"""Analytic singular-integral solution of plane frictional multiple contact.

Conventions (see README): p >= 0 compressive, A = 4(1 - nu^2)/E, forces per unit width,
M = int x p dx about x = 0.  Entry points: :func:`solve_normal`, :func:`load_curve`,
:mod:`analytic.profiles`, :func:`stress` (the field in body 2).
"""

from analytic import profiles
from analytic.errors import ConvergenceError, InputError
from analytic.fretting import CycleResult, cycle
from analytic.normal import (
    NormalSolution,
    load_curve,
    solve_normal,
    solve_normal_fixed_rotation,
)
from analytic.overlap import Fig5Data, OverlapSolution, fig5_data, overlapped
from analytic.stick import StickSolution, solve_stick
from analytic.stress import RuizResult, StressField, ruiz, stress, surface_stress

__all__ = [
    "ConvergenceError",
    "CycleResult",
    "Fig5Data",
    "OverlapSolution",
    "fig5_data",
    "overlapped",
    "InputError",
    "NormalSolution",
    "StickSolution",
    "cycle",
    "load_curve",
    "profiles",
    "RuizResult",
    "StressField",
    "ruiz",
    "stress",
    "surface_stress",
    "solve_normal",
    "solve_normal_fixed_rotation",
    "solve_stick",
]
