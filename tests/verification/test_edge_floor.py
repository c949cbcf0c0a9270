"""The O(h) floor of the FE edges on cattaneo (issue 28): the FE smears a sqrt edge over its outer
~4 nodes, and a quadratic through nodes 3-7 extrapolated that tail to the edge, 0.017-0.036
element at every level, so the stick-edge error stalled from level 3 (4.9e-5 / 4.1e-5 / 2.6e-5 of
the width at levels 3 / 4 / 5, rings).  The edge estimators now fit a band of up to
fem.results.EDGE_FIT_MAX (pressure side) / GAP_FIT_MAX (gap side) nodes on long runs, and the
errors keep falling through level 4 (README, the ring-mesh table).  Ring layout, the library
case's growth.  The floor is the estimators': it shows against plain Q1, whose level-3 FE error
is far below it (its grading stiffness cancels part of the contact's own widening); with the
incompatible modes (the default elements) the FE's own error at level 3 is 0.011 / 0.017
element, at the old floor, so the estimator test runs on plain Q1 and the default elements get
their own convergence test."""

import numpy as np
import pytest

from compare.analytic_side import solve_case
from compare.cases import load_case
from compare.fem_side import kinks, run_fem
from compare.metrics import observed_order, regular_mask, singular_points
from compare.run import normal_metrics, sample_metrics

#: Contact / stick edge errors in elements at level 3: below the old estimators' floor (0.013 /
#: 0.017 element); measured 0.0014 / 0.011.
LEVEL3_EDGE_ELEMENTS, LEVEL3_STICK_ELEMENTS = 0.005, 0.014
#: Issue 28's level-4 accuracy target, edge and stick (of the width); measured 2.8e-6 / 1.1e-5
#: (plain Q1), 1.45e-5 / 1.8e-5 (incompatible modes).
LEVEL4_ACCURACY = 2e-5
#: Observed order of the edge and stick errors over levels 2-4 (least squares), per element
#: (incompatible modes?): plain Q1 measured 2.5 / 2.1 (8.7e-5 / 3.9e-6 / 2.8e-6 and 2.1e-4 /
#: 3.1e-5 / 1.1e-5; with the old estimators 1.0 / 1.2, and 0.27 for the stick edge from level
#: 3 to 4); with the modes 1.0 / 1.5 (5.9e-5 / 3.1e-5 / 1.45e-5 and 1.5e-4 / 4.9e-5 / 1.8e-5:
#: the free edge error's order 1, the phase's, no cancellation helping it).
MIN_ORDER = {False: 1.5, True: 0.8}


def errors(level: int, incompatible: bool = False) -> tuple[float, float, float, float]:
    """(edge, stick, edge in elements, stick in elements) of cattaneo on rings at ``level``
    (plain Q1 unless ``incompatible``)."""
    case = load_case("cattaneo").with_fem(layout="rings", level=level, incompatible=incompatible)
    an = solve_case(case)
    hist = run_fem(case, an.normal)
    end = hist.stage(1)[-1]
    m, _ = normal_metrics(case, an, end)
    ns = an.normal
    keep = regular_mask(end.interface.x, ns.zones,
                        singular_points(ns.zones, ns.singular, kinks(case)))
    ms, _ = sample_metrics(case, an, hist, keep)
    return (m["edge_error_max"], ms["stick_edge_error_max"], m["edge_error_max_elements"],
            ms["stick_edge_error_max_elements"])


def test_level3_edges_below_the_old_floor():
    edge, stick, edge_el, stick_el = errors(3)
    print(f"level 3: edge {edge:.2e} ({edge_el:.4f} el), stick {stick:.2e} ({stick_el:.4f} el)")
    assert edge_el < LEVEL3_EDGE_ELEMENTS
    assert stick_el < LEVEL3_STICK_ELEMENTS


@pytest.mark.slow
@pytest.mark.parametrize("incompatible", [False, True])
def test_edges_converge_through_level4(incompatible):
    rows = [errors(level, incompatible) for level in (2, 3, 4)]
    h = 2.0 ** -np.arange(3)
    edge, stick = [r[0] for r in rows], [r[1] for r in rows]
    print(f"edge {edge}, stick {stick}")
    assert edge[-1] <= LEVEL4_ACCURACY and stick[-1] <= LEVEL4_ACCURACY
    assert observed_order(h, edge) >= MIN_ORDER[incompatible]
    assert observed_order(h, stick) >= MIN_ORDER[incompatible]


#: Issue 28's bar for the phase-locked edge error at level 5 (of the width): no stall above it;
#: measured 5.9e-6 (edge) and 1.2e-5 (stick) on rings, levels 2-5 falling monotonically.
PHASE_LOCKED_LEVEL5 = 1e-5


@pytest.mark.slow
def test_phase_locked_edges_fall_through_level5():
    """Phase-locked (a node on each analytic edge), rings with the default elements: plain Q1
    measured edge 3.5e-5 / 3.2e-5 / 1.3e-5 / 5.9e-6 and stick 2.3e-4 / 6.5e-5 / 3.7e-5 /
    1.2e-5 of the width at levels 2-5; with the incompatible modes (the default since) it
    passes as well (slow run of 27 Nov 2026, before the h39 merges)."""
    from compare.convergence import convergence

    case = load_case("cattaneo").with_fem(layout="rings")
    study = convergence(case, levels=[2, 3, 4, 5], phase_locked=True)
    edge, stick = study.errors["edge_error_max"], study.errors["stick_edge_error_max"]
    print(f"edge {edge}, stick {stick}")
    assert study.phase_locked
    assert np.all(np.diff(edge) < 0), edge
    assert np.all(np.diff(stick) < 0), stick
    assert edge[-1] < PHASE_LOCKED_LEVEL5
