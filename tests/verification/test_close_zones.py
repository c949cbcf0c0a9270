"""Two contact zones much closer to each other than their widths (audit seed 106705: a sharp
flat punch beside two cylinders, vertical, P = 0.96; the cylinders' zones 0.42 and 0.45 wide
are 1.4e-5 apart across the ridge where the cylinders meet).

``omega = 1/W`` on each zone carries the facing edge's factor ``|s - e|^(+-1/2)``, which varies
on the scale of the gap.  One Gauss-Jacobi rule per zone needs ``32 + 14 sqrt(width / gap)``
nodes (2440 here) and was capped at MAX_NODES = 640: Newton converged (residuals 1e-12) on
under-resolved equations, zone loads 5.8e-9 P off, and the self-check refused the rigid
approach spread 2.01e-8 A P (tolerance 2e-8).  The zone is now graded towards an edge whose
neighbour is that close (like towards a kink with a close cut beyond): 1184 nodes on the two
zones, and the solution agrees with one uncapped Gauss-Jacobi rule per zone.
"""

from __future__ import annotations

import numpy as np
import pytest

import analytic
from analytic import _rules, _zone_quadrature
from analytic._layout import Layout
from analytic.selfcheck import APPROACH_TOL, LOAD_TOL
from compare.audit import cases, checks

SEED = 106705
GAP = 1.43e-5
"""The gap between the cylinders' zones (1.4289e-5)."""


@pytest.fixture(scope="module")
def case():
    return cases.make_case(SEED)


@pytest.fixture(scope="module")
def solution(case):
    return analytic.solve_normal(case.profile, case.P, case.A)


def test_close_zones_solve_with_a_margin_on_the_self_check(case, solution) -> None:
    """Three zones (two free-edged on the cylinders, the punch pinned at its corners); the
    self-check's approach spread (2.01e-8 A P before) and load figures are 1/50 of their
    tolerances, and the audit's independent quadratures agree."""
    z = solution.zones
    assert solution.singular == [(False, False), (False, False), (True, True)]
    assert z[1][0] - z[0][1] == pytest.approx(GAP, rel=0.01)
    assert solution.residuals["selfcheck_approach"] < APPROACH_TOL / 50
    assert solution.residuals["selfcheck_load"] < LOAD_TOL / 50
    found = checks.quadrature_findings(solution)
    assert found and not [f.line() for f in found if f.failed]


def test_zone_rule_is_graded_towards_the_close_neighbour(solution) -> None:
    """No panel of the zone rule sits at MAX_NODES (two did); the cylinders' zones are graded
    towards their facing edges (a panel one gap long at each: >= 40 nodes within a gap of the
    edge, where the capped rule had 2), the punch's zone (0.42 from its neighbour) is one panel,
    and the two graded zones take fewer nodes than the two capped rules did."""
    edges = np.array([e for zone in solution.zones for e in zone])
    lay = Layout(edges, np.array([s for pair in solution.singular for s in pair]))
    plan = _zone_quadrature.squad_plan(lay, solution.profile)
    assert max(plan.counts) < _rules.MAX_NODES
    assert plan.counts[-1] == _rules.nodes_for(edges[5] - edges[4], edges[4] - edges[3])
    assert sum(plan.counts[:-1]) < 2 * _rules.MAX_NODES
    s = _zone_quadrature.squad_nodes(plan, solution.profile, edges[None, :], 0.0,
                                     np.zeros(1)).s[0]
    for edge in edges[1:3]:
        assert np.count_nonzero(np.abs(s - edge) < GAP) >= 40


def test_graded_rule_agrees_with_one_uncapped_rule_per_zone(case, solution, monkeypatch
                                                            ) -> None:
    """With MAX_NODES raised to 4096 no zone is graded (one Gauss-Jacobi rule of 2440 / 2504
    nodes each): zone loads and edges agree with the graded rule's (measured 5.5e-12 P and
    6.9e-13 of the zone width; Newton's residuals are ~1e-12).  With the old cap of 640 on one
    rule per zone the loads were 5.8e-9 P off."""
    monkeypatch.setattr(_rules, "MAX_NODES", 4096)
    ref = analytic.solve_normal(case.profile, case.P, case.A)
    widths = np.diff(np.array(ref.zones), axis=1).ravel()
    assert np.max(np.abs(np.array(solution.zone_loads) - ref.zone_loads)) < 3e-11 * case.P
    assert np.all(np.abs(np.array(solution.zones) - ref.zones).max(axis=1) < 1e-11 * widths)
