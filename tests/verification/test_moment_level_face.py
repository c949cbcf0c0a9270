"""Moment mode with the load centre on the level flat face of a rounded punch
(analytic._applied_moment._from_level_face): the joint Newton from the overlap guess at the
face-alone rotation.  Audit seed 105672 (rounded punch beside two cylinders): the search from
theta = 0 met the level face touching along its whole length at once (3.2 s); from the face
rotation it is one guess and one joint Newton.  The result is judged by the audit's independent
quadratures of the returned pressure (loads, moment, rigid approach, p >= 0, gap >= 0)."""

from __future__ import annotations

import numpy as np

from analytic import _applied_moment
from analytic.normal import _finish
from compare.audit import cases, checks


def _level_face(seed: int):
    case = cases.make_case(seed)
    xe = case.M / case.P
    return case, _applied_moment._from_level_face(case.profile, case.P, case.A, case.M, xe)


def test_a_level_face_start_solves_the_moment_problem() -> None:
    case, found = _level_face(105672)
    assert found is not None
    st, sys_ = found
    sol = _finish(st, sys_, case.profile, case.A, "moment", case.M)
    assert not [f.line() for f in checks.quadrature_findings(sol) if f.failed]
    assert abs(sol.zone_loads[0] + sol.zone_loads[1] - case.P) < 1e-10 * case.P
    assert len(sol.zones) == 2 and sol.zones[0][0] < -0.9773 < sol.zones[0][1]  # past the face
    assert np.sign(sol.theta) == np.sign(case.M / case.P)  # tilted towards the load centre


def test_no_level_face_start_on_the_wrong_side() -> None:
    """Seed 103644: the face-alone rotation (+0.085) lies on the wrong side of the solution
    (-0.045: the cylinders take the moment); the guess there fails and the search runs as
    before instead of a full solve at that rotation (minutes)."""
    _, found = _level_face(103644)
    assert found is None
