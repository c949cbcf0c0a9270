"""Moment mode where the cheap starts fail at the initial rotation but solve on both sides of it
(audit seed 112425: a parabolic-cornered punch beside two cylinders, M/P on the punch's face).

The overlap guess and the warm start fail at theta0 = 0; the guess solves at theta0 -+ step
with moments either side of M.  The search used to solve theta0 in full anyway (the
continuation from the first touch, 2.6 s of the 4.4 s, four zones) and the joint Newton from
there failed; the two probes are now the bracket (2.6 s in all; the first-touch continuation
runs once, at a rotation Brent asks for, not at theta0).
"""

from __future__ import annotations

import pytest

import analytic
from analytic import _applied_moment
from compare.audit import cases, checks

SEED = 112425
THETA = 0.08445856322114
"""The solution's rotation (on the solver before the change: 0.08445856322114019)."""


@pytest.fixture(scope="module")
def case():
    return cases.make_case(SEED)


def test_the_probes_bracket_the_moment_without_a_full_solve_at_theta0(case, monkeypatch
                                                                       ) -> None:
    """The first-touch continuation never runs at theta0 = 0, the answer is the same (three
    zones: two on the cylinders, one on the punch), and the audit's quadratures agree."""
    seen = []
    first_touch = _applied_moment.solve_from_first_touch

    def spy(profile, P, A, theta):
        seen.append(theta)
        return first_touch(profile, P, A, theta)

    monkeypatch.setattr(_applied_moment, "solve_from_first_touch", spy)
    sol = analytic.solve_normal(case.profile, case.P, case.A, case.M)
    assert 0.0 not in seen and len(seen) <= 1
    assert sol.theta == pytest.approx(THETA, abs=1e-12)
    assert len(sol.zones) == 3 and sol.zones[-1][0] < 0.0 < sol.zones[-1][1]
    assert not [f.line() for f in checks.quadrature_findings(sol) if f.failed]


def test_no_probe_bracket_where_the_guess_solves_at_theta0(case) -> None:
    """Where a cheap start solves at theta0 there is nothing to bracket around it."""
    rot = _applied_moment._Rotations(case.profile, case.P, case.A)
    assert _applied_moment._probe_bracket(rot, case.M, 0.0, 0.540681) == pytest.approx(
        (-0.540681, 0.540681))
    rot.solved[0.0] = rot.solved[-0.540681]
    assert _applied_moment._probe_bracket(rot, case.M, 0.0, 0.540681) is None
