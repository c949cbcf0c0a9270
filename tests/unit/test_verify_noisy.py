"""``verify`` of a mortar-like result: the analytic Cattaneo solution sampled at nodes with the
node-to-node ripple of a mortar code's tractions, without a status column.

The data are the analytic fields, so every edge the tool reports should be 0 away from the
truth: what it reports is the estimator's own error.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.analytic_side import solve_case
from compare.cases import load_case
from compare.errors import CaseError
from compare.external import ExternalResult
from compare.external.exchange import RawStep, derived_status, slip_sense
from compare.verify import measurement_lines, verify

#: Reported edge error (elements) of the rippled Cattaneo result (h = a/20, +-2 % ripple):
#: measured 0.03; the issue's bound.
NOISY_EDGE_ELEMENTS = 0.05
#: Reported stick-edge error (elements) of the same in stage 2: measured 0.019 (band fit).  In
#: stage 3 the frozen stage-2 stick edge is a kink 1-4 elements inside the stick zone, the band
#: is not trusted and sqrt_edge errs up to 0.54 element, within its reported uncertainty (1-2.4).
NOISY_STICK_ELEMENTS = 0.05
RIPPLE = 0.02


@pytest.fixture(scope="module")
def analytic():
    case = load_case("cattaneo")
    return case, solve_case(case)


def mortar_like(case, an, ripple=RIPPLE, phase=0.37, edit=None) -> ExternalResult:
    """Steps at the end of stage 1 and at the case's stage-2/3 samples; nodes of spacing a/20
    shifted by ``phase`` elements; p and q times (1 +- ripple) alternating from node to node."""
    a = an.normal.zones[0][1]
    h = a / 20
    x = (np.arange(-50, 51) + phase) * h
    r = ripple * (-1.0) ** np.arange(x.size)
    p = np.asarray(an.normal.pressure(x), float) * (1 + r)
    steps = [RawStep("stage 1 end", 1, case.P, 0.0, math.nan, math.nan,
                     {"x": x, "p": p, "q": 0 * p})]
    for st in an.samples:
        q = np.asarray(st.shear(x), float) * (1 + r)
        steps.append(RawStep(f"stage {st.stage}, Q = {st.Q:g}", st.stage, case.P, st.Q,
                             math.nan, math.nan, {"x": x, "p": p, "q": q}))
    if edit:
        steps = [edit(s) for s in steps]
    return ExternalResult("mortar-like", tuple(steps))


def test_noisy_mortar_like_edges_within_a_twentieth_element(analytic):
    case, an = analytic
    res = verify(case, mortar_like(case, an))
    (zone,) = res.zones
    assert max(zone["edge_error_elements"]) <= NOISY_EDGE_ELEMENTS
    assert zone["edge_error_elements"] == pytest.approx(
        [e / h for e, h in zip(zone["edge_error"], zone["h_local"], strict=True)])
    assert all(e <= u for e, u in zip(zone["edge_error_elements"],
                                      zone["edge_uncertainty_elements"], strict=True))
    assert res.metrics["edge_error_max_elements"] == max(zone["edge_error_elements"])
    for row in res.samples:
        (err,), (unc,) = row["stick_edge_error_elements"], row["stick_uncertainty_elements"]
        assert err <= max(unc)
        assert row["stage"] == 3 or err <= NOISY_STICK_ELEMENTS
    assert any(line.startswith("edge error:") and "element" in line
               for line in measurement_lines(res))
    assert "edge_error_elements" in res.summary()["zones"][0]


def _below_the_cone(slack: float, mu: float):
    """Shear of the slip nodes (at the cone in the stage's slip direction) slack * mu p below
    it, as a regularised friction law or a short number format leaves it."""
    def edit(s: RawStep) -> RawStep:
        p, q = s.columns["p"], s.columns["q"]
        at_cone = (s.stage > 1) & (np.abs(np.abs(q) - mu * p) <= 1e-12 * p.max())
        return RawStep(s.where, s.stage, s.P, s.Q, s.M, s.theta,
                       s.columns | {"q": np.where(at_cone, (1 - slack) * q, q)})
    return edit


@pytest.mark.parametrize("slack", [2e-3, 5e-3])
def test_slip_nodes_a_little_below_the_cone_are_slip(analytic, slack):
    """Without a status column the stick edges do not move when the slip nodes' shear sits a
    few 1e-3 below the cone (SLIP_SLACK; STATUS_EPS alone put the whole zone in stick)."""
    case, an = analytic
    ref = verify(case, mortar_like(case, an, ripple=0.0))
    got = verify(case, mortar_like(case, an, ripple=0.0, edit=_below_the_cone(slack, case.mu)))
    assert got.metrics["stick_edge_error_max_elements"] == pytest.approx(
        ref.metrics["stick_edge_error_max_elements"], abs=0.02)


def test_stage_3_nodes_at_the_stage_2_cone_are_stick():
    """Stage 3 slips only against the stage-2 direction (Jaeger-Ciavarella): a node at the cone
    in the stage-2 direction is a frozen stage-2 slip node, stick."""
    p, q = np.array([1.0, 2.0, 1.0]), np.array([-0.5, 0.9, 0.5])
    assert list(derived_status(p, q, 0.5, slip_sense(3, 18.0))) == [2, 1, 1]
    assert list(derived_status(p, q, 0.5, slip_sense(2, 18.0))) == [1, 1, 2]
    assert list(derived_status(p, q, 0.5, slip_sense(1, 18.0))) == [2, 1, 2]
    assert list(derived_status(np.array([0.0, 1.0]), np.zeros(2), 0.5, 1.0)) == [0, 1]


def test_status_derived_when_not_given(analytic):
    """No status column: stick where |q| < (1 - STATUS_EPS) mu p; the stick zones are found."""
    case, an = analytic
    res = verify(case, mortar_like(case, an))
    found = [r["stick_fem"][0] for r in res.samples if r["stick_analytic"][0]]
    assert found and all(s is not None for s in found)


def _scaled(name: str, factor: float, stage: int | None = None):
    def edit(s: RawStep) -> RawStep:
        if stage is not None and s.stage != stage:
            return s
        return RawStep(s.where, s.stage, s.P, s.Q, s.M, s.theta,
                       s.columns | {name: factor * s.columns[name]})
    return edit


@pytest.mark.parametrize("edit, words", [
    (_scaled("p", -1.0), ["stage 1 end", "sum p w = -", "P = 100", "sign of p",
                          "pressure_sign"]),
    (_scaled("q", -1.0, 2), ["stage 2, Q = 9", "sum q w = -", "Q = 9", "opposite signs",
                             "shear_sign flips both"]),
    (_scaled("p", 1e6), ["stage 1 end", "sum p w = 1.00", "P = 100", "different units",
                         "convert both alike"]),
    (_scaled("p", 0.5), ["stage 1 end", "sum p w = 50", "tributary lengths w"]),
])
def test_sign_unit_and_width_mistakes_are_input_errors(analytic, edit, words):
    case, an = analytic
    with pytest.raises(CaseError) as exc:
        verify(case, mortar_like(case, an, edit=edit))
    msg = str(exc.value)
    assert all(w in msg for w in words), msg
    assert "\n" not in msg


def test_widths_column_doubled_is_an_input_error(analytic):
    case, an = analytic

    def edit(s: RawStep) -> RawStep:
        x = s.columns["x"]
        return RawStep(s.where, s.stage, s.P, s.Q, s.M, s.theta,
                       s.columns | {"w": np.full(x.size, 2 * (x[1] - x[0]))})
    with pytest.raises(CaseError, match=r"stage 1 end: sum p w = 2\d\d.*tributary lengths w"):
        verify(case, mortar_like(case, an, edit=edit))


def test_small_negative_pressure_clipped_with_a_note_large_one_an_error(analytic):
    case, an = analytic

    def negative(value):
        def edit(s: RawStep) -> RawStep:
            p = s.columns["p"].copy()
            p[0] = value * float(np.max(p))  # an open node far outside the zone
            return RawStep(s.where, s.stage, s.P, s.Q, s.M, s.theta, s.columns | {"p": p})
        return edit
    res = verify(case, mortar_like(case, an, edit=negative(-0.005)))
    assert len(res.notes) == len(res.fem.steps)
    assert "clipped to 0" in res.notes[0] and "Note:" in _note(res)
    assert np.all(res.fem.steps[0].interface.p >= 0)
    with pytest.raises(CaseError, match=r"stage 1 end: pressure p = -.* at node 1 .*tensile"):
        verify(case, mortar_like(case, an, edit=negative(-0.05)))


def _note(res) -> str:
    from compare.verify import report_note

    return report_note(res)


def test_one_node_dominating_the_pressure_error_is_said(analytic):
    case, an = analytic

    def spike(s: RawStep) -> RawStep:
        p = s.columns["p"].copy()
        p[int(np.argmax(p))] *= 1.1
        return RawStep(s.where, s.stage, s.P, s.Q, s.M, s.theta, s.columns | {"p": p})
    res = verify(case, mortar_like(case, an, ripple=0.0, edit=spike))
    assert res.metrics["pressure_l2_top_share"] > 0.9
    assert any("pressure_l2_error: one node at x = " in line and "% of the squared error"
               in line for line in measurement_lines(res))


def test_stick_line_names_the_worst_step_and_its_own_uncertainty(analytic):
    """The stick-edge line says at which step the error is largest and the estimator's
    uncertainty there, not only the largest uncertainty of any step (Kratos: 0.84 element at
    one step, uncertainty 0.19 there, 7.7 at another)."""
    case, an = analytic
    res = verify(case, mortar_like(case, an))
    rows = [r for r in res.samples if np.isfinite(r["stick_edge_error_max"])]
    worst = max(rows, key=lambda r: r["stick_edge_error_max"])
    here = max(u for pair in worst["stick_uncertainty_elements"] if pair for u in pair)
    (line,) = [x for x in measurement_lines(res) if x.startswith("stick-edge error:")]
    assert f"(worst at stage {worst['stage']}, Q = {worst['Q']:.4g}; " in line
    assert f"estimator uncertainty there {here:.2g} element" in line


def test_worst_stick_wording_with_and_without_an_uncertainty_there():
    from types import SimpleNamespace

    from compare.verify import _worst_stick

    def row(stage, Q, err, unc):
        return {"stage": stage, "Q": Q, "stick_edge_error_max": err,
                "stick_uncertainty_elements": unc}

    rows = [row(2, 1.0, 0.001, [(0.5, 7.0)]), row(3, -2.0, 0.004, [(0.2, 0.1)])]
    assert _worst_stick(SimpleNamespace(samples=rows)) == (
        " (worst at stage 3, Q = -2; estimator uncertainty there 0.2 element, up to 7 over the "
        "steps)")
    rows[1]["stick_uncertainty_elements"] = [None]
    assert _worst_stick(SimpleNamespace(samples=rows)) == (
        " (worst at stage 3, Q = -2; estimator uncertainty up to 7 element over the steps)")
    assert _worst_stick(SimpleNamespace(samples=rows[1:])) == " (worst at stage 3, Q = -2)"
    assert _worst_stick(SimpleNamespace(samples=[])) == ""


def test_a_stick_fail_within_the_estimators_uncertainty_says_so():
    """A FAIL is flagged when every failing step is within its uncertainty of the tolerance
    (the verdict then flips with the noise); a clear FAIL and a pass are not."""
    from types import SimpleNamespace

    from compare.run import Check
    from compare.verify import _stick_unresolved

    def res(*rows):
        samples = [{"stage": st, "Q": Q, "stick_edge_error_max": e, "stick_edge_error_max_elements":
                    e / 0.01 * 0.5, "stick_uncertainty_elements": [(u, u)]}
                   for st, Q, e, u in rows]  # 1 % of the width = 0.5 element
        return SimpleNamespace(samples=samples, checks=(Check("stick", "m", 0.0, 0.01),))

    (line,) = _stick_unresolved(res((2, 9.0, 0.004, 5.0), (3, 2.25, 0.022, 0.7)))
    assert line.startswith("stick FAIL within the estimator's uncertainty: at stage 3, Q = 2.25 "
                           "the error is 1.1 +- 0.7 element against a tolerance of 0.5 element")
    assert _stick_unresolved(res((3, 2.25, 0.022, 0.5))) == []  # 1.1 - 0.5 > 0.5: a real FAIL
    assert _stick_unresolved(res((3, 2.25, 0.009, 5.0))) == []  # a pass is not flagged
    assert _stick_unresolved(res((3, 2.25, 0.022, 0.7), (3, 0.0, 0.05, 0.1))) == []
