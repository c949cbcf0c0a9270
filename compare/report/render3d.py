"""Off-screen pyvista pictures of the FE mesh around each contact zone, coloured by von Mises.

The whole bodies are many times wider than the contact: a picture of them shows the zones as
single pixels.  So the picture shows, per contact zone, the box of the report's contact-region
figure (:func:`compare.report.region.region_boxes`): the cells of both bodies there coloured by
von Mises stress on the deformed geometry at true scale (element edges drawn where they can be
told apart, MAX_EDGES), with a horizontal colour bar per zone.  Rendering runs in a child
process with a time limit: a missing EGL/OSMesa/X library can crash VTK outright, and the
report must still be written (with the reason) when that happens.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

#: Seconds allowed for one off-screen rendering.
RENDER_TIMEOUT = 120
#: Pixels of one zone's picture (width, height); at most MAX_COLUMNS zones side by side.
PANEL_PIXELS = (600, 560)
MAX_COLUMNS = 2
#: Element edges are drawn when about this many elements or fewer span the box (more are a
#: grey moire at this size).
MAX_EDGES = 80

SCRIPT = r"""
import json
import math
import sys
import numpy as np
import pyvista as pv
pv.OFF_SCREEN = True


def zone_view(pl, mesh, k, box):
    xlo, xhi, ylo, yhi = box
    part = mesh.clip_box((xlo, xhi, ylo, yhi, -1.0, 1.0), invert=False, crinkle=True)
    vm = np.asarray(part.point_data["von_mises"])
    across = (part.n_cells * (xhi - xlo) / (yhi - ylo)) ** 0.5  # elements across the box
    title = " " * (k + 1)  # one bar per view (pyvista keys them by title); said in the text
    pl.add_mesh(part.warp_by_vector("displacement", factor=1.0), scalars="von_mises",
                cmap="viridis", show_edges=bool(across <= MAX_EDGES), edge_color="white",
                line_width=0.5, clim=(0.0, float(np.percentile(vm, 99)) or 1.0),
                scalar_bar_args={"title": title, "vertical": False, "position_x": 0.15,
                                 "position_y": 0.02, "width": 0.7, "height": 0.1,
                                 "title_font_size": 18, "label_font_size": 18, "fmt": "%.3g",
                                 "n_labels": 4, "color": "black"})
    pl.scalar_bars[title].SetTextPositionToPrecedeScalarBar()  # tick labels under the bar
    pl.add_text(f"zone {k}, x = {xlo:.4g} .. {xhi:.4g}: von Mises stress", position="upper_edge",
                font_size=11, color="black")
    pl.view_xy()
    pl.enable_parallel_projection()
    cx, cy, w, h = 0.5 * (xlo + xhi), 0.5 * (ylo + yhi), xhi - xlo, yhi - ylo
    cam = pl.camera
    cam.focal_point = (cx, cy - 0.1 * h, 0.0)
    cam.position = (cx, cy - 0.1 * h, 10.0 * max(w, h))
    cam.up = (0.0, 1.0, 0.0)
    cam.parallel_scale = 0.5 * max(1.45 * h, 1.1 * w * PANEL[1] / PANEL[0])


def render(src, out, boxes):
    mesh = pv.read(src)
    cols = min(len(boxes), MAX_COLUMNS)
    rows = math.ceil(len(boxes) / cols)
    pl = pv.Plotter(off_screen=True, shape=(rows, cols), border=False,
                    window_size=(PANEL[0] * cols, PANEL[1] * rows))
    pl.set_background("white")
    for k, box in enumerate(boxes):
        pl.subplot(k // cols, k % cols)
        zone_view(pl, mesh, k, box)
    pl.screenshot(out)
    pl.close()


PANEL, MAX_COLUMNS, MAX_EDGES = json.loads(sys.argv[1])
for k, job in enumerate(json.loads(sys.stdin.read())):
    try:
        render(*job)
    except Exception as exc:
        print(f"job {k}: {type(exc).__name__}: {exc}", file=sys.stderr)
"""


def render_many(jobs: list[tuple[Path, Path, list[tuple[float, float, float, float]]]]
                ) -> list[tuple[bool, str]]:
    """Render each job's ``vtu`` (bodies of one step) into its ``out_png``: one view per box
    (xmin, xmax, ymin, ymax) of its zones, all in one child process (pyvista is imported once:
    ~1 s per picture saved); returns (ok, reason-if-not) per job."""
    if not jobs:
        return []
    spec = json.dumps([[str(v), str(o), [list(map(float, b)) for b in boxes]]
                       for v, o, boxes in jobs])
    timeout = RENDER_TIMEOUT * len(jobs)
    try:
        settings = json.dumps([list(PANEL_PIXELS), MAX_COLUMNS, MAX_EDGES])
        proc = subprocess.run([sys.executable, "-c", SCRIPT, settings], input=spec,
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return [(False, f"pyvista rendering timed out after {timeout} s")] * len(jobs)
    tail = " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-3:])
    why = ("pyvista off-screen rendering failed (needs EGL, OSMesa or an X server): "
           f"exit {proc.returncode}: {tail}")
    return [(True, "") if Path(out).is_file() else (False, why) for _, out, _ in jobs]
