"""Report figures of a multi-zone case: one panel per zone with its error, the contact region,
and the case header (verdict with the worst metric, backend)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest

from compare.cases import load_case
from compare.report import html, region, zones
from compare.run import Check, run_case


@pytest.fixture(scope="module")
def two_zones():
    return run_case(load_case("two_cylinders_unequal").with_fem(level=1))


def test_one_zoomed_panel_per_zone_with_its_error(two_zones) -> None:
    ns = two_zones.analytic.normal
    fig = zones.pressure_axes(two_zones)
    axes = np.array(fig.axes).reshape(2, len(ns.zones))
    for k, (a, b) in enumerate(ns.zones):
        lo, hi = axes[0, k].get_xlim()
        assert lo < a < b < hi and hi - lo == pytest.approx((b - a) * (1 + 2 * zones.ZONE_MARGIN))
        others = [z for j, z in enumerate(ns.zones) if j != k]
        assert all(z[1] < lo or z[0] > hi for z in others)
        assert axes[1, k].get_xlim() == (lo, hi)
        x, err = (np.concatenate([ln.get_xdata() for ln in axes[1, k].lines[:2]]),
                  np.concatenate([ln.get_ydata() for ln in axes[1, k].lines[:2]]))
        it = two_zones.fem.stage(1)[-1].interface
        m = (it.x >= lo) & (it.x <= hi)
        assert np.allclose(np.sort(x), it.x[m])
        assert np.allclose(np.sort(err), np.sort(it.p[m] - ns.pressure(it.x[m])))
    assert axes[0, 1].get_ylim() == axes[0, 0].get_ylim()  # one pressure axis for all zones
    assert axes[1, 1].get_ylim() == axes[1, 0].get_ylim()
    plt.close(fig)


def test_shear_panels_per_zone_and_stage(two_zones) -> None:
    fig = zones.shear_axes(two_zones)
    n = len(two_zones.analytic.normal.zones)
    assert len(fig.axes) == 4 * n
    plt.close(fig)
    assert zones.pressure_figure(two_zones)[:4] == b"\x89PNG"


def test_contact_region_is_three_spans_with_the_status(two_zones) -> None:
    ns = two_zones.analytic.normal
    fig = region.region_axes(two_zones)
    field, strip = fig.axes[:2]
    lo, hi = field.get_xlim()
    span = ns.zones[-1][1] - ns.zones[0][0]
    assert hi - lo == pytest.approx(region.REGION_SPANS * span)
    assert lo < ns.zones[0][0] and ns.zones[-1][1] < hi
    step = region.region_step(two_zones)
    assert step.stage == 2 and step.Q == pytest.approx(two_zones.case.Q0)
    colours = {tuple(np.round(p.get_facecolor(), 3)) for p in strip.patches}
    assert len(colours) == 3  # open, stick and slip all appear
    plt.close(fig)


def _check(name: str, value: float, tol: float) -> Check:
    return Check(name, f"{name}_metric", value, tol)


def test_worst_check_relative_to_its_tolerance() -> None:
    checks = (_check("edge", 0.01, 0.02), _check("shear", 0.12, 0.15),
              _check("moment", math.nan, 0.01), _check("zone_count", 0.0, 0.0))
    worst, ratio = html.worst_check(checks)
    assert worst.name == "shear" and ratio == pytest.approx(0.8)
    worst, ratio = html.worst_check((*checks, _check("full_slip", 1.0, 0.0)))
    assert worst.name == "full_slip" and math.isinf(ratio)
    assert html.worst_check((_check("moment", math.nan, 0.01),)) is None
    res = SimpleNamespace(checks=checks, passed=True)
    assert html.verdict_text(res) == ("agrees; worst: shear_metric = 0.12 (80 % of its "
                                      "tolerance 0.15)")


def test_slow_backend_is_announced() -> None:
    def section(backend, source="multicontact fem"):
        return SimpleNamespace(result=SimpleNamespace(fem=SimpleNamespace(backend=backend),
                                                      source=source))

    assert html.backend_notice([section("cholmod")]) == ""
    loud = html.backend_notice([section("cholmod"), section("scipy-splu")])
    assert "scipy-splu" in loud and "CHOLMOD" in loud and 'class="loud"' in loud
    # an external result's "backend" is the code's name, not a sparse solver
    assert html.backend_notice([section("Kratos 10.3", "Kratos 10.3 (r/steps.csv)")]) == ""
