"""Accuracy next to kinks of h0 (audit of the fixed solver, 500 cases: the 10 disagreements).

- The deformed gap away from a zone whose edge lies just past a kink (a parabolic corner's
  start 2e-4 inside the zone): the gap integrals from that edge were sized on the distance to
  the next edge (0.95), not to the kink, and ``gap(x)`` drifted 1e-3 A P off over a distance 1
  (audit seeds 6, 48, 128, 140, 270, 282, 410, 423: gap_consistency).
- The pressure a distance d < 1e-12 (zone widths) from a wedge's apex: it was taken as at the
  apex (no log term), 0.35 mu p short of the shear of a stick state (seeds 372, 446:
  stick_friction).  It is ``p ~ -(Delta h' / (pi A)) ln d`` down to d of a few ulps.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

import analytic
from analytic import profiles

GAP_REF_RTOL = 1e-8
"""|gap(x) - recomputed| / (A P): adaptive quadrature of the log potential (~1e-12 A P)."""
LOG_SLOPE_RTOL = 1e-6
"""The apex's log coefficient from p at d = 1e-6 .. 1e-15 (the next terms are O(d ln d)) ..."""
ROUNDING_ULPS = 4.0
"""... plus the rounding of x: ~c ulp(x) / d (measured 0.8 c ulp / d at d = 1e-13)."""


@pytest.mark.slow
def test_gap_far_from_a_zone_with_a_kink_just_inside() -> None:
    """Audit seed 6: a parabolic-cornered punch beside a cylinder at light load (slow: adaptive
    quadrature, 14 s; the default suite has seed 6 in the audit's fast sample)."""
    prof = profiles.union(
        profiles.flat_punch(-0.4746166958506708, 0.4746166958506708,
                            corner_radius=0.10371492266307131, lift=0.009874449901864667,
                            corner_shape="parabolic"),
        profiles.cylinder(0.6413346581382645, -1.6875203351191344, 0.013598353223280447))
    P, A = 4.119664740257873e-05, 1.0
    sol = analytic.solve_normal(prof, P, A)
    (a, b), = sol.zones
    kinks = [q for q in prof.kinks if a < q < b]

    def u(x: float) -> float:  # -(A/pi) int p ln|x - s| ds, adaptive
        pts = kinks + ([x] if a < x < b else [])
        return -A / np.pi * quad(lambda s: float(sol.pressure(s)) * np.log(abs(x - s)), a, b,
                                 points=pts, limit=400, epsabs=0.0, epsrel=1e-13)[0]

    mid = 0.5 * (a + b)
    x = np.array([0.6, 1.0, 1.5, -1.0, -1.6875203351191344])
    ref = prof.h0(x) - float(prof.h0(np.array([mid]))[0]) + np.array([u(v) for v in x]) - u(mid)
    assert np.max(np.abs(sol.gap(x) - ref)) < GAP_REF_RTOL * A * P


def test_pressure_at_a_wedge_apex_is_log_singular_to_ulps() -> None:
    """Audit seed 372's wedge: p grows like ``-(Delta h' / (pi A)) ln d`` on both sides, down to
    d = 1e-15 (the audit saw d = 1.3e-12 taken as d = 0)."""
    left, right, apex = 0.24368911226849926, 0.107840696058284, -0.18042970842457529
    sol = analytic.solve_normal(profiles.wedge(left, right, apex=apex), 0.13, 1.0)
    d = 10.0 ** -np.arange(6.0, 16.0)
    c = (np.tan(left) + np.tan(right)) / np.pi
    for side in (-1.0, 1.0):
        x = apex + side * d
        p = sol.pressure(x)
        dist = np.abs(x - apex)  # as represented (1e-15 rounds by 3 %)
        expected = -c * np.diff(np.log(dist))
        # x itself rounds: the divided differences across the apex carry c ulp(x) / d
        rounding = ROUNDING_ULPS * c * np.spacing(abs(apex)) / dist[1:]
        assert np.all(np.abs(np.diff(p) - expected) <= LOG_SLOPE_RTOL * expected + rounding)


def test_stick_shear_within_friction_next_to_the_apex() -> None:
    """Audit seed 372: a stage-2 stick state on the wedge, |q| <= mu p at the apex +- d."""
    from compare.audit import cases

    case = cases.make_case(372)
    normal = analytic.solve_normal(case.profile, case.P, case.A, case.M)
    st = analytic.solve_stick(normal, case.mu, case.Q, case.Q0)
    apex = case.profile.kinks[0]
    x = apex + np.array([-1.0, 1.0])[:, None] * 10.0 ** -np.arange(3.0, 15.0)[None, :]
    p, q = normal.pressure(x.ravel()), st.shear(x.ravel())
    assert np.all(np.abs(q) <= case.mu * p * (1 + 1e-9))
