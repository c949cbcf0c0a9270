"""Where moment mode's search starts (analytic._applied_moment._search_starts), issue 29.

Audit seed 103644 (a rounded punch beside two cylinders, ridges of the union at 2.0049 and
2.2304, the load centre on the punch's flat face): the overlap guess fails at the initial
rotation theta = 0, where the untilted union's continuation from the first touch crowds both
notches (6 s of the 11.6 s the search took), but solves at the bracket's first step below,
-0.196, whose moment asks for a larger rotation.  The joint Newton from there (one solve, no
topology event) fails; the warm start at their midpoint, -0.098, solves, and the joint Newton
converges from there to -0.04458: no continuation from the first touch at all.  The result is
judged by the audit's independent quadratures of the returned pressure (loads, moment, rigid
approach, p >= 0, gap >= 0).
"""

from __future__ import annotations

from collections import Counter

import pytest

import analytic
from analytic import _applied_moment
from compare.audit import cases, checks

THETA = -0.044577781106047334
"""The rotation the search from theta = 0 found (ce828ca); the two paths agree to ~2e-13."""


@pytest.fixture(scope="module")
def case():
    return cases.make_case(103644)


def test_no_continuation_from_the_first_touch(case, monkeypatch) -> None:
    guesses: Counter = Counter()
    first_touch: list[float] = []
    guess = _applied_moment.solve_from_guess

    def counted_guess(profile, P, A, theta):
        guesses[theta] += 1
        return guess(profile, P, A, theta)

    def no_first_touch(profile, P, A, theta):
        first_touch.append(theta)
        raise AssertionError(f"continuation from the first touch at theta = {theta}")

    monkeypatch.setattr(_applied_moment, "solve_from_guess", counted_guess)
    monkeypatch.setattr(_applied_moment, "solve_from_first_touch", no_first_touch)
    sol = analytic.solve_normal(case.profile, case.P, case.A, M=case.M)
    assert first_touch == []
    assert max(guesses.values()) == 1  # a failed guess is not retried at the same rotation
    assert sol.theta == pytest.approx(THETA, abs=1e-12)
    assert len(sol.zones) == 3 and sol.zones[1][1] < 2.2304209731041116 < sol.zones[2][0]
    assert not [f.line() for f in checks.quadrature_findings(sol) if f.failed]


def test_the_search_starts_between_the_guess_and_the_initial_rotation(case) -> None:
    rot = _applied_moment._Rotations(case.profile, case.P, case.A)
    step = 0.25 * (case.A * case.P / case.profile.scale + 1e-12)  # the bracket's first step
    starts = list(_applied_moment._search_starts(rot, case.M, 0.0, step))
    assert starts == [(-step, 1), (-0.5 * step, _applied_moment.MAX_TOPOLOGY_CHANGES)]
    assert 0.0 in rot.no_guess and sorted(rot.solved) == [-step, -0.5 * step]  # none at 0
    assert rot.solved[-step][2] < case.M  # the moment there asks for a larger rotation
