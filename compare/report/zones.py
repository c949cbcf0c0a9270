"""Per-zone figures of a case: one panel per contact zone, zoomed to it, with FE - analytic below.

Zones of a multi-zone case are narrow against the gaps between them; drawn over the whole
window they are spikes.  Here every zone gets its own column (the zone widened by
:data:`ZONE_MARGIN` of its width on each side; tractions share one y axis across the zones),
and under each traction panel the nodal error FE - analytic.  Nodes the metrics leave out (within
``metrics.SINGULAR_EXCLUSION`` of a zone width of a singular point, where the traction is
unbounded) are drawn hollow and do not set the error axis.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.cm import ScalarMappable  # noqa: E402
from matplotlib.colors import ListedColormap, Normalize  # noqa: E402

from compare import metrics as mt  # noqa: E402
from compare.fem_side import kinks  # noqa: E402
from compare.report.figures import caption, few_x_ticks, png, zone_windows  # noqa: E402
from compare.run import CaseResult  # noqa: E402

#: Colours of the shear states: Q / Q0 from -1 to 1 (viridis without its palest yellow).
Q_NORM = Normalize(-1.0, 1.0)
Q_CMAP = ListedColormap(plt.cm.viridis(np.linspace(0.0, 0.9, 256)))
#: Width (inches) of one zone column; the figure is at most MAX_WIDTH wide.
PANEL_WIDTH, MAX_WIDTH = 4.2, 13.0
#: Analytic curve samples per zone panel.
CURVE_POINTS = 600
#: Traction axis: 1.1 times the largest analytic value, at most TOP_FACTOR times its 98th
#: percentile (an unbounded singular edge would flatten the rest), at least the largest
#: regular FE value.
TOP_FACTOR = 1.6


def _grid(n_zones: int, traction_rows: int):
    """Axes: for each traction row, a traction panel and an error panel under it, per zone."""
    width = min(PANEL_WIDTH * n_zones + 1.2, MAX_WIDTH)
    ratios = [3, 1.3] * traction_rows
    fig, axes = plt.subplots(2 * traction_rows, n_zones, squeeze=False, sharex="col",
                             figsize=(width, 3.2 * traction_rows + 0.6),
                             gridspec_kw={"height_ratios": ratios}, layout="constrained")
    few_x_ticks(axes)
    for row in range(2 * traction_rows):  # one y axis per row across the zones
        for ax in axes[row, 1:]:
            ax.sharey(axes[row, 0])
            ax.tick_params(labelleft=False)
    return fig, axes


def _curve_x(lo: float, hi: float, zone: tuple[float, float]) -> np.ndarray:
    a, b = zone
    inside = np.linspace(a, b, CURVE_POINTS)[1:-1]
    return np.unique(np.r_[np.linspace(lo, hi, CURVE_POINTS // 2), inside, a, b])


def _regular(res: CaseResult, x: np.ndarray) -> np.ndarray:
    ns = res.analytic.normal
    return mt.regular_mask(x, ns.zones, mt.singular_points(ns.zones, ns.singular,
                                                          kinks(res.case)))


def _error_panel(ax, x: np.ndarray, err: np.ndarray, regular: np.ndarray, color) -> float:
    """Nodal error (filled: in the metrics, hollow: next to a singular point); returns the
    largest regular |error| (for the shared error axis)."""
    ax.plot(x[regular], err[regular], "o-", ms=2.2, lw=0.6, color=color)
    ax.plot(x[~regular], err[~regular], "o", ms=3, mfc="none", color=color)
    ax.axhline(0, color="0.6", lw=0.6)
    return float(np.max(np.abs(err[regular]), initial=0.0))


def _mark_zone(ax, zone, fe_zone) -> None:
    ax.axvspan(*zone, color="0.93", zorder=0)
    if fe_zone is not None:
        for e in fe_zone:
            ax.axvline(e, color="tab:red", lw=0.7, ls=":")


def _set_error_limits(axes_row, worst: float) -> None:
    if worst > 0:
        axes_row[0].set_ylim(-1.25 * worst, 1.25 * worst)


def _traction_top(curves: list[np.ndarray], fe_regular: list[np.ndarray]) -> float:
    vals = np.abs(np.concatenate(curves))
    vals = vals[np.isfinite(vals) & (vals > 0)]
    top = min(1.1 * vals.max(), TOP_FACTOR * np.percentile(vals, 98)) if vals.size else 1.0
    fe = np.abs(np.concatenate(fe_regular)) if fe_regular else np.zeros(0)
    return max(top, 1.05 * float(fe.max(initial=0.0)))


def pressure_figure(res: CaseResult) -> bytes:
    """PNG of :func:`pressure_axes`."""
    return png(pressure_axes(res))


def shear_figure(res: CaseResult) -> bytes | None:
    """PNG of :func:`shear_axes` (None without tangential load)."""
    fig = shear_axes(res)
    return None if fig is None else png(fig)


def pressure_axes(res: CaseResult):
    """Stage-1 end, per zone: analytic pressure (line), FE nodes (dots), FE - analytic below.

    Grey band: the analytic zone; red dotted lines: the FE edges.  Returns the figure (axes
    ``[row, zone]``: row 0 pressure, row 1 error).
    """
    ns, end = res.analytic.normal, res.fem.stage(1)[-1]
    it = end.interface
    fe_zones = [None if j is None else end.contact_zones[j]
                for j in mt.match_zones(ns.zones, list(end.contact_zones))]
    fig, axes = _grid(len(ns.zones), 1)
    curves, fe_reg, worst = [], [], 0.0
    for k, (lo, hi) in enumerate(zone_windows(ns.zones)):
        ax, err = axes[0, k], axes[1, k]
        x = _curve_x(lo, hi, ns.zones[k])
        curves.append(ns.pressure(x))
        m = (it.x >= lo) & (it.x <= hi)
        reg = _regular(res, it.x[m])
        fe_reg.append(it.p[m][reg])
        _mark_zone(ax, ns.zones[k], fe_zones[k])
        ax.plot(x, curves[-1], "k-", lw=1.2)
        ax.plot(it.x[m], it.p[m], "o", ms=2.5, color="tab:red")
        worst = max(worst, _error_panel(err, it.x[m], it.p[m] - ns.pressure(it.x[m]), reg,
                                        "tab:red"))
        ax.set_xlim(lo, hi)
        ax.set_title(f"zone {k}: [{ns.zones[k][0]:.5g}, {ns.zones[k][1]:.5g}]", fontsize=9)
        err.set_xlabel("x")
    axes[0, 0].set_ylim(0, _traction_top(curves, fe_reg))
    _set_error_limits(axes[1], worst)
    axes[0, 0].set_ylabel("p(x)")
    axes[1, 0].set_ylabel("p_FE - p_an")
    text = (f"{res.case.name}: pressure at P = {res.case.P:g}; black line: analytic, red dots: "
            "FE nodes (hollow: next to a singular point, left out of the metrics); grey band: "
            "analytic zone, red dotted lines: FE edges")
    fig.suptitle(caption(text, fig.get_figwidth(), 9), fontsize=9)
    return fig


def shear_axes(res: CaseResult):
    """Stages 2 and 3, per zone: analytic shear (lines) and FE shear (dots) at the sampled Q,
    with FE - analytic under each stage.  Returns the figure (rows: stage-2 shear, its error,
    stage-3 shear, its error) or None without tangential load."""
    samples = res.analytic.samples
    if not samples:
        return None
    ns = res.analytic.normal
    fig, axes = _grid(len(ns.zones), 2)
    for row, stage in enumerate((2, 3)):
        states = [s for s in samples if s.stage == stage]
        _shear_rows(res, axes[2 * row], axes[2 * row + 1], states)
        axes[2 * row, 0].set_ylabel(f"stage {stage}: q(x)")
        axes[2 * row + 1, 0].set_ylabel("q_FE - q_an")
    for err in axes[-1]:
        err.set_xlabel("x")
    for k, zone in enumerate(ns.zones):
        axes[0, k].set_title(f"zone {k}: [{zone[0]:.5g}, {zone[1]:.5g}]", fontsize=9)
    fig.colorbar(ScalarMappable(Q_NORM, Q_CMAP), ax=axes, label="Q / Q0 of the state",
                 aspect=40)
    text = (f"{res.case.name}: shear at the sampled Q, coloured by Q / Q0; lines: analytic, "
            "dots: FE nodes (hollow: next to a singular point, left out of the metrics)")
    fig.suptitle(caption(text, fig.get_figwidth(), 9), fontsize=9)
    return fig


def _shear_rows(res: CaseResult, q_axes, e_axes, states) -> None:
    ns = res.analytic.normal
    colors = [Q_CMAP(Q_NORM(st.Q / res.case.Q0)) for st in states]
    curves, fe_reg, worst = [], [], 0.0
    for k, (lo, hi) in enumerate(zone_windows(ns.zones)):
        x = _curve_x(lo, hi, ns.zones[k])
        q_axes[k].axvspan(*ns.zones[k], color="0.93", zorder=0)
        for st, col in zip(states, colors, strict=False):
            it = res.fem.at(st.stage, Q=st.Q).interface
            m = (it.x >= lo) & (it.x <= hi)
            reg = _regular(res, it.x[m])
            curves.append(st.shear(x))
            fe_reg.append(it.q[m][reg])
            q_axes[k].plot(x, curves[-1], "-", color=col, lw=1.1)
            q_axes[k].plot(it.x[m], it.q[m], "o", ms=2.0, color=col)
            worst = max(worst, _error_panel(e_axes[k], it.x[m], it.q[m] - st.shear(it.x[m]),
                                            reg, col))
        q_axes[k].axhline(0, color="0.7", lw=0.6)
        q_axes[k].set_xlim(lo, hi)
    top = _traction_top(curves, fe_reg) if curves else 1.0
    q_axes[0].set_ylim(-top, top)
    _set_error_limits(e_axes, worst)
