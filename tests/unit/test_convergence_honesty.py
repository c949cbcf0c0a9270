"""Convergence verdicts on synthetic error sequences: a stall is reported as a stall, Richardson
refuses negative / implausible orders and non-monotone sequences instead of returning the finest
value, and the text output says what theory expects."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare import metrics as mt
from compare.convergence import STALL_ORDER, TRACKED, assemble, convergence_text, study_values
from compare.errors import CaseError
from compare.tolerances import EDGE_RTOL

H = [0.04, 0.02, 0.01, 0.005]
ZONES = [(-1.0, 1.0)]


def errors(n: int = 4, **given) -> dict:
    """Tracked errors on the first ``n`` levels: first order, overridden by ``given``."""
    out = {m: [0.1 * h for h in H[:n]] for m in TRACKED}
    out.update(given)
    return out


def edges(b: list[float]) -> list[list[float]]:
    return [[-v, v] for v in b]


def study(errs: dict, b: list[float], kind: str = "h", values=(0, 1, 2, 3), par=H):
    return assemble("synthetic", kind, list(values), list(par), errs, edges(b), ZONES)


def test_first_order_sequence_converges_with_its_order_and_ratios():
    st = study(errors(), [1.0 + 0.3 * h for h in H])
    assert st.converges and st.verdict() == "converges" and not st.stall
    assert st.orders["pressure_l2_error"] == pytest.approx(1.0)
    assert st.local_orders["edge_error_max"] == pytest.approx([1.0, 1.0, 1.0])
    assert st.ratios["shear_l2_error"] == pytest.approx([2.0, 2.0, 2.0])
    assert st.richardson_error == pytest.approx(0.0, abs=1e-12)  # exact for a power law


def test_a_stalling_edge_error_is_reported_as_a_stall():
    """Issue 14: edge errors 0.24 %, 0.088 %, 0.11 % printed 'converges: True'."""
    st = study(errors(3, edge_error_max=[2.4e-3, 8.8e-4, 1.1e-3]), [1.0, 1.001, 1.002],
               values=(0, 1, 2), par=H[:3])
    assert not st.converges
    assert st.verdict().startswith("does not converge: stalls at level 2: edge_error_max")
    assert st.local_orders["edge_error_max"][-1] < STALL_ORDER


def test_a_slow_last_step_stalls_but_a_tiny_error_does_not():
    slow = [1e-2, 5e-3, 2.5e-3, 2.2e-3]  # last local order 0.18
    assert "pressure_l2_error" in study(errors(pressure_l2_error=slow), [1.0] * 4).stall
    tiny = [1e-6, 5e-7, 4e-8, 4e-8]      # below STALL_FLOOR: rounding level
    assert not study(errors(edge_error_max=tiny), [1.0] * 4).stall


def test_richardson_refuses_negative_order_and_says_why():
    """double_wedge_a extrapolated with order -1.33; now refused with the reason."""
    seq = [1.0, 1.001, 1.00352]  # growing differences: negative order
    val, order, why = mt.richardson_check(seq)
    assert math.isnan(val) and order < 0 and "outside" in why
    st = study(errors(), [1.0, 1.001, 1.00352, 1.00987])
    assert math.isnan(st.richardson_error) and "outside" in st.richardson_reason
    assert "refused" in convergence_text(st)


def test_richardson_refuses_non_monotone_sequences_instead_of_the_finest_value():
    val, order, why = mt.richardson_check([1.0, 1.002, 1.001])
    assert math.isnan(val) and math.isnan(order) and "non-monotone" in why
    assert all(math.isnan(v) for v in mt.richardson([1.0, 1.0, 1.0]))
    assert "three" in mt.richardson_check([1.0, 1.1])[2]


def test_richardson_refuses_implausibly_high_orders():
    val, order, why = mt.richardson_check([1.0, 1.0 + 1e-3, 1.0 + 1e-3 + 1e-6])
    assert math.isnan(val) and order > 3 and "outside" in why


def test_text_states_expected_orders_and_penalty_shift():
    st = study(errors(), [1.0 + 0.3 * h for h in H])
    text = convergence_text(st)
    assert "expected pressure_l2_error: ~1" in text and "sqrt" in text
    pen = assemble("synthetic", "penalty", [100.0, 1e4, math.inf], [1e-2, 1e-4, 0.0],
                   {m: [1e-3] * 3 for m in TRACKED}, edges([1.0001, 1.0, 1.0]), ZONES)
    assert pen.edge_shift == pytest.approx(5e-5) and pen.converges
    assert "move by 5.00e-05" in pen.verdict()
    moved = assemble("synthetic", "penalty", [100.0, math.inf], [1e-2, 0.0],
                     {m: [1e-3] * 2 for m in TRACKED}, edges([1.002, 1.0]), ZONES)
    assert not moved.converges and "> 0.0003" in moved.verdict()


def test_local_orders_skip_undefined_errors():
    out = mt.local_orders([0.1, 0.05, 0.025], [1.0, np.nan, 0.25])
    assert all(math.isnan(v) for v in out)


def test_convergence_figure_draws_a_stalling_study():
    from compare.report.figures import convergence_figure

    st = study(errors(3, edge_error_max=[2.4e-3, 8.8e-4, 1.1e-3]), [1.0, 1.001, 1.00352],
               values=(0, 1, 2), par=H[:3])
    assert convergence_figure(st)[:8] == b"\x89PNG\r\n\x1a\n"


def test_richardson_refuses_a_sequence_crossing_the_limit():
    """Cattaneo levels 1-3: the finest FE edge crosses the analytic one (error -9.2e-5,
    -3.25e-5, +8.1e-6): estimated order 0.55, an extrapolated error 12x the finest one."""
    val, order, why = mt.richardson_check([-9.2e-5, -3.25e-5, 8.1e-6])
    assert math.isnan(val) and 0.5 < order < 0.75 and "outside" in why


def test_words_not_literals_and_rows_the_case_lacks_are_left_out():
    """Issue 26: the report said 'converges: True' and listed stick and shear rows for Hertz;
    the CLI text, the report and the figure now share the verdict and the Richardson line."""
    nan = [math.nan] * 3
    st = study(errors(3, stick_edge_error_max=nan, shear_l2_error=nan), [1.0, 1.1, 1.2],
               values=(0, 1, 2), par=H[:3])
    assert st.converges and st.verdict() == "converges"
    assert not st.applies("shear_l2_error") and st.applies("pressure_l2_error")
    line = st.richardson_line()
    assert line.startswith("Richardson extrapolation of the edges refused (edge 0: ")
    text = convergence_text(st)
    assert "stick_edge_error_max" not in text and "shear_l2_error" not in text
    assert line in text and "True" not in text
    good = study(errors(), [1.0 + 0.3 * h for h in H])
    assert good.richardson_line().endswith(f"(within the edge tolerance {EDGE_RTOL:g})")
    stalled = study(errors(3, edge_error_max=[2.4e-3, 8.8e-4, 1.1e-3]), [1.0, 1.001, 1.002],
                    values=(0, 1, 2), par=H[:3])
    assert stalled.verdict().startswith("does not converge: stalls at level 2")


def test_the_study_says_which_refinement_ran():
    free = study(errors(), [1.0 + 0.3 * h for h in H])
    locked = assemble("synthetic", "h", [0, 1, 2, 3], H, errors(), edges([1.0] * 4), ZONES,
                      phase_locked=True)
    assert not free.phase_locked and locked.phase_locked
    assert "refinement: free phase" in convergence_text(free)
    assert "refinement: phase-locked" in convergence_text(locked)
    assert locked.summary()["phase_locked"] is True
    assert locked.summary()["phase"].startswith("phase-locked")


def test_phase_locked_cases_put_a_mesh_node_on_every_analytic_edge():
    from compare.analytic_side import solve_case
    from compare.cases import load_case
    from compare.fem_side import kinks, mesh, mesh_kinks, window
    from fem.mesh import build_mesh

    case = load_case("two_cylinders_unequal").with_fem(level=-1)
    normal = solve_case(case).normal
    assert mesh_kinks(case, normal) == kinks(case)  # the profile's own kink only
    locked = case.with_fem(edge_nodes=True)
    edges_ = sorted(e for z in normal.zones for e in z)
    assert mesh_kinks(locked, normal) == tuple(sorted({*edges_, *kinks(case)}))
    tbm = build_mesh(mesh(locked), window(locked, normal), mesh_kinks(locked, normal))
    x = tbm.bodies[0].p[0, tbm.nodes["contact_upper"]]
    assert max(np.min(np.abs(x - e)) for e in edges_) < 1e-12 * max(map(abs, edges_))


def test_converge_command_passes_phase_locked_and_prints_which_ran(monkeypatch, capsys):
    import sys

    from compare.cli import main

    conv = sys.modules["compare.convergence"]  # the package exports a function of that name

    seen = {}

    def fake(case, levels, kind, values, progress, phase_locked):
        seen["phase_locked"] = phase_locked
        return assemble("hertz", "h", [0, 1, 2, 3], H, errors(), edges([1.0] * 4), ZONES,
                        phase_locked=phase_locked)

    monkeypatch.setattr(conv, "convergence", fake)
    for flag, words in (([], "free phase"), (["--phase-locked"], "phase-locked")):
        assert main(["converge", "hertz", *flag]) == 0
        assert seen["phase_locked"] == bool(flag)
        assert f"refinement: {words}" in capsys.readouterr().out


def test_the_edge_offset_keeps_its_sign_and_a_crossing_is_named():
    """Issue 28: phase-locked Hertz on rings, edge errors 3.3e-4, 1.3e-5, 3.5e-5, 2.8e-5: a
    discretisation error widening the zone crosses a grading error narrowing it."""
    wide_then_narrow = [1.0 + 3.3e-4 * 2, 1.0 + 1.3e-5 * 2, 1.0 - 3.5e-5 * 2, 1.0 - 2.8e-5 * 2]
    st = study(errors(edge_error_max=[3.3e-4, 1.3e-5, 3.5e-5, 2.8e-5]), wide_then_narrow)
    assert st.edge_offsets() == pytest.approx([3.3e-4, 1.3e-5, -3.5e-5, -2.8e-5])
    assert st.offset_crossings() == [(1, 2)]
    text = convergence_text(st)
    assert "edge offset (wider +)" in text
    assert "changes sign from level 1 to 2" in text
    assert st.summary()["offset_crossings"] == [[1, 2]]
    same_sign = study(errors(), [1.0 + 0.3 * h for h in H])
    assert same_sign.offset_crossings() == [] and "changes sign" not in convergence_text(same_sign)


@pytest.mark.parametrize("kind, levels, values, expected", [
    ("h", (0, 1, 2), None, [0, 1, 2]),
    ("h", (-1, 1), None, [-1, 1]),
    ("h", (2.0, 3.0), None, [2, 3]),
    ("penalty", (), None, [100.0, 1e4, math.inf]),
    ("penalty", (), (1.0, 10.0, math.inf), [1.0, 10.0, math.inf]),
    ("domain", (), None, [6.0, 12.0, 25.0]),
])
def test_study_values_in_refining_order(kind, levels, values, expected):
    assert study_values(kind, levels, values) == expected


@pytest.mark.parametrize("kind, levels, values, words", [
    ("h", (0,), None, "levels=0 is not allowed for an h-study: need at least two levels"),
    ("h", (1, 0), None, "levels=1 0 is not allowed"),
    ("h", (0, 0), None, "levels=0 0 is not allowed"),
    ("h", (0, 1.5), None, "levels=0 1.5 is not allowed"),
    ("h", (), None, "levels= is not allowed"),
    ("penalty", (), (0.0, 10.0), "values=0 10 is not allowed for a penalty-study"),
    ("penalty", (), (math.inf, math.inf), "values=inf inf is not allowed"),
    ("penalty", (), (10.0, math.nan), "values=10 nan is not allowed"),
    ("domain", (), (12.0, 6.0), "values=12 6 is not allowed for a domain-study"),
    ("domain", (), (6.0, math.inf), "values=6 inf is not allowed"),
    ("domain", (), (6.0,), "values=6 is not allowed"),
    ("mesh", (0, 1), None, "kind='mesh' is not allowed: need one of h, penalty, domain"),
])
def test_study_values_refused(kind, levels, values, words):
    """A study whose runs are not in refining order would read the coarsest run as the finest
    ('error not smaller at the finest run' for a study that converges): refused at once."""
    with pytest.raises(CaseError) as exc:
        study_values(kind, levels, values)
    assert words in str(exc.value)


def test_convergence_refuses_before_solving(monkeypatch):
    """convergence() checks its runs before the analytic solution or any FE run."""
    import importlib

    cv = importlib.import_module("compare.convergence")  # compare.convergence: the function
    monkeypatch.setattr(cv, "solve_case", lambda case: pytest.fail("solved a refused study"))
    with pytest.raises(CaseError, match="levels=1 0 is not allowed"):
        cv.convergence("hertz", levels=(1, 0))
    with pytest.raises(CaseError, match="fem.level=7 is not allowed"):
        cv.convergence("hertz", levels=(5, 7))


def test_exact_errors_do_not_make_a_study_fail():
    """Edges exact by construction (0 at every level, a sharp punch) are not 'not smaller at the
    finest run': the pressure still converges, so the study does."""
    st = study(errors(edge_error_max=[0.0] * 4, stick_edge_error_max=[0.0] * 4), [1.0] * 4)
    assert st.converges, st.verdict()
    assert "no change over the last three runs" in st.richardson_reason  # not "non-monotone"
    grown = study(errors(edge_error_max=[1e-3, 2e-3, 3e-3, 4e-3]), [1.0] * 4)
    assert not grown.converges


