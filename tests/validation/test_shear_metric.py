"""The shear metric in units of the Coulomb bound (issue 25, item 6): exactly ||e|| / (mu ||p||)
at every sample whatever Q is, and our own FE at its default level passes every load ratio
(the former relative metric failed Q0 = 0.2 and 0.5 mu P at the stage-3 reversal)."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from compare import load_case, run_case
from compare import metrics as mt
from compare.analytic_side import solve_case
from compare.run import evaluate
from compare.testing import assert_agrees
from compare.tolerances import SHEAR_RTOL

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from shear_load_ratios import RATIOS, at_ratio  # noqa: E402

#: The former metric's limit (relative L2 with the denominator floored at 0.1 mu ||p||).
FORMER_SHEAR_RTOL = 0.05


def test_shear_error_is_in_units_of_the_coulomb_bound():
    """q_fe = q_an + delta mu p_an at every sampled Q: the metric is delta, at Q = 0 too."""
    case = load_case("cattaneo").with_fem(level=-1)
    res = run_case(case)
    an, delta = res.analytic, 0.0123
    steps = list(res.fem.steps)
    for st in an.samples:
        step = res.fem.at(st.stage, Q=st.Q)
        x = step.interface.x
        q = np.asarray(st.shear(x), float) + delta * case.mu * an.normal.pressure(x)
        steps[step.index] = replace(step, interface=replace(step.interface, q=q))
    m, _, rows = evaluate(case, an, replace(res.fem, steps=tuple(steps)))
    assert [r["shear_l2_error"] for r in rows] == pytest.approx([delta] * len(rows), rel=1e-9)
    assert m["shear_l2_error"] == pytest.approx(delta, rel=1e-9)
    assert any(r["Q"] == 0 for r in rows)


def former_metric(res) -> float:
    """The relative shear error before issue 25, max over the samples."""
    out = []
    for st in res.analytic.samples:
        it = res.fem.at(st.stage, Q=st.Q).interface
        floor = mt.SHEAR_FLOOR * res.case.mu * mt.l2(res.analytic.normal.pressure(it.x), it.w)
        out.append(mt.relative_l2(it.q, st.shear(it.x), it.w, floor))
    return max(out)


#: The FE of issue 25, on which the former metric failed: the default mesh then (the tensor
#: layout, plain Q1).  On today's default (rings, incompatible modes) it measures 3.6 % at Q0 =
#: 0.5 mu P: a more accurate FE, the same flawed metric.
ISSUE25_FE = {"layout": "tensor", "incompatible": False}


def passes_at_ratio(ratio: float, **fem):
    case = at_ratio(load_case("cattaneo"), ratio).with_fem(**fem)
    res = run_case(case, analytic=solve_case(case))
    assert_agrees(res)
    assert res.metrics["shear_l2_error"] <= SHEAR_RTOL
    return res


def test_default_level_passes_where_the_former_metric_failed():
    res = passes_at_ratio(0.5)  # the load ratio of issue 25
    assert res.case.fem.level == load_case("cattaneo").fem.level
    assert former_metric(passes_at_ratio(0.5, **ISSUE25_FE)) > FORMER_SHEAR_RTOL  # 5.4 %


@pytest.mark.slow
@pytest.mark.parametrize("ratio", sorted(set(RATIOS) - {0.5}))
def test_default_level_passes_every_load_ratio(ratio):
    passes_at_ratio(ratio)
    if ratio == 0.2:
        assert former_metric(passes_at_ratio(ratio, **ISSUE25_FE)) > FORMER_SHEAR_RTOL  # 8.4 %
