"""Where the tractions of a contact zone stop being smooth: the breakpoints of its quadratures.

The pressure is log-singular at a profile kink inside a zone, and a stick solution's shear has a
square-root end at every stick edge of its stage and of the stages before it.  Quadratures of
the tractions (the stick module's self-checks and dissipation, the stresses of
:mod:`analytic.stress`) cut every zone at these points.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from analytic.profiles import Profile

if TYPE_CHECKING:  # annotations only: analytic.stick imports this module
    from analytic.stick import StickSolution


def split_at_kinks(profile: Profile, lo: float, hi: float) -> np.ndarray:
    """``[lo, hi]`` cut at the profile kinks inside (the pressure is log-singular there)."""
    return np.asarray([lo, *(v for v in profile.kinks if lo < v < hi), hi], float)


def breakpoints(sol: StickSolution, k: int) -> np.ndarray:
    """Contact edges, profile kinks and every stick edge (this and earlier stages) in zone k."""
    pts = list(split_at_kinks(sol.normal.profile, *sol.normal.zones[k]))
    s: StickSolution | None = sol
    while s is not None:
        pts += [v for cd in s.stick_intervals[k] for v in cd]
        s = s.previous
    return np.unique(np.asarray(pts, float))
