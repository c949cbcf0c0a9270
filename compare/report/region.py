"""The contact region of a case: the stress field around the contact and the interface status.

The whole bodies are many times wider than the contact (``size_factor``), so a picture of them
shows the contact as a few pixels.  This figure shows a box of about three contact spans
(:data:`REGION_SPANS`) around the contact, coloured by sigma_xx of both bodies on the undeformed
geometry, and under it the interface status along x: the FE nodes (open / stick / slip) and the
analytic contact and stick zones at the same load.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

from compare.analytic_side import stick_state  # noqa: E402
from compare.report.figures import png  # noqa: E402
from compare.run import CaseResult  # noqa: E402

#: Width of the pictured box in contact spans (first to last analytic edge); height half that.
REGION_SPANS = 3.0
#: Colour limits: this percentile of |sigma_xx| in the box (singular edges are unbounded).
STRESS_PERCENTILE = 98.0
STATUS_COLORS = {0: "0.85", 1: "tab:blue", 2: "tab:red"}  # open, stick, slip
STATUS_NAMES = {0: "open", 1: "stick", 2: "slip"}


def region_step(res: CaseResult):
    """The FE step pictured: the end of stage 2 (Q = Q0), or of stage 1 without Q."""
    return res.fem.stage(2)[-1] if res.fem.stage(2) else res.fem.stage(1)[-1]


def region_box(res: CaseResult) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of the picture: REGION_SPANS contact spans wide, centred."""
    zones = res.analytic.normal.zones
    lo, hi = zones[0][0], zones[-1][1]
    c, w = 0.5 * (lo + hi), 0.5 * REGION_SPANS * (hi - lo)
    return c - w, c + w, -0.5 * w, 0.5 * w


def _stress_field(res: CaseResult, step, box) -> tuple[Triangulation, np.ndarray]:
    """Triangulated sigma_xx of both bodies (nodal values) on the cells touching the box."""
    from fem.vtk import bodies_mesh

    mesh = bodies_mesh(res.fem, step)
    xy, quads = mesh.points[:, :2], mesh.cells[0].data
    sxx = mesh.point_data["stress"][:, 0]
    cx, cy = xy[quads, 0], xy[quads, 1]
    near = ((cx.max(1) >= box[0]) & (cx.min(1) <= box[1]) & (cy.max(1) >= box[2])
            & (cy.min(1) <= box[3]))
    q = quads[near]
    tri = Triangulation(xy[:, 0], xy[:, 1], np.r_[q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return tri, sxx


def _field_panel(ax, res: CaseResult, step, box):
    tri, sxx = _stress_field(res, step, box)
    used = np.unique(tri.triangles)
    lim = float(np.percentile(np.abs(sxx[used]), STRESS_PERCENTILE)) or 1.0
    art = ax.tripcolor(tri, np.clip(sxx, -lim, lim), shading="gouraud", cmap="RdBu_r",
                       norm=TwoSlopeNorm(0.0, -lim, lim))
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_ylabel("y (body 1 above, body 2 below)")
    return art


def _status_panel(ax, res: CaseResult, step) -> None:
    it = step.interface
    for s, col in STATUS_COLORS.items():
        m = it.status == s
        ax.bar(it.x[m], 0.8, width=it.w[m], bottom=1.1, color=col, linewidth=0)
    ns = res.analytic.normal
    ax.barh(0.5, it.x[-1] - it.x[0], left=it.x[0], height=0.8, color=STATUS_COLORS[0],
            linewidth=0)
    sticks = (stick_state(ns, res.case.mu, step.Q).stick_zones if step.stage == 2 and
              step.Q > 0 else [None if step.stage == 2 else z for z in ns.zones])
    for (a, b), st in zip(ns.zones, sticks, strict=True):
        ax.barh(0.5, b - a, left=a, height=0.8, color=STATUS_COLORS[2 if step.stage == 2
                                                                    else 1], linewidth=0)
        if st is not None:
            ax.barh(0.5, st[1] - st[0], left=st[0], height=0.8, color=STATUS_COLORS[1],
                    linewidth=0)
    ax.set_ylim(0, 2)
    ax.set_yticks([0.5, 1.5], ["analytic", "FE"])
    ax.set_xlabel("x")
    ax.legend(handles=[Patch(color=c, label=STATUS_NAMES[s]) for s, c in STATUS_COLORS.items()],
              loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=3, fontsize=7, frameon=False)


def region_figure(res: CaseResult) -> bytes | None:
    """PNG of :func:`region_axes`; None for a result without body fields (an external code's
    interface-only result), which has no stress field to draw."""
    if not res.fem.has_fields:
        return None
    return png(region_axes(res))


def region_axes(res: CaseResult):
    """sigma_xx around the contact and the interface status, at :func:`region_step`; returns
    the figure (axes: field, status strip, colour bar)."""
    step = region_step(res)
    box = region_box(res)
    fig, (ax, st) = plt.subplots(2, 1, sharex=True, figsize=(10, 5.2),
                                 gridspec_kw={"height_ratios": [5, 1]})
    art = _field_panel(ax, res, step, box)
    _status_panel(st, res, step)
    fig.colorbar(art, ax=[ax, st], label="sigma_xx (tension > 0)", pad=0.01)
    load = f"Q = {step.Q:.4g} (end of stage 2)" if step.stage == 2 else f"P = {step.P:.4g}"
    ax.set_title(f"{res.case.name}: contact region at {load}, sigma_xx on the undeformed "
                 "geometry", fontsize=9)
    return fig