@pytest.mark.parametrize("levels, ratio", [((0, 1, 2), 2.0), ((-1, 1, 3), 4.0),
                                           ((0, 1, 2, 4), math.nan), ((0, 1, 3), math.nan)])
def test_richardson_ratio_follows_the_levels(levels, ratio):
    """Levels two apart quarter h: Richardson's ratio is 4, not 2; uneven last steps have none."""
    from compare.convergence import level_ratio

    assert level_ratio("h", list(levels)) == pytest.approx(ratio, nan_ok=True)
    h = [0.04 / 2.0**lv for lv in levels]
    b = [1.0 + 0.3 * x for x in h]  # first order: exact Richardson with the true ratio
    st = assemble("synthetic", "h", list(levels), h, errors(len(levels)), edges(b), ZONES,
                  ratio=level_ratio("h", list(levels)))
    if math.isnan(ratio):
        assert "not evenly spaced" in st.richardson_reason
    else:
        assert st.richardson_error == pytest.approx(0.0, abs=1e-12)


def test_domain_study_goes_by_how_far_the_edges_move():
    """With the half-plane far field the errors do not depend on the body size (they are the
    mesh's): a domain study is judged like a penalty study, by the edges' shift."""
    flat = {m: [1e-3] * 3 for m in TRACKED}
    st = assemble("synthetic", "domain", [6.0, 12.0, 25.0], [1 / 6, 1 / 12, 1 / 25], flat,
                  edges([1.0 + 1.2e-6, 1.0, 1.0]), ZONES)
    assert st.converges and "over the body-size range" in st.verdict()
    moved = assemble("synthetic", "domain", [6.0, 25.0], [1 / 6, 1 / 25],
                     {m: [1e-3] * 2 for m in TRACKED}, edges([1.002, 1.0]), ZONES)
    assert not moved.converges and "move by 1.00e-03" in moved.verdict()
