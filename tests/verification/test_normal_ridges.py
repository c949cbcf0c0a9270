"""Contact zones next to ridges of a union of cylinders (where two members meet, h0 has a
concave kink: a zone cannot span it, and the deformed gap has a local maximum there).

The case is the one failure of the random stress test of unions of 1-3 cylinders: a zone is
born on the middle member just left of a ridge.  Between the last g' sample before the ridge
and the ridge, g' turned positive (a minimum of g) and dropped back below zero across the
ridge, so no sign change was seen: the continuation accepted inadmissible two-zone states
(g = -4.8e-4 at P = 0.2887) and then added the zone far too wide, and the applied-moment
solve raised ConvergenceError after ~75 s.
"""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import profiles
from compare.bem import solve_normal_bem

MEMBERS = [(2.2214403016677178, -1.8382833517217814, 0.043601788401233146),
           (1.0338133265473761, 2.4804895247794008, 0.03324841935181864),
           (2.800589487036358, 2.831484488484085, 0.0022364510372928138)]
"""(R, centre, lift): stress case 96 (rng seed 1)."""
P_CASE, M_CASE = 0.29005049366181523, 0.5868226579276996
THETA_NEAR_BIRTH = -0.03563785633359021  # a rotation the moment search visits
P_NEAR_BIRTH = 0.281  # just above the load where the middle zone is born at that rotation
SIGN_TOL = 1e-9
"""g >= -SIGN_TOL * A * P: the solver's admissibility tolerance."""
BEM_THETA_TOL = 1e-6
"""|theta_analytic - theta_BEM| at N = 2048 (the BEM rotation converges at first order:
5e-8 off at N = 2048, 1e-8 at N = 4096)."""


@pytest.fixture(scope="module")
def union3() -> profiles.Profile:
    return profiles.union(*[profiles.cylinder(R, center=c, lift=h) for R, c, h in MEMBERS])


def test_zone_born_next_to_a_ridge_is_found(union3) -> None:
    """The middle member touches just left of the ridge at x = 2.3875: three zones, and the
    deformed gap is non-negative across the middle member (it was -6.2e-5 with two zones)."""
    lo, hi = union3.ridges[1:]  # the middle member's stretch of h0
    sol = analytic.solve_normal_fixed_rotation(union3, P_NEAR_BIRTH, 1.0, THETA_NEAR_BIRTH)
    assert sol.n_zones == 3
    a, b = sol.zones[1]
    assert lo < a < b < hi
    x = np.linspace(lo, hi, 120)
    x = x[(x < a) | (x > b)]
    assert sol.gap(x).min() >= -SIGN_TOL * P_NEAR_BIRTH


@pytest.mark.slow
def test_applied_moment_with_a_zone_between_ridges(union3) -> None:
    """Stress case 96 in applied-moment mode (~10 s): the rotation agrees with the independent
    BEM solve, and the analytic solution resolves the narrow gap at the ridge."""
    sol = analytic.solve_normal(union3, P_CASE, 1.0, M_CASE)
    bem = solve_normal_bem(union3, (-4.0, 5.0), 2048, P_CASE, 1.0, M=M_CASE)
    assert abs(sol.theta - bem.theta) < BEM_THETA_TOL
    assert sol.n_zones == 3 and sol.zones[1][1] < union3.ridges[2] < sol.zones[2][0]
    r = sol.residuals
    assert r["equations"] < 1e-9 and r["equilibrium"] < 1e-9
    assert r["min_pressure"] >= -SIGN_TOL and r["min_gap"] >= -SIGN_TOL * P_CASE
