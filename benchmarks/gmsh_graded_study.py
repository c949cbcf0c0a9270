"""Rings or gmsh's quads at equal DOFs (issue 28, item 1: "conforming quad transitions, or
triangles/quads from gmsh with a size field, whichever converges better at equal DOFs").

Hertz (E = 1, nu = 0.3, R = 100, P = 0.01; the meshes' case, meshes/hertz.geo) under its full
normal load on two graded meshes of the same law, element size ``h + (rate - 1) d`` at distance
d from the window, rate ``1 + (growth - 1) 2^(-(level + 1) / 2)``:

- ``rings``: fem's default (fem.rings: rings with conforming 3:1 transitions);
- ``gmsh``: meshes/graded_bodies.inc (gmsh's frontal quads with the size field, every element
  split into quads), at the default growth and at a finer one (more DOFs).

Per level: DOFs, the contact half-width error and the peak pressure error (signed, relative to
the closed form: Johnson 1985, Sec. 5.5, ``a = sqrt(2 A P R / pi)``, ``p0 = a / (A R)``), Q1
with incompatible modes (the default).  Needs gmsh (``pip install gmsh``).  The measured table is
in meshes/README.md.

Run: OPENBLAS_NUM_THREADS=1 python benchmarks/gmsh_graded_study.py [--levels 0 1 2]
"""

from __future__ import annotations

import argparse
import importlib.util
import tempfile
from pathlib import Path

import numpy as np

import fem

E, NU, R, P, MU = 1.0, 0.3, 100.0, 0.01, 0.5
A = 4 * (1 - NU**2) / E
A_HERTZ = float(np.sqrt(2 * A * P * R / np.pi))
P0_HERTZ = A_HERTZ / (A * R)
WINDOW = (-1.3 * A_HERTZ, 1.3 * A_HERTZ)  # meshes/hertz.geo
#: Growths of the gmsh meshes: the default and a finer grading (about the rings' DOFs).
GMSH_GROWTHS = (1.2, 1.1)
MESHES = Path(__file__).resolve().parents[1] / "meshes"


def load_generate():
    """meshes/generate.py as a module (meshes/ is not a package)."""
    spec = importlib.util.spec_from_file_location("meshes_generate", MESHES / "generate.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def hertz_errors(mesh) -> tuple[int, float, float]:
    """(DOFs, half-width error, peak pressure error) of Hertz at the full normal load."""
    hist = fem.solve_history(lambda x: x**2 / (2 * R), P, 0.0, MU, E, NU, mesh=mesh,
                             window=WINDOW, increments=fem.LoadPath(n_normal=3, n_tangential=1))
    step = hist.steps[2]  # the end of stage 1
    ((lo, hi),) = step.contact_zones
    width = 0.5 * (hi - lo) / A_HERTZ - 1.0
    return hist.n_dofs, width, float(step.interface.p.max()) / P0_HERTZ - 1.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2])
    args = ap.parse_args()
    gen = load_generate()
    gmsh = gen.gmsh_command()
    print(f"{'level':>5} {'mesh':<14}{'DOFs':>8}{'width err':>12}{'peak err':>12}")
    with tempfile.TemporaryDirectory() as tmp:
        for level in args.levels:
            rows = [("rings", fem.MeshSpec(level=level))]
            for g in GMSH_GROWTHS:
                out = Path(tmp) / f"hertz_{level}_{g}.msh"
                gen.run_gmsh(gmsh, "hertz", level, "graded", out, growth=g)
                rows.append((f"gmsh g {g:g}", fem.MeshFile(out)))
            for name, mesh in rows:
                n, width, peak = hertz_errors(mesh)
                print(f"{level:>5} {name:<14}{n:>8}{width:>+12.2e}{peak:>+12.2e}", flush=True)


if __name__ == "__main__":
    main()
