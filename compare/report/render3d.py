"""Off-screen pyvista picture of the whole deformed bodies coloured by von Mises stress.

The picture is the small overview: the bodies are many times wider than the contact, which the
report shows in its contact-region figure; a red frame marks that region here.  Rendering runs
in a child process with a time limit: a missing EGL/OSMesa/X library can crash VTK outright,
and the report must still be written (with the reason) when that happens.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

#: Seconds allowed for one off-screen rendering.
RENDER_TIMEOUT = 120

SCRIPT = r"""
import sys
import numpy as np
import pyvista as pv
pv.OFF_SCREEN = True
src, out = sys.argv[1], sys.argv[2]
xlo, xhi, ylo, yhi = (float(v) for v in sys.argv[3:7])
mesh = pv.read(src)
b = mesh.bounds
disp = np.asarray(mesh.point_data["displacement"])
scale = 0.03 * (b[3] - b[2]) / max(float(np.abs(disp[:, 1]).max()), 1e-300)
warped = mesh.warp_by_vector("displacement", factor=scale)
vm = np.asarray(mesh.point_data["von_mises"])
pl = pv.Plotter(off_screen=True, window_size=(640, 400))
pl.add_mesh(warped, scalars="von_mises", cmap="viridis", show_edges=False,
            clim=(0.0, float(np.percentile(vm, 99.5)) or 1.0),
            scalar_bar_args={"title": "von Mises", "label_font_size": 10, "title_font_size": 11})
frame = np.array([[xlo, ylo, 0], [xhi, ylo, 0], [xhi, yhi, 0], [xlo, yhi, 0], [xlo, ylo, 0]])
pl.add_mesh(pv.lines_from_points(frame + [0, 0, 1e-3 * (b[1] - b[0])]), color="red",
            line_width=2)
pl.view_xy()
pl.camera.zoom(1.3)
pl.add_text(f"whole bodies, displacement x {scale:.3g}; red: contact region", font_size=8)
pl.screenshot(out)
"""


def render_bodies(vtu: Path, out_png: Path, region: tuple[float, float, float, float]
                  ) -> tuple[bool, str]:
    """Render ``vtu`` (bodies of one step) into ``out_png`` with a frame around ``region``
    (xmin, xmax, ymin, ymax); returns (ok, reason-if-not)."""
    cmd = [sys.executable, "-c", SCRIPT, str(vtu), str(out_png), *map(repr, region)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=RENDER_TIMEOUT)
    except subprocess.TimeoutExpired:
        return False, f"pyvista rendering timed out after {RENDER_TIMEOUT} s"
    if proc.returncode != 0 or not out_png.is_file():
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        return False, ("pyvista off-screen rendering failed (needs EGL, OSMesa or an X "
                       f"server): exit {proc.returncode}: {' | '.join(tail)}")
    return True, ""
