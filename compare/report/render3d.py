"""Off-screen pyvista picture of the deformed bodies coloured by von Mises stress.

Rendering runs in a child process with a time limit: a missing EGL/OSMesa/X library can crash
VTK outright, and the report must still be written (with the reason) when that happens.
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
src, out, xlo, xhi = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
mesh = pv.read(src)
width = xhi - xlo
box = (xlo - 0.6 * width, xhi + 0.6 * width, -0.5 * width, 0.5 * width, -1.0, 1.0)
clip = mesh.clip_box(box, invert=False)
disp = np.asarray(clip.point_data["displacement"])
scale = 0.08 * width / max(float(np.abs(disp[:, 1]).max()), 1e-300)
warped = clip.warp_by_vector("displacement", factor=scale)
pl = pv.Plotter(off_screen=True, window_size=(1000, 520))
pl.add_mesh(warped, scalars="von_mises", cmap="viridis", show_edges=False,
            scalar_bar_args={"title": "von Mises stress"})
pl.view_xy()
pl.camera.zoom(1.3)
pl.add_text(f"deformed (displacement x {scale:.3g})", font_size=10)
pl.screenshot(out)
"""


def render_bodies(vtu: Path, out_png: Path, window: tuple[float, float]) -> tuple[bool, str]:
    """Render ``vtu`` (bodies of one step) into ``out_png``; returns (ok, reason-if-not)."""
    cmd = [sys.executable, "-c", SCRIPT, str(vtu), str(out_png), repr(window[0]),
           repr(window[1])]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=RENDER_TIMEOUT)
    except subprocess.TimeoutExpired:
        return False, f"pyvista rendering timed out after {RENDER_TIMEOUT} s"
    if proc.returncode != 0 or not out_png.is_file():
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        return False, ("pyvista off-screen rendering failed (needs EGL, OSMesa or an X "
                       f"server): exit {proc.returncode}: {' | '.join(tail)}")
    return True, ""
