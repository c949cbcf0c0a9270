"""Report figures of a multi-zone case: one panel per zone with its error, the contact region,
and the case header (verdict with the worst metric, backend)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest

from compare import stress as cs
from compare.cases import load_case
from compare.report import figures, html, region, stress, zones
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
        assert lo < a < b < hi and hi - lo == pytest.approx((b - a) * (1 + 2 * figures.ZONE_MARGIN))
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
    assert len(fig.axes) == 4 * n + 1  # and the Q / Q0 colour bar
    plt.close(fig)
    assert zones.pressure_figure(two_zones)[:4] == b"\x89PNG"


def _zoomed_to_its_zone(ax, zones, k) -> tuple[float, float]:
    """x is horizontal and the panel holds zone k and no other zone."""
    lo, hi = ax.get_xlim()
    a, b = zones[k]
    assert lo < a < b < hi, (k, lo, hi)
    assert all(z[1] < lo or z[0] > hi for j, z in enumerate(zones) if j != k)
    return lo, hi


def test_contact_region_one_true_aspect_box_per_zone_with_the_status(two_zones) -> None:
    ns = two_zones.analytic.normal
    fig = region.region_axes(two_zones)
    n = len(ns.zones)
    fields, strips = fig.axes[:n], fig.axes[n:2 * n]
    for k, (field, strip) in enumerate(zip(fields, strips, strict=True)):
        lo, hi = _zoomed_to_its_zone(field, ns.zones, k)
        width = ns.zones[k][1] - ns.zones[k][0]
        assert hi - lo == pytest.approx((1 + 2 * region.REGION_PAD) * width)
        assert field.get_ylim() == pytest.approx((-region.REGION_DEPTH * width,
                                                  region.REGION_DEPTH * width))
        assert field.get_aspect() == 1.0  # true aspect ratio
        assert strip.get_xlim() == (lo, hi)
    step = region.region_step(two_zones)
    assert step.stage == 2 and step.Q == pytest.approx(two_zones.case.Q0)
    colours = {tuple(np.round(p.get_facecolor(), 3)) for s in strips for p in s.patches}
    assert len(colours) == 3  # open, stick and slip all appear
    assert len(fig.axes) == 3 * n  # a colour bar per zone
    plt.close(fig)


def test_status_strip_tiles_a_graded_interface() -> None:
    """Each node is drawn from midpoint to midpoint: no gap, no overlap (the bars of the
    tributary width centred on the node left a notch at x = 0.08 in two_cylinders_unequal)."""
    x = np.array([0.16, -0.15, 0.0025, 0.3, 0.31, 1.0])
    lo, hi = region.node_cells(x)
    order = np.argsort(x)
    assert np.all(lo[order][1:] == hi[order][:-1])
    assert np.all((lo < x) & (x < hi))


def test_stress_and_map_figures_have_a_column_per_zone_x_horizontal(two_zones) -> None:
    ns = two_zones.analytic.normal
    n = len(ns.zones)
    surface = stress.surface_axes(two_zones)
    for k in range(n):
        _zoomed_to_its_zone(surface.axes[k], ns.zones, k)
    assert surface.legends and not any(ax.get_legend() for ax in surface.axes)  # outside
    contour = stress.contour_axes(two_zones)
    for k, (x0, x1, depth) in enumerate(stress.stress_boxes(ns.zones)):
        for ax in contour.axes[k], contour.axes[n + k]:  # analytic over FE
            assert _zoomed_to_its_zone(ax, ns.zones, k) == pytest.approx((x0, x1))
            assert ax.get_ylim() == pytest.approx((-depth, 0))
            assert ax.get_aspect() == 1.0
            assert depth == pytest.approx(cs.BOX_DEPTH * (ns.zones[k][1] - ns.zones[k][0]))
    ruiz = stress.ruiz_axes(two_zones)
    for k in range(n):
        m, r = ruiz.axes[k], ruiz.axes[n + k]  # map over the Ruiz parameter, same x
        _zoomed_to_its_zone(m, ns.zones, k)
        assert m.get_xlim() == r.get_xlim() and m.get_ylim() == (0, 2)
    for fig in (surface, contour, ruiz):
        plt.close(fig)


def test_shear_states_are_a_colour_bar_not_a_legend(two_zones) -> None:
    fig = zones.shear_axes(two_zones)
    n = len(two_zones.analytic.normal.zones)
    assert not any(ax.get_legend() for ax in fig.axes) and not fig.legends
    bar = fig.axes[4 * n]
    assert bar.get_ylabel() == "Q / Q0 of the state" and bar.get_ylim() == (-1.0, 1.0)
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
    assert html.backend_notice([section("multicontact fem")]) == ""  # a verified result
    loud = html.backend_notice([section("cholmod"), section("scipy-splu")])
    assert "scipy-splu" in loud and "CHOLMOD" in loud and 'class="loud"' in loud
    # an external result's "backend" is the code's name, not a sparse solver
    assert html.backend_notice([section("Kratos 10.3", "Kratos 10.3 (r/steps.csv)")]) == ""
