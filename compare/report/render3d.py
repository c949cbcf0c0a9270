"""Off-screen pyvista picture of the whole deformed bodies coloured by von Mises stress.

The picture is the small overview: the bodies are many times wider than the contact, which the
report shows in its contact-region figure; a red frame marks that region here.  Rendering runs
in a child process with a time limit: a missing EGL/OSMesa/X library can crash VTK outright,
and the report must still be written (with the reason) when that happens.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

#: Seconds allowed for one off-screen rendering.
RENDER_TIMEOUT = 120

SCRIPT = r"""
import json
import sys
import numpy as np
import pyvista as pv
pv.OFF_SCREEN = True


def render(src, out, xlo, xhi, ylo, yhi):
    mesh = pv.read(src)
    b = mesh.bounds
    disp = np.asarray(mesh.point_data["displacement"])
    scale = 0.03 * (b[3] - b[2]) / max(float(np.abs(disp[:, 1]).max()), 1e-300)
    warped = mesh.warp_by_vector("displacement", factor=scale)
    vm = np.asarray(mesh.point_data["von_mises"])
    pl = pv.Plotter(off_screen=True, window_size=(640, 400))
    pl.add_mesh(warped, scalars="von_mises", cmap="viridis", show_edges=False,
                clim=(0.0, float(np.percentile(vm, 99.5)) or 1.0),
                scalar_bar_args={"title": "von Mises", "label_font_size": 10,
                                 "title_font_size": 11})
    frame = np.array([[xlo, ylo, 0], [xhi, ylo, 0], [xhi, yhi, 0], [xlo, yhi, 0], [xlo, ylo, 0]])
    pl.add_mesh(pv.lines_from_points(frame + [0, 0, 1e-3 * (b[1] - b[0])]), color="red",
                line_width=2)
    pl.view_xy()
    pl.camera.zoom(1.3)
    pl.add_text(f"whole bodies, displacement x {scale:.3g}; red: contact region", font_size=8)
    pl.screenshot(out)
    pl.close()


for k, job in enumerate(json.loads(sys.stdin.read())):
    try:
        render(*job)
    except Exception as exc:
        print(f"job {k}: {type(exc).__name__}: {exc}", file=sys.stderr)
"""


def render_many(jobs: list[tuple[Path, Path, tuple[float, float, float, float]]]
                ) -> list[tuple[bool, str]]:
    """Render each job's ``vtu`` (bodies of one step) into its ``out_png`` with a frame around
    its ``region`` (xmin, xmax, ymin, ymax), all in one child process (pyvista is imported once:
    ~1 s per picture saved); returns (ok, reason-if-not) per job."""
    if not jobs:
        return []
    spec = json.dumps([[str(v), str(o), *map(float, r)] for v, o, r in jobs])
    timeout = RENDER_TIMEOUT * len(jobs)
    try:
        proc = subprocess.run([sys.executable, "-c", SCRIPT], input=spec, capture_output=True,
                              text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return [(False, f"pyvista rendering timed out after {timeout} s")] * len(jobs)
    tail = " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-3:])
    why = ("pyvista off-screen rendering failed (needs EGL, OSMesa or an X server): "
           f"exit {proc.returncode}: {tail}")
    return [(True, "") if Path(out).is_file() else (False, why) for _, out, _ in jobs]
