"""Report figures of the stresses in body 2 (issue 17): PNG bytes, or None when not applicable.

- surface sxx, FE nodes against the analytic curve, at the end of stage 1 and at the last
  sampled Q of stages 2 and 3;
- a contour pair (analytic | FE) of the in-plane maximum shear below the surface at the end of
  stage 2 (stage 1 without tangential load), with the metric in the title;
- the analytic stick-slip map beside the Ruiz parameter along the surface at the end of stage 3
  (``Q = -Q0``), its maximum marked.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

import analytic  # noqa: E402
from compare import stress as cs  # noqa: E402
from compare.report.figures import analytic_stick_edges, png  # noqa: E402
from compare.run import CaseResult  # noqa: E402

CONTOUR_LEVELS = 21
GRID = (160, 80)  # analytic contour grid (x, depth)


def _shown_states(res: CaseResult) -> list[tuple[int, float, object]]:
    """Stage-1 end and the last sampled state of stages 2 and 3."""
    states = cs.analytic_states(res.case, res.analytic)
    out = [states[0]]
    for stage in (2, 3):
        out += [s for s in states if s[0] == stage][-1:]
    return out


def surface_figure(res: CaseResult) -> bytes:
    """Surface sxx of body 2: analytic lines, FE nodal points."""
    fig, ax = plt.subplots(figsize=(7.5, 3.4))
    window = cs.surface_window(res.analytic.normal)
    colors = ("k", "tab:blue", "tab:red")
    for (stage, Q, sol), col in zip(_shown_states(res), colors, strict=False):
        xa, sa = cs.analytic_surface(sol, window)
        step = cs.fem_step(res.fem, stage, Q)
        xf, sf = cs.fem_surface(res.fem, step, window)
        label = "P0, Q = 0" if stage == 1 else f"stage {stage}, Q/Q0 = {Q / res.case.Q0:.2f}"
        ax.plot(xa, sa, "-", color=col, lw=1.2, label=label)
        ax.plot(xf, sf, "o", ms=2.2, color=col)
    ax.axhline(0, color="0.7", lw=0.6)
    ax.set(xlabel="x", ylabel="sxx(x, 0) of body 2",
           title=f"{res.case.name}: surface sxx (lines analytic, dots FE; tension > 0)")
    ax.legend(fontsize=7)
    return png(fig)


def contour_figure(res: CaseResult) -> bytes:
    """Analytic | FE in-plane maximum shear below the surface, same colour levels."""
    stage, Q, sol = _shown_states(res)[1 if res.analytic.samples else 0]
    zones = res.analytic.normal.zones
    lo, hi = zones[0][0], zones[-1][1]
    w = max(b - a for a, b in zones)
    x0, x1 = lo - cs.BOX_PAD * w, hi + cs.BOX_PAD * w
    X, Y = np.meshgrid(np.linspace(x0, x1, GRID[0]), np.linspace(-cs.BOX_DEPTH * w, 0, GRID[1]))
    tau_an = analytic.stress(sol, X, Y, nu=res.case.nu).max_shear
    x, y = cs.body2_xy(res.fem)
    step = cs.fem_step(res.fem, stage, Q)
    s = res.fem.body_stress(step, 1)
    m = (x >= x0) & (x <= x1) & (y >= -2 * cs.BOX_DEPTH * w)  # graded rows: overshoot, clip
    tau_fe = np.hypot(0.5 * (s[0, m] - s[1, m]), s[2, m])
    levels = np.linspace(0, np.percentile(tau_an, 99.5), CONTOUR_LEVELS)
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6), sharey=True)
    axes[0].contourf(X, Y, tau_an, levels=levels, extend="max")
    cf = axes[1].tricontourf(Triangulation(x[m], y[m]), tau_fe, levels=levels, extend="max")
    fig.colorbar(cf, ax=axes, label="max in-plane shear")
    err = res.metrics.get("stress_l2_error", float("nan"))
    when = "P0" if stage == 1 else f"stage {stage}, Q = {Q:.4g}"
    axes[0].set(title=f"analytic ({when})", xlabel="x", ylabel="y (body 2)")
    axes[1].set(title=f"FE (stress L2 error, worst state: {err:.3g})", xlabel="x",
                ylim=(-cs.BOX_DEPTH * w, 0))
    return png(fig)


def ruiz_figure(res: CaseResult) -> bytes | None:
    """Analytic stick-slip map beside the Ruiz parameter at the end of stage 3 (x vertical)."""
    if res.case.Q0 == 0:
        return None
    normal, Q0 = res.analytic.normal, res.case.Q0
    t, edges = analytic_stick_edges(res)
    rz = analytic.ruiz(analytic.solve_stick(normal, res.case.mu, -Q0, Q0, allow_full_slip=True))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True,
                             gridspec_kw={"width_ratios": [3, 2]})
    for k, (a, b) in enumerate(normal.zones):
        for j in (0, 1):
            axes[0].plot(t, edges[:, k, j], "k-", lw=1.1)
        for ax in axes:
            ax.axhspan(a, b, color="0.92", zorder=0)
    axes[0].set(xlabel="load parameter (1: Q = Q0, 2: Q = -Q0)", ylabel="x",
                title="stick zones (analytic; grey: contact zones)")
    axes[1].plot(rz.value, rz.x, "-", color="tab:purple")
    axes[1].plot([rz.maximum], [rz.x_max], "o", color="tab:purple")
    axes[1].set(xlabel="max(sxx, 0) |q| |slip|",
                title=f"Ruiz at Q = -Q0: max {rz.maximum:.3g} at x = {rz.x_max:.4g}")
    return png(fig)


def stress_figures(res: CaseResult) -> dict:
    """Title -> PNG of the stress figures of a case (None entries dropped by the caller); the
    FE stress figures only for a result with body fields (not an external interface result)."""
    out = {}
    if res.fem.has_fields:
        out = {"surface sxx (body 2)": surface_figure(res),
               "subsurface max shear: analytic | FE": contour_figure(res)}
    return out | {"stick-slip map and Ruiz parameter": ruiz_figure(res)}
