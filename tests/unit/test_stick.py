"""Unit tests of ``analytic.stick``: bad inputs, limiting states, self-checks, helpers.

The physics against closed forms and the BEM is in tests/verification/test_stick.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import beta

import analytic
from analytic import fretting, stick
from analytic import profiles as pr
from analytic.errors import ConvergenceError, InputError

A, R, P, MU = 1.0, 1.0, 0.5, 0.3
A_HERTZ = np.sqrt(2 * A * P * R / np.pi)
EXACT = 1e-12
"""Quantities that are identities of the construction (roundoff only)."""


@pytest.fixture(scope="module")
def hertz() -> analytic.NormalSolution:
    return analytic.solve_normal(pr.cylinder(R), P, A)


# ------------------------------------------------------------------------------ bad inputs
@pytest.mark.parametrize("mu", [0.0, -0.2, float("nan"), float("inf")])
def test_bad_mu(hertz, mu: float) -> None:
    with pytest.raises(InputError, match=f"mu={mu!r}"):
        analytic.solve_stick(hertz, mu, 0.05)


@pytest.mark.parametrize("Q", [MU * P, -MU * P])
def test_gross_sliding_needs_the_keyword(hertz, Q: float) -> None:
    with pytest.raises(InputError, match=rf"Q={Q!r}.*gross sliding"):
        analytic.solve_stick(hertz, MU, Q)


def test_beyond_the_friction_limit_is_always_an_error(hertz) -> None:
    with pytest.raises(InputError, match="Q=0.16"):
        analytic.solve_stick(hertz, MU, 0.16, allow_full_slip=True)


@pytest.mark.parametrize("Q", [0.11, -0.11, float("nan")])
def test_stage3_load_outside_the_range(hertz, Q: float) -> None:
    with pytest.raises(InputError, match=rf"Q={Q!r} is not allowed: need .* in stage 3"):
        analytic.solve_stick(hertz, MU, Q, 0.1)


def test_stage3_turning_load_above_the_limit(hertz) -> None:
    with pytest.raises(InputError, match="Q0=0.2"):
        analytic.solve_stick(hertz, MU, 0.0, 0.2)


def test_not_a_normal_solution() -> None:
    with pytest.raises(InputError, match="NormalSolution"):
        analytic.solve_stick("hertz", MU, 0.05)  # type: ignore[arg-type]


@pytest.mark.parametrize("Q0", [0.0, -0.05, MU * P, 0.2])
def test_cycle_bad_amplitude(hertz, Q0: float) -> None:
    with pytest.raises(InputError, match=f"Q0={Q0!r}"):
        analytic.cycle(hertz, MU, Q0)


@pytest.mark.parametrize("n", [6, 10.5])
def test_cycle_bad_sample_count(hertz, n) -> None:
    with pytest.raises(InputError, match=f"n={n!r}"):
        analytic.cycle(hertz, MU, 0.1, n=n)


# ------------------------------------------------------------------------ limiting states
def test_zero_load_is_full_stick(hertz) -> None:
    s = analytic.solve_stick(hertz, MU, 0.0)
    x = np.linspace(-A_HERTZ, A_HERTZ, 50)
    assert s.reduced is hertz
    assert s.stick_zones == tuple(hertz.zones)
    assert s.slip_zones == ((),)
    assert np.all(s.shear(x) == 0) and np.all(s.slip(x) == 0)


def test_explicit_gross_sliding_state(hertz) -> None:
    s = analytic.solve_stick(hertz, MU, -MU * P, allow_full_slip=True)
    x = np.linspace(-1.1 * A_HERTZ, 1.1 * A_HERTZ, 60)
    assert s.reduced is None and s.full_slip_zones == (0,) and s.stick_zones == (None,)
    assert s.slip_zones == (tuple(hertz.zones),)
    assert np.allclose(s.shear(x), -MU * hertz.pressure(x), rtol=0, atol=EXACT)
    inside = np.abs(x) < A_HERTZ
    assert np.all(np.isnan(s.slip(x)[inside])) and np.all(s.slip(x)[~inside] == 0)


def test_stage3_after_gross_sliding(hertz) -> None:
    s = analytic.solve_stick(hertz, MU, 0.0, MU * P)
    c = A_HERTZ * np.sqrt(0.5)
    assert s.stick_zones[0] == pytest.approx((-c, c), abs=1e-10)
    with pytest.raises(InputError, match="gross sliding"):
        analytic.solve_stick(hertz, MU, -MU * P, MU * P)
    back = analytic.solve_stick(hertz, MU, -MU * P, MU * P, allow_full_slip=True)
    assert back.full_slip_zones == (0,)


def test_stage3_starts_from_the_stage2_end(hertz) -> None:
    x = np.linspace(-A_HERTZ, A_HERTZ, 40)
    s3 = analytic.solve_stick(hertz, MU, 0.1, 0.1)
    s2 = analytic.solve_stick(hertz, MU, 0.1)
    assert np.max(np.abs(s3.shear(x) - s2.shear(x))) < EXACT
    assert np.all(s3.slip(x) == 0)
    assert s3.stage == 3 and s3.direction == -1.0 and s3.previous.Q == 0.1


def test_slip_and_stick_zones_tile_the_contact(hertz) -> None:
    s = analytic.solve_stick(hertz, MU, 0.08)
    (c, d), (a, b) = s.stick_zones[0], hertz.zones[0]
    assert s.slip_zones[0] == ((a, c), (d, b))
    assert s.residuals["friction"] <= stick.FRICTION_TOL
    assert s.residuals["equilibrium"] <= stick.EQUILIBRIUM_TOL


# ------------------------------------------------------------- self-checks can fail
def test_inadmissible_reduced_pressure_is_refused(hertz) -> None:
    sharp = analytic.solve_normal(pr.cylinder(0.02), 0.25, A)  # narrow, tall: p_S > 2 p
    with pytest.raises(ConvergenceError, match=r"violates \|q\| <= mu p") as err:
        stick.checked_state(hertz, MU, 0.075, None, sharp, 0.25, None)
    assert err.value.diagnostics["residuals"]["friction"] > stick.FRICTION_TOL


def test_wrong_reduced_load_breaks_equilibrium(hertz) -> None:
    red = analytic.solve_normal(pr.cylinder(R), 0.3, A)
    with pytest.raises(ConvergenceError, match="int q = Q"):
        stick.checked_state(hertz, MU, 0.05, None, red, 0.3, None)


def test_stick_zone_outside_the_contact_is_refused(hertz) -> None:
    red = analytic.solve_normal(pr.cylinder(R, center=2.0), 0.3, A)
    with pytest.raises(ConvergenceError, match="outside every contact zone"):
        stick.checked_state(hertz, MU, 0.06, None, red, 0.3, None)


# ------------------------------------------------------------------------------ helpers
@pytest.mark.parametrize(("f", "exact"), [
    (lambda x: np.sqrt(x), 2 / 3),
    (lambda x: 1 / np.sqrt(x * (1 - x)), np.pi),
    (lambda x: x**1.5 * np.sqrt(1 - x), beta(2.5, 1.5)),
])
def test_cosine_rule_handles_square_root_edges(f, exact: float) -> None:
    x, w = stick.cosine_rule(0.0, 1.0)
    assert float(w @ f(x)) == pytest.approx(exact, rel=EXACT)


def test_cycle_samples_share_the_reduced_loads() -> None:
    Q, stage, frac = fretting._cycle_loads(1.0, 100)
    assert Q.size == 100 and Q[0] == 0
    assert list(np.bincount(stage)[2:]) == [34, 33, 33]
    assert Q[stage == 2][-1] == 1.0 and Q[stage == 3][-1] == -1.0 and Q[-1] == 1.0
    assert np.unique(frac).size == 34


def test_cycle_layout_and_mirror_symmetry(hertz) -> None:
    cy = analytic.cycle(hertz, MU, 0.1, n=13)
    assert cy.Q.shape == (13,) and cy.stick_edges.shape == (13, 1, 2)
    assert cy.full_slip.shape == (13, 1) and not np.any(cy.full_slip)
    up, down = cy.stick_edges[cy.stage == 3], cy.stick_edges[cy.stage == 4]
    assert np.array_equal(up, down)
    assert np.array_equal(cy.Q[cy.stage == 3], -cy.Q[cy.stage == 4])
    assert cy.W_total == sum(cy.W) and cy.W[0] > 0
    assert cy.residuals["rate"] <= fretting.RATE_TOL
