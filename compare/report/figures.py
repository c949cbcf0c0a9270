"""Matplotlib figures of a case result (PNG bytes; the Agg backend, no display needed).

The per-zone pressure and shear figures are in :mod:`compare.report.zones`, the contact region
in :mod:`compare.report.region`.
"""

from __future__ import annotations

import io
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

import analytic  # noqa: E402
from compare._memo import memo  # noqa: E402
from compare.run import CaseResult  # noqa: E402

DPI = 100
CYCLE_POINTS = 12  # analytic load steps per leg of the cycle plot (analytic.cycle)
#: Each zone panel shows the zone widened by this fraction of its width on each side.
ZONE_MARGIN = 0.3
#: Width (inches) of the widest figure (one column per zone).
MAX_WIDTH = 13.0
#: Most x tick labels of a zone panel.
X_TICKS = 5
#: Shades of the stick and slip parts of a contact zone (stick-zone and stick-slip figures).
STICK_SHADE, SLIP_SHADE = "#bcd3ee", "#f4cccc"


def png(fig) -> bytes:
    """Render and close a figure."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def zone_windows(zones) -> list[tuple[float, float]]:
    """The x range of each zone's panel: the zone widened by ZONE_MARGIN of its width."""
    return [(a - ZONE_MARGIN * (b - a), b + ZONE_MARGIN * (b - a)) for a, b in zones]


def caption(text: str, width_in: float, fontsize: float) -> str:
    """``text`` wrapped to a figure ``width_in`` inches wide (no title is cut off or widens
    the figure past its panels)."""
    return textwrap.fill(text, max(20, int(width_in * 72 / (0.6 * fontsize))))


def zone_columns(n_zones: int, rows: int, panel: tuple[float, float], ratios=None,
                 sharex: bool = True, layout: str = "constrained"):
    """A figure with one column per contact zone (``rows`` rows; ``panel`` is the size in inches
    of one column's panels), at most MAX_WIDTH wide; ``layout="compressed"`` for panels of a
    fixed (true) aspect ratio."""
    width = min(panel[0] * n_zones + 1.0, MAX_WIDTH)
    fig, axes = plt.subplots(rows, n_zones, squeeze=False, sharex="col" if sharex else False,
                             figsize=(width, panel[1]), gridspec_kw={"height_ratios": ratios},
                             layout=layout)
    few_x_ticks(axes)
    return fig, axes


def few_x_ticks(axes) -> None:
    """At most X_TICKS x tick labels per panel (narrow zone panels crowd them otherwise)."""
    for ax in np.ravel(axes):
        ax.xaxis.set_major_locator(MaxNLocator(X_TICKS))


def stick_map_panel(ax, res: CaseResult, k: int, window: tuple[float, float]) -> None:
    """Stick-slip map of zone ``k`` over the cycle, x horizontal and the load parameter
    (:func:`cycle_parameter`) upwards: the analytic stick region (blue, between black edge
    lines) and slip (pink) inside the analytic zone, the FE stick edges at every FE step (red
    dots).  Stage 3 starts at the load reversal (t = 1) with the whole zone stuck (no slip
    increment yet: Jager-Ciavarella), so stages 2 and 3 are drawn apart."""
    a, b = res.analytic.normal.zones[k]
    ax.axvspan(a, b, color=SLIP_SHADE, zorder=0)
    t, stage, edges = analytic_stick_edges(res)
    for st in (2, 3):
        m = stage == st
        tt, c, d = t[m], edges[m, k, 0], edges[m, k, 1]
        if st == 3:
            tt, c, d = np.r_[1.0, tt], np.r_[a, c], np.r_[b, d]
        ax.fill_betweenx(tt, c, d, where=np.isfinite(c), color=STICK_SHADE, lw=0, zorder=1)
        ax.plot(c, tt, "k-", lw=0.9)
        ax.plot(d, tt, "k-", lw=0.9)
    Q0, lo, hi = res.case.Q0, window[0], window[1]
    pts = [(e, cycle_parameter(s.stage, s.Q, Q0)) for s in res.fem.stage(2) + res.fem.stage(3)
           for z in s.stick_zones if z is not None for e in z if lo <= e <= hi]
    if pts:  # every FE zone's edges in the window: FE zones need not pair with the analytic ones
        ax.plot(*zip(*pts, strict=True), "o", ms=2.2, color="tab:red")
    ax.set(xlim=window, ylim=(0, 2))


def analytic_cycle(res: CaseResult):
    """The analytic load cycle of the figures (solved once per case: two figures draw it)."""
    normal, mu, Q0 = res.analytic.normal, res.case.mu, res.case.Q0
    return memo(normal, ("cycle", mu, Q0, CYCLE_POINTS),
                lambda: analytic.cycle(normal, mu, Q0, n=3 * CYCLE_POINTS + 1))


