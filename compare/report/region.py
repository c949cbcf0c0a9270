"""The contact region of a case: the stress field around each contact zone and the interface
status.

The whole bodies are many times wider than the contact (``size_factor``) and the zones of a
multi-zone case are narrow against the gaps between them, so a picture of the bodies, or of all
zones at once, shows each zone as a few pixels.  This figure has one column per contact zone: a
box of the zone and :data:`REGION_PAD` zone widths on each side (cut half-way to a neighbour),
:data:`REGION_DEPTH` zone widths into each body, at true aspect ratio, coloured by sigma_xx of
both bodies on the undeformed geometry; under it the interface status along x: the FE nodes
(open / stick / slip, each node drawn over its own part of the interface, from midpoint to
midpoint between its neighbours) and the analytic contact and stick zones at the same load.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402
from matplotlib.tri import Triangulation  # noqa: E402

from compare.analytic_side import stick_state  # noqa: E402
from compare.report.figures import caption, png, zone_columns  # noqa: E402
from compare.run import CaseResult  # noqa: E402

#: Each zone's box: the zone and this many zone widths on each side (cut half-way to a
#: neighbouring zone), and this many zone widths into each body.
REGION_PAD, REGION_DEPTH = 0.5, 1.0
#: Colour limits: this percentile of |sigma_xx| in the box (singular edges are unbounded).
STRESS_PERCENTILE = 98.0
STATUS_COLORS = {0: "0.85", 1: "tab:blue", 2: "tab:red"}  # open, stick, slip


def region_step(res: CaseResult):
    """The FE step pictured: the end of stage 2 (Q = Q0), or of stage 1 without Q."""
    return res.fem.stage(2)[-1] if res.fem.stage(2) else res.fem.stage(1)[-1]


def region_boxes(res: CaseResult) -> list[tuple[float, float, float, float]]:
    """(xmin, xmax, ymin, ymax) of each zone's picture (REGION_PAD, REGION_DEPTH)."""
    zones = res.analytic.normal.zones
    out = []
    for k, (a, b) in enumerate(zones):
        w = b - a
        lo, hi = a - REGION_PAD * w, b + REGION_PAD * w
        if k > 0:
            lo = max(lo, 0.5 * (zones[k - 1][1] + a))
        if k + 1 < len(zones):
            hi = min(hi, 0.5 * (b + zones[k + 1][0]))
        out.append((lo, hi, -REGION_DEPTH * w, REGION_DEPTH * w))
    return out


def _stress_field(mesh, box) -> tuple[Triangulation, np.ndarray]:
    """Triangulated sigma_xx of both bodies (nodal values of ``fem.vtk.bodies_mesh``) on the
    cells touching the box."""
    xy, quads = mesh.points[:, :2], mesh.cells[0].data
    sxx = mesh.point_data["stress"][:, 0]
    cx, cy = xy[quads, 0], xy[quads, 1]
    near = ((cx.max(1) >= box[0]) & (cx.min(1) <= box[1]) & (cy.max(1) >= box[2])
            & (cy.min(1) <= box[3]))
    q = quads[near]
    tri = Triangulation(xy[:, 0], xy[:, 1], np.r_[q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return tri, sxx


def _field_panel(ax, mesh, box):
    tri, sxx = _stress_field(mesh, box)
    used = np.unique(tri.triangles)
    lim = float(np.percentile(np.abs(sxx[used]), STRESS_PERCENTILE)) or 1.0
    art = ax.tripcolor(tri, np.clip(sxx, -lim, lim), shading="gouraud", cmap="RdBu_r",
                       norm=TwoSlopeNorm(0.0, -lim, lim))
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xlim=box[:2], ylim=box[2:], aspect="equal")
    return art


def node_cells(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left and right ends of each interface node's part of the interface: the midpoints to its
    neighbours (the first and last node: half their one element).  Bars of the tributary
    weight centred on the node do not tile a graded interface: the two_cylinders_unequal strip
    had a white notch at x = 0.08 between the nodes 0.0025 and 0.16."""
    order = np.argsort(x)
    xs = x[order]
    mid = 0.5 * (xs[1:] + xs[:-1])
    left = np.r_[xs[0] - (mid[0] - xs[0]), mid] if xs.size > 1 else xs - 0.5
    right = np.r_[mid, xs[-1] + (xs[-1] - mid[-1])] if xs.size > 1 else xs + 0.5
    lo, hi = np.empty_like(x), np.empty_like(x)
    lo[order], hi[order] = left, right
    return lo, hi


def _status_panel(ax, res: CaseResult, step, k: int) -> None:
    it = step.interface
    lo, hi = node_cells(it.x)
    for s, col in STATUS_COLORS.items():
        m = it.status == s
        ax.barh(1.5, hi[m] - lo[m], left=lo[m], height=0.8, color=col, linewidth=0)
    ns = res.analytic.normal
    ax.barh(0.5, it.x.max() - it.x.min(), left=it.x.min(), height=0.8, color=STATUS_COLORS[0],
            linewidth=0)
    a, b = ns.zones[k]
    if step.stage == 2:
        st = stick_state(ns, res.case.mu, step.Q).stick_zones[k] if step.Q > 0 else None
        ax.barh(0.5, b - a, left=a, height=0.8, color=STATUS_COLORS[2], linewidth=0)
    else:
        st = (a, b)
    if st is not None:
        ax.barh(0.5, st[1] - st[0], left=st[0], height=0.8, color=STATUS_COLORS[1], linewidth=0)
    ax.set_ylim(0, 2)
    ax.set_yticks([0.5, 1.5], ["analytic", "FE"])
    ax.set_xlabel("x")


def region_figure(res: CaseResult) -> bytes | None:
    """PNG of :func:`region_axes`; None for a result without body fields (an external code's
    interface-only result), which has no stress field to draw."""
    if not res.fem.has_fields:
        return None
    return png(region_axes(res))


def region_axes(res: CaseResult):
    """sigma_xx around each contact zone and the interface status under it, at
    :func:`region_step`; returns the figure (axes ``[row, zone]``: row 0 the field, row 1 the
    status strip; then one colour bar per zone)."""
    from fem.vtk import bodies_mesh

    step = region_step(res)
    boxes = region_boxes(res)
    aspect = max((b[1] - b[0]) / (b[3] - b[2]) for b in boxes)
    fig, axes = zone_columns(len(boxes), 2, (4.2, 4.0 / aspect + 2.4),
                             ratios=[4.0 / aspect, 0.5],
                             layout="compressed")
    mesh = bodies_mesh(res.fem, step)
    for k, box in enumerate(boxes):
        art = _field_panel(axes[0, k], mesh, box)
        _status_panel(axes[1, k], res, step, k)
        axes[0, k].set_title(f"zone {k}: [{box[0]:.4g}, {box[1]:.4g}]", fontsize=9)
        fig.colorbar(art, ax=axes[:, k], orientation="horizontal", fraction=0.05,
                     label="sigma_xx (tension > 0)")
        if k:
            axes[1, k].tick_params(labelleft=False)
    axes[0, 0].set_ylabel("y (body 1 above, body 2 below)")
    load = f"Q = {step.Q:.4g} (end of stage 2)" if step.stage == 2 else f"P = {step.P:.4g}"
    text = (f"{res.case.name}: sigma_xx around each contact zone at {load}, undeformed "
            "geometry, true aspect ratio; strip: interface status (grey: open, blue: stick, "
            "red: slip) of the FE nodes and of the analytic solution")
    fig.suptitle(caption(text, fig.get_figwidth(), 9), fontsize=9, y=1.0, va="bottom")
    return fig
