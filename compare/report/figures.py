"""Matplotlib figures of a case result (PNG bytes; the Agg backend, no display needed).

The per-zone pressure and shear figures are in :mod:`compare.report.zones`, the contact region
in :mod:`compare.report.region`.
"""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import analytic  # noqa: E402
from compare._memo import memo  # noqa: E402
from compare.run import CaseResult  # noqa: E402

DPI = 90
CYCLE_POINTS = 12  # analytic load steps per leg of the cycle plot (analytic.cycle)


def png(fig) -> bytes:
    """Render and close a figure."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def stick_cycle_figure(res: CaseResult) -> bytes | None:
    """Stick-zone edges over the loading cycle: analytic curves, FE points at every FE step."""
    if res.case.Q0 == 0:
        return None
    Q0 = res.case.Q0
    t_an, edges = analytic_stick_edges(res)
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    for k, (a, b) in enumerate(res.analytic.normal.zones):
        for j in (0, 1):
            ax.plot(t_an, edges[:, k, j], "k-", lw=1.1, label="analytic" if k == j == 0 else None)
        ax.axhspan(a, b, color="0.92", zorder=0)
    for step in res.fem.stage(2) + res.fem.stage(3):
        t = cycle_parameter(step.stage, step.Q, Q0)
        for s in step.stick_zones:
            if s is not None:
                ax.plot([t, t], s, "o", ms=2.5, color="tab:red")
    ax.plot([], [], "o", ms=2.5, color="tab:red", label="FE")
    ax.set(xlabel="load parameter (1: Q = Q0, 2: Q = -Q0)", ylabel="stick-zone edges c, d",
           title=f"{res.case.name}: stick zones over the cycle (grey: contact zones)")
    ax.legend(fontsize=8)
    return png(fig)


def analytic_cycle(res: CaseResult):
    """The analytic load cycle of the figures (solved once per case: two figures draw it)."""
    normal, mu, Q0 = res.analytic.normal, res.case.mu, res.case.Q0
    return memo(normal, ("cycle", mu, Q0, CYCLE_POINTS),
                lambda: analytic.cycle(normal, mu, Q0, n=3 * CYCLE_POINTS + 1))


def analytic_stick_edges(res: CaseResult) -> tuple[np.ndarray, np.ndarray]:
    """The analytic cycle's stages 2 and 3 (those the FE history covers): each sample's
    :func:`cycle_parameter` and its stick edges (n, zones, 2; nan where a zone is in full slip)."""
    cyc = analytic_cycle(res)
    keep = cyc.stage <= 3
    t = np.array([cycle_parameter(st, q, res.case.Q0)
                  for st, q in zip(cyc.stage[keep], cyc.Q[keep], strict=True)])
    return t, cyc.stick_edges[keep]


def cycle_parameter(stage: int, Q: float, Q0: float) -> float:
    """Abscissa of a tangential state along the cycle: Q / Q0 in stage 2 (0 -> 1), then
    1 + (Q0 - Q) / (2 Q0) in stage 3 (1 -> 2 as Q goes Q0 -> -Q0)."""
    return Q / Q0 if stage == 2 else 1.0 + (Q0 - Q) / (2 * Q0)


def convergence_figure(study) -> bytes:
    """Log-log errors against the study parameter with observed orders; segments where an error
    stalls (local order < STALL_ORDER) in red, the expected pressure order as a reference slope,
    the Richardson-extrapolated edge error as a dotted line (or why it was refused)."""
    from compare.convergence import STALL_ORDER

    fig, ax = plt.subplots(figsize=(6.5, 4))
    h = np.asarray(study.parameter)
    for name, errs in study.errors.items():
        e = np.asarray(errs, float)
        if np.all(~np.isfinite(e)) or np.all(h <= 0):
            continue
        line, = ax.loglog(h, e, "o-", label=f"{name} (order {study.orders[name]:.2f})")
        for i, p in enumerate(study.local_orders[name]):
            if np.isfinite(p) and p < STALL_ORDER:
                ax.loglog(h[i:i + 2], e[i:i + 2], "-", color="red", lw=3, alpha=0.5)
                ax.annotate(f"stalls ({p:.2f})", (h[i + 1], e[i + 1]), fontsize=7, color="red",
                            xytext=(4, -10), textcoords="offset points")
    _expected_slope(ax, study, h)
    _richardson_line(ax, study)
    xlabel = {"h": "finest element length h", "penalty": "1 / penalty factor",
              "domain": "1 / size factor"}[study.kind]
    ax.set(xlabel=xlabel, ylabel="error",
           title=f"{study.case_name}: {study.kind}-convergence\n{study.verdict()}"[:160])
    ax.title.set_fontsize(8)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
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


def _richardson_line(ax, study) -> None:
    if study.kind != "h":
        return
    if np.isfinite(study.richardson_error) and study.richardson_error > 0:
        ax.axhline(study.richardson_error, ls=":", color="k", lw=1,
                   label=f"Richardson edge error {study.richardson_error:.2e}")
    elif study.richardson_reason:
        ax.text(0.02, 0.02, f"Richardson refused: {study.richardson_reason}"[:90],
                transform=ax.transAxes, fontsize=6, color="red")


def fig5_figure(rows: list[dict]) -> bytes:
    """Paper Fig. 5: actual vs overlapped extent against P per angle pair, and Pe vs kappa."""
    n = len(rows)
    fig, axes = plt.subplots(1, n + 1, figsize=(4.2 * (n + 1), 3.6))
    for ax, r in zip(axes[:n], rows, strict=True):
        ax.plot(r["P"], r["actual"], "k-", label="actual (consistency)")
        ax.plot(r["P"], r["overlapped"], "k--", label="overlapped")
        if r.get("fem_P"):
            ax.plot(r["fem_P"], r["fem_extent"], "o", color="tab:red", ms=4, label="FE")
        ax.set(xlabel="P", ylabel="extent b - a",
               title=f"({r['label']}) phi1={r['phi1']}, phi2={r['phi2']}")
        ax.legend(fontsize=7)
    for r in rows:
        axes[n].plot(r["kappa"], r["Pe"], "-", label=f"({r['label']})")
    axes[n].set(xlabel="kappa = actual extent / c", ylabel="Pe (%)", title="(d) percent error")
    axes[n].legend(fontsize=7)
    fig.tight_layout()
    return png(fig)