def analytic_stick_edges(res: CaseResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The analytic cycle's stages 2 and 3 (those the FE history covers): each sample's
    :func:`cycle_parameter`, its stage and its stick edges (n, zones, 2; nan where a zone is in
    full slip)."""
    cyc = analytic_cycle(res)
    keep = cyc.stage <= 3
    t = np.array([cycle_parameter(st, q, res.case.Q0)
                  for st, q in zip(cyc.stage[keep], cyc.Q[keep], strict=True)])
    return t, cyc.stage[keep], cyc.stick_edges[keep]


def cycle_parameter(stage: int, Q: float, Q0: float) -> float:
    """Abscissa of a tangential state along the cycle: Q / Q0 in stage 2 (0 -> 1), then
    1 + (Q0 - Q) / (2 Q0) in stage 3 (1 -> 2 as Q goes Q0 -> -Q0)."""
    return Q / Q0 if stage == 2 else 1.0 + (Q0 - Q) / (2 * Q0)


def convergence_figure(study) -> bytes:
    """Log-log errors against the study parameter with observed orders (metrics the case does
    not have left out); segments where an error stalls (local order < STALL_ORDER) in red, the
    expected pressure order as a reference slope, the Richardson-extrapolated edge error as a
    dotted line; the verdict and the Richardson line (the CLI's words) under the plot."""
    from compare.convergence import STALL_ORDER

    fig, ax = plt.subplots(figsize=(6.5, 4))
    h = np.asarray(study.parameter)
    for name, errs in study.errors.items():
        e = np.asarray(errs, float)
        if not study.applies(name) or np.all(h <= 0):
            continue
        ax.loglog(h, e, "o-", label=f"{name} (order {study.orders[name]:.2f})")
        for i, p in enumerate(study.local_orders[name]):
            if np.isfinite(p) and p < STALL_ORDER:
                ax.loglog(h[i:i + 2], e[i:i + 2], "-", color="red", lw=3, alpha=0.5)
                ax.annotate(f"stalls ({p:.2f})", (h[i + 1], e[i + 1]), fontsize=7, color="red",
                            xytext=(4, -10), textcoords="offset points")
    _expected_slope(ax, study, h)
    if study.kind == "h" and np.isfinite(study.richardson_error) and study.richardson_error > 0:
        ax.axhline(study.richardson_error, ls=":", color="k", lw=1,
                   label=f"Richardson edge error {study.richardson_error:.2e}")
    xlabel = {"h": "finest element length h", "penalty": "1 / penalty factor",
              "domain": "1 / size factor"}[study.kind]
    ax.set(xlabel=xlabel, ylabel="error (relative)")
    ax.set_title(f"{study.case_name}: {study.kind}-convergence", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)
    note = "; ".join(t for t in (study.verdict(), study.richardson_line()) if t)
    ax.annotate(caption(note, 8.0, 8), (0.0, 0.0), xycoords="axes fraction", xytext=(-40, -40),
                textcoords="offset points", fontsize=8, va="top", ha="left")
    return png(fig)


def _expected_slope(ax, study, h: np.ndarray) -> None:
    """Dashed reference line of the expected pressure order through the coarsest point."""
    if "pressure_l2_error" not in study.expected:
        return
    e0 = study.errors["pressure_l2_error"][0]
    if not (np.isfinite(e0) and e0 > 0):
        return
    order = study.expected["pressure_l2_error"][0]
    ax.loglog(h, e0 * (h / h[0]) ** order, "--", color="0.5", lw=1,
              label=f"expected pressure order {order:g}")


def fig5_figure(rows: list[dict]) -> bytes:
    """Paper Fig. 5: actual vs overlapped extent against P A / c per angle pair (FE points at
    the FE loads), and Pe vs kappa; one legend under the panels."""
    n = len(rows)
    fig, axes = plt.subplots(1, n + 1, figsize=(3.6 * (n + 1), 3.6), layout="constrained")
    for ax, r in zip(axes[:n], rows, strict=True):
        ax.plot(r["PAc"], r["actual"], "k-", label="actual (consistency conditions)")
        ax.plot(r["PAc"], r["overlapped"], "k--", label="overlapped (free interpenetration)")
        if r.get("fem_PAc"):
            ax.plot(r["fem_PAc"], r["fem_extent"], "o", color="tab:red", ms=4, label="FE")
        ax.set(xlabel="P A / c", ylabel="extent b - a of the right zone",
               title=f"({r['label']}) phi1 = {r['phi1']}, phi2 = {r['phi2']}")
        ax.title.set_fontsize(9)
    for r in rows:
        axes[n].plot(r["kappa"], r["Pe"], "-", label=f"Pe of pair ({r['label']})")
    axes[n].set(xlabel="kappa = actual extent / c", ylabel="Pe (%)", title="(d) percent error")
    axes[n].title.set_fontsize(9)
    outside_legend(fig, axes, ncol=3)
    return png(fig)


def outside_legend(fig, axes, ncol: int, **kw) -> None:
    """One legend for all ``axes`` (entries with the same label once) under the figure, where it
    covers no data."""
    seen: dict = {}
    for ax in np.ravel(axes):
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(lab, h)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="outside lower center", ncol=ncol,
                   fontsize=8, frameon=False, **kw)

