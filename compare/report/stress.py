"""Report figures of the stresses in body 2 (issue 17): PNG bytes, or None when not applicable.

Every figure has one column per contact zone, zoomed to it, x horizontal:

- surface sxx, FE nodes against the analytic curve, at the end of stage 1 and at the last
  sampled Q of stages 2 and 3;
- contours (analytic over FE) of the in-plane maximum shear below the surface at the end of
  stage 2 (stage 1 without tangential load) in the box of the stress metric, true aspect ratio;
- the stick-slip map over the cycle (analytic, with the FE stick edges) over the Ruiz parameter
  along the surface at the end of stage 3 (``Q = -Q0``), its maximum marked.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

import analytic  # noqa: E402
from compare import metrics as mt  # noqa: E402
from compare import stress as cs  # noqa: E402
from compare.fem_side import kinks  # noqa: E402
from compare.report.figures import (  # noqa: E402
    caption,
    outside_legend,
    png,
    stick_map_panel,
    zone_columns,
    zone_windows,
)
from compare.run import CaseResult  # noqa: E402

CONTOUR_LEVELS = 21
GRID = (160, 80)  # analytic contour grid (x, depth) per zone
RUIZ_POINTS = 801  # Ruiz parameter samples per zone panel


def _shown_states(res: CaseResult) -> list[tuple[int, float, object]]:
    """Stage-1 end and the last sampled state of stages 2 and 3."""
    states = cs.analytic_states(res.case, res.analytic)
    out = [states[0]]
    for stage in (2, 3):
        out += [s for s in states if s[0] == stage][-1:]
    return out


def surface_axes(res: CaseResult):
    """Surface sxx of body 2, one panel per contact zone (the zone and BOX_PAD widths each
    side, cut half-way to a neighbour; one sxx axis): analytic lines, FE nodal points.  The
    axis is set by the values outside the singular discs (compare.stress.STRESS_EXCLUSION):
    sxx is unbounded at a sharp corner."""
    ns = res.analytic.normal
    zones = ns.zones
    points = mt.singular_points(zones, ns.singular, kinks(res.case))
    fig, axes = zone_columns(len(zones), 1, (4.2, 3.6))
    colors = ("k", "tab:blue", "tab:red")
    shown = []
    for k, win in enumerate(cs.peak_windows(zones)):
        ax = axes[0, k]
        ax.axvspan(*zones[k], color="0.93", zorder=0)
        for (stage, Q, sol), col in zip(_shown_states(res), colors, strict=False):
            xa, sa = cs.analytic_surface(sol, win)
            xf, sf = cs.fem_surface(res.fem, cs.fem_step(res.fem, stage, Q), win)
            label = "P0, Q = 0" if stage == 1 else f"stage {stage}, Q/Q0 = {Q / res.case.Q0:.2f}"
            ax.plot(xa, sa, "-", color=col, lw=1.2, label=label)
            ax.plot(xf, sf, "o", ms=2.2, color=col)
            shown += [sa[cs.regular(xa, zones, points)], sf[cs.regular(xf, zones, points)]]
        ax.axhline(0, color="0.7", lw=0.6)
        ax.set(xlim=win, xlabel="x", title=f"zone {k}: [{zones[k][0]:.5g}, {zones[k][1]:.5g}]")
        ax.title.set_fontsize(9)
    vals = np.concatenate(shown)
    vals = vals[np.isfinite(vals)]
    lo, hi = (vals.min(), vals.max()) if vals.size else (-1.0, 1.0)
    pad = 0.08 * (hi - lo) or 1.0
    for i, ax in enumerate(axes[0]):
        ax.set_ylim(lo - pad, hi + pad)
        if i:
            ax.tick_params(labelleft=False)
    axes[0, 0].set_ylabel("sxx(x, 0) of body 2")
    cut = " (axis cut at the singular edges)" if points else ""
    text = (f"{res.case.name}: surface sxx (tension > 0); lines: analytic, dots: FE nodes; "
            f"grey band: analytic zone{cut}")
    fig.suptitle(caption(text, fig.get_figwidth(), 9), fontsize=9)
    outside_legend(fig, axes, ncol=3)
    return fig


def _share_y(row) -> None:
    """One y range for a row of zone panels (the union of their data ranges)."""
    lims = np.array([ax.get_ylim() for ax in row])
    for i, ax in enumerate(row):
        ax.set_ylim(lims[:, 0].min(), lims[:, 1].max())
        if i:
            ax.tick_params(labelleft=False)


def stress_boxes(zones) -> list[tuple[float, float, float]]:
    """Per zone ``(x0, x1, depth)``: the box of the stress metric (compare.stress: the zone and
    BOX_PAD widths each side, cut half-way to a neighbour; BOX_DEPTH widths deep)."""
    return [(lo, hi, cs.BOX_DEPTH * (b - a))
            for (a, b), (lo, hi) in zip(zones, cs.peak_windows(zones), strict=True)]


def contour_axes(res: CaseResult):
    """Analytic over FE in-plane maximum shear below the surface, one column per contact zone
    (the box of the stress metric, true aspect ratio); each column has its own colour levels."""
    stage, Q, sol = _shown_states(res)[1 if res.analytic.samples else 0]
    zones = res.analytic.normal.zones
    boxes = stress_boxes(zones)
    aspect = max((x1 - x0) / d for x0, x1, d in boxes)
    fig, axes = zone_columns(len(zones), 2, (4.2, 2 * 4.0 / aspect + 2.2), layout="compressed")
    x, y = cs.body2_xy(res.fem)
    s = res.fem.body_stress(cs.fem_step(res.fem, stage, Q), 1)
    tau = np.hypot(0.5 * (s[0] - s[1]), s[2])
    for k, (x0, x1, depth) in enumerate(boxes):
        X, Y = np.meshgrid(np.linspace(x0, x1, GRID[0]), np.linspace(-depth, 0, GRID[1]))
        tau_an = analytic.stress(sol, X, Y, nu=res.case.nu).max_shear
        m = (x >= x0 - 0.1 * depth) & (x <= x1 + 0.1 * depth) & (y >= -1.5 * depth)
        levels = np.linspace(0, np.percentile(tau_an, 99.5), CONTOUR_LEVELS)
        axes[0, k].contourf(X, Y, tau_an, levels=levels, extend="max")
        cf = axes[1, k].tricontourf(Triangulation(x[m], y[m]), tau[m], levels=levels,
                                    extend="max")
        for ax, who in zip(axes[:, k], ("analytic", "FE"), strict=True):
            ax.set(xlim=(x0, x1), ylim=(-depth, 0), aspect="equal")
            ax.set_title(f"zone {k}, {who}", fontsize=9)
        axes[1, k].set_xlabel("x")
        fig.colorbar(cf, ax=axes[:, k], orientation="horizontal", fraction=0.05,
                     label="max in-plane shear")
    for ax in axes[:, 0]:
        ax.set_ylabel("y (body 2)")
    err = res.metrics.get("stress_l2_error", float("nan"))
    when = "P0 (end of stage 1)" if stage == 1 else f"stage {stage}, Q = {Q:.4g}"
    text = (f"{res.case.name}: in-plane maximum shear in body 2 at {when}, in the box of the "
            f"stress metric (stress L2 error, worst state: {err:.3g})")
    fig.suptitle(caption(text, fig.get_figwidth(), 9), fontsize=9, y=1.0, va="bottom")
    return fig


def ruiz_axes(res: CaseResult):
    """Stick-slip map over the cycle (analytic, FE stick edges as dots) and under it the Ruiz
    parameter along the surface at the end of stage 3 (Q = -Q0), one column per contact zone
    zoomed to it (x horizontal)."""
    normal, Q0 = res.analytic.normal, res.case.Q0
    state = analytic.solve_stick(normal, res.case.mu, -Q0, Q0, allow_full_slip=True)
    fig, axes = zone_columns(len(normal.zones), 2, (4.2, 6.0), ratios=[3, 2])
    peaks = []
    for k, ((a, b), (lo, hi)) in enumerate(zip(normal.zones, zone_windows(normal.zones),
                                               strict=True)):
        stick_map_panel(axes[0, k], res, k, (lo, hi))
        rz = analytic.ruiz(state, np.linspace(lo, hi, RUIZ_POINTS))
        axes[1, k].plot(rz.x, rz.value, "-", color="tab:purple")
        axes[1, k].axvspan(a, b, color="0.93", zorder=0)
        axes[1, k].set(xlim=(lo, hi), xlabel="x")
        axes[0, k].set_title(f"zone {k}: [{a:.5g}, {b:.5g}]", fontsize=9)
        if rz.maximum > 0:
            axes[1, k].plot([rz.x_max], [rz.maximum], "o", color="tab:purple")
            axes[1, k].set_title(f"Ruiz max {rz.maximum:.3g} at x = {rz.x_max:.5g}", fontsize=9)
        else:
            axes[1, k].set_title("Ruiz parameter 0: no slip in stage 3", fontsize=9)
        peaks.append(rz.maximum)
    _share_y(axes[1])
    axes[0, 0].set_ylabel("load parameter\n(0: Q = 0, 1: Q = Q0, 2: Q = -Q0)")
    axes[1, 0].set_ylabel("Ruiz max(sxx, 0) |q| |slip|\nat Q = -Q0")
    for ax in axes[0, 1:]:
        ax.tick_params(labelleft=False)
    where = f" (largest in zone {int(np.argmax(peaks))})" if len(peaks) > 1 else ""
    text = (f"{res.case.name}: stick-slip map over the cycle (analytic: blue stick between "
            "black edges, pink slip, white open; red dots: FE stick edges at every FE step) and "
            f"the Ruiz fretting parameter at the end of stage 3{where}")
    fig.suptitle(caption(text, fig.get_figwidth(), 9), fontsize=9)
    return fig


def surface_figure(res: CaseResult) -> bytes:
    """PNG of :func:`surface_axes`."""
    return png(surface_axes(res))


def contour_figure(res: CaseResult) -> bytes:
    """PNG of :func:`contour_axes`."""
    return png(contour_axes(res))


def ruiz_figure(res: CaseResult) -> bytes | None:
    """PNG of :func:`ruiz_axes` (None without tangential load)."""
    return None if res.case.Q0 == 0 else png(ruiz_axes(res))


def stress_figures(res: CaseResult) -> dict:
    """Title -> PNG of the stress figures of a case (None entries dropped by the caller); the
    FE stress figures only for a result with body fields (not an external interface result)."""
    out = {}
    if res.fem.has_fields:
        out = {"surface sxx (body 2)": surface_figure(res),
               "subsurface max shear: analytic | FE": contour_figure(res)}
    return out | {"stick-slip map over the cycle and Ruiz parameter": ruiz_figure(res)}
