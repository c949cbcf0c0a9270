"""Convergence studies: Hertz under uniform h-refinement with linear (Q4) elements.

Expected order of the relative L2 pressure error: 1.  The nodal penalty traction carries an
O(h) penetration error (k_n = 100 E / h), and the square-root edges of the Hertz pressure limit
the piecewise-linear approximation near the edges to O(h^1.5) in L2, so O(h) dominates.
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from compare import convergence


@pytest.fixture(autouse=True)
def runs_once(monkeypatch, contact_case):
    """convergence() runs each variant through compare.convergence.run_case: here through the
    session's contact_case (pytest plugin), so a variant run before is computed once (hertz
    levels 0 and 1 of both hertz studies and the library hertz of the edge test; the library
    cattaneo of the domain and penalty studies, also test_compare_agreement's).  The analytic
    solution it would pass is the one contact_case solves (the same function of the case).
    Each study still assembles, fits and judges its own runs."""
    module = importlib.import_module("compare.convergence")
    monkeypatch.setattr(module, "run_case", lambda case, analytic=None: contact_case(case))


THEORETICAL_ORDER = 1.0
ORDER_BAND = 0.35  # three coarse levels give the slope to about +-0.3


def test_hertz_pressure_order_close_to_one():
    # level -1 (12 elements across the zone) is pre-asymptotic: with it the slope was 1.55
    st = convergence("hertz", levels=(0, 1, 2))
    order = st.orders["pressure_l2_error"]
    assert abs(order - THEORETICAL_ORDER) < ORDER_BAND, st.summary()
    assert st.converges and not st.stall
    assert st.errors["pressure_l2_error"][-1] < 0.5 * st.errors["pressure_l2_error"][0]


#: The edge error must fall at least this fast at every refinement (theory: order 1, the
#: sqrt-fit estimator adds O(h^2)); measured 2.75 and 1.41 for levels -1 -> 0 -> 1 (the ring
#: layout: 2.56 and 0.63, fem.settings.DEFAULT_LAYOUT says why).
MIN_EDGE_ORDER = 0.75
#: The gap-side and pressure-side edge estimates of one FE solution agree to this fraction of
#: the finest element (both fit the same sqrt edge; measured 0.032, 0.012, 0.004 at levels 0-2).
SIDES_AGREE = 0.1


def test_hertz_edge_error_falls_at_order_one_and_both_sides_agree(contact_case):
    from fem.results import contact_edges

    st = convergence("hertz", levels=(-1, 0, 1))
    assert min(st.local_orders["edge_error_max"]) > MIN_EDGE_ORDER, st.summary()
    res = contact_case("hertz")  # the session's library run (read only)
    it = res.fem.stage(1)[-1].interface
    cand = np.isfinite(it.gap)
    by_gap = contact_edges(it.x, it.p, it.status, cand, it.gap)
    by_pressure = contact_edges(it.x, it.p, it.status, cand)
    assert np.max(np.abs(np.subtract(by_gap, by_pressure))) < SIDES_AGREE * res.fem.h_min


#: Richardson-extrapolated edges within 0.05 % of the width (issue 14; measured 0.0095 % on the
#: plain Q1 tensor mesh, free refinement).  Phase-locked: on the default mesh (rings, incompatible
#: modes) the free edges -9.2e-4 / -9.7e-5 / -5.9e-5 of the width at levels 0-2 carry the O(h)
#: phase error, their apparent order 4.4 is outside metrics.RICHARDSON_ORDERS and the study
#: rightly refuses to extrapolate; locked -7.1e-4 / -2.0e-4 / -5.6e-5 (order 1.8).
RICHARDSON_EDGE = 5e-4


@pytest.mark.slow
def test_hertz_richardson_edges_close_to_analytic():
    st = convergence("hertz", levels=(0, 1, 2), phase_locked=True)
    assert abs(st.orders["pressure_l2_error"] - THEORETICAL_ORDER) < ORDER_BAND
    assert st.richardson_error < RICHARDSON_EDGE, st.richardson_reason


#: Half-plane boundary: spread of the errors over body sizes W = 4, 8, 25 (relative to the
#: smallest). Measured <= 0.10 (mesh-grading noise); clamped bodies: 11x (edge), 7.8x (pressure).
DOMAIN_SPREAD = 0.25


def test_cattaneo_domain_size_independent():
    """The half-plane far-field boundary (fem.farfield) removes the finite-body error: the
    errors no longer depend on the body size (clamped bodies: order ~1 in 1/W)."""
    st = convergence("cattaneo", kind="domain", values=(4.0, 8.0, 25.0))
    for name in ("pressure_l2_error", "edge_error_max", "stick_edge_error_max"):
        err = st.errors[name]
        assert max(err) < (1 + DOMAIN_SPREAD) * min(err), (name, err)
    assert st.converges, st.verdict()  # by the edges' shift (it could never converge by orders)


@pytest.mark.slow
def test_cattaneo_penalty_growth_reaches_discretisation_error():
    """Penalty error falls until the mesh error dominates; the default factor is past that."""
    st = convergence("cattaneo", kind="penalty", values=(1.0, 10.0, 100.0, 1000.0))
    err = st.errors["pressure_l2_error"]
    assert err[0] > 1.5 * err[1]
    assert abs(err[3] - err[2]) < 0.1 * err[2]


def test_penalty_is_not_the_limit():
    """Cattaneo edges move by <= 0.03 % of the width from penalty factor 100 to 1e4 and to the
    augmented Lagrangian (measured 2.7e-5 for 100 / 1e3 / AL before the relative law check)."""
    st = convergence("cattaneo", kind="penalty")
    assert st.values[-1] == float("inf") and st.converges, st.verdict()
