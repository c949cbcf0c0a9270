"""Regenerate the two-body meshes of the library cases.

``<case>.geo`` sets the window and the kinks of one case.  Three layouts:

- rings (``fem.MeshSpec(layout="rings")``, the default): ``<case>_L<level>.msh`` written by
  fem's own generator (``fem.mesh.write_msh``, gmsh 2.2 format) with the window and kinks of
  ``<case>.geo``; no gmsh needed.
- graded (``--graded``): ``graded_bodies.inc`` (the .geo's default, ``layout = 1``) meshes the
  rings' grading law, element size ``h + (rate - 1) d`` at distance d from the window, with
  gmsh's unstructured quads; this runs

      gmsh -2 <case>.geo -setnumber level <level> -o <case>_graded_L<level>.msh

  and checks the mesh read back (:func:`check_graded`): node-to-node interface rows, a node on
  every kink, the window's spacing at most h, every element's size within
  :data:`GRADED_SIZE_RANGE` of the law, the body ``[xc - W, xc + W] x [0, H]``.
- tensor (``--tensor``; ``layout="tensor"``, growth 1.2): ``two_bodies.inc``
  (``-setnumber layout 0``) builds the two bodies as structured gmsh quad blocks from a handful
  of parameters (level, n_window, growth, margin, size_factor, near_depth); the mesh read back
  must be the grid of fem's tensor generator with the same parameters (to gmsh's rounding,
  :data:`GRID_RTOL`).

gmsh is needed only for the last two: ``pip install gmsh`` (the ``test`` extra has it; its
library needs libGLU and a few X libraries, ``.ci/sysdeps.sh``), or set ``GMSH`` to an
executable.  Every mesh written is read back and checked; the README table is printed.  Run from
the repository root: ``python meshes/generate.py [--graded | --tensor] [LEVEL ...]`` (default
levels 0 1 2).  Only the level-0 ring meshes are stored in git (the tests read them).
"""

from __future__ import annotations

import importlib.util
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

import fem
from fem.mesh import TwoBodyMesh, build_mesh, near_growth, read_mesh, write_msh

HERE = Path(__file__).resolve().parent
CASES = ("hertz", "double_wedge")
LEVELS = (0, 1, 2)
#: gmsh places the nodes of a progression to ~1e-8 relative: measured at most 5.2e-9 W off
#: fem's generator (levels 0-2 of both cases, gmsh 4.15); fem's own .msh files are exact to
#: the printed digits.
GRID_RTOL = 1e-8
#: An element of the graded gmsh mesh: sqrt(area) over the law h + (rate - 1) d at its centroid
#: (d: distance to the widened window on y = 0).  Measured 0.48-1.40 over both cases at levels
#: 0-2 (gmsh 4.15: the frontal mesher's sizes scatter about the field, the split halves them).
GRADED_SIZE_RANGE = (0.4, 1.6)
#: The .inc of each gmsh layout and its ``layout`` number in ``<case>.geo``.
GEO_LAYOUTS = {"graded": ("graded_bodies.inc", 1), "tensor": ("two_bodies.inc", 0)}
#: Runs gmsh from its Python module (``pip install gmsh``) as the ``gmsh`` command would.
GMSH_MAIN = "import sys, gmsh; gmsh.initialize(['gmsh'] + sys.argv[1:], run=True); gmsh.finalize()"
#: gmsh functions and constants used in the parameter expressions, as Python.
GEO_NAMES = {"Sqrt": math.sqrt, "Pi": math.pi}
PARAMETER = re.compile(r"^\s*(\w+)\s*=\s*\{(.+?),\s*Name\s+\"", re.MULTILINE)
KINKS = re.compile(r"^\s*kinks\[\]\s*=\s*\{(.*?)\};", re.MULTILINE)


def geo_parameters(case: str, layout: str = "tensor") -> dict:
    """Default parameters of ``<case>.geo`` and the ``layout``'s .inc (``two_bodies.inc`` or
    ``graded_bodies.inc``; DefineConstant entries) and the case's ``kinks`` tuple, evaluated as
    Python."""
    inc = GEO_LAYOUTS[layout][0]
    text = (HERE / f"{case}.geo").read_text() + (HERE / inc).read_text()
    params = {
        name: float(eval(expr.replace("^", "**"), {"__builtins__": {}}, GEO_NAMES))  # noqa: S307
        for name, expr in PARAMETER.findall(text)
    }
    (kinks,) = KINKS.findall(text)
    params["kinks"] = tuple(float(k) for k in kinks.split(",") if k.strip())
    return params


def mesh_spec(params: dict, level: int, layout: str = "tensor") -> fem.MeshSpec:
    """The fem.MeshSpec of ``layout`` at ``level``: the tensor layout with the .geo parameters,
    the ring layout with fem's default parameters."""
    if layout == "rings":
        return fem.MeshSpec(level=level, layout="rings")
    return fem.MeshSpec(
        level=level,
        n_window=int(params["n_window"]),
        growth=params["growth"],
        margin=params["margin"],
        size_factor=params["size_factor"],
        layout="tensor",
    )


def reference_mesh(case: str, level: int, layout: str = "tensor") -> TwoBodyMesh:
    """fem's generator with the window and kinks of ``<case>.geo`` at ``level``."""
    params = geo_parameters(case)
    window = (params["xmin"], params["xmax"])
    return build_mesh(mesh_spec(params, level, layout), window, params["kinks"])


def mesh_name(case: str, level: int, layout: str) -> str:
    """File stem: ``<case>_L<level>`` (rings), ``<case>_graded_L<level>`` or
    ``<case>_tensor_L<level>``."""
    return f"{case}_L{level}" if layout == "rings" else f"{case}_{layout}_L{level}"


def grid_offset(mesh: TwoBodyMesh, reference: TwoBodyMesh) -> float:
    """Largest distance of a node of ``mesh`` from its own node of ``reference`` (per body),
    relative to the body half-width W; inf if the node sets do not pair one to one."""
    from scipy.spatial import cKDTree

    worst = 0.0
    for body, ref in zip(mesh.bodies, reference.bodies, strict=True):
        if body.p.shape != ref.p.shape or body.t.shape != ref.t.shape:
            return math.inf
        dist, nearest = cKDTree(ref.p.T).query(body.p.T)
        if np.unique(nearest).size != ref.p.shape[1]:
            return math.inf
        worst = max(worst, float(dist.max()) / (0.5 * np.ptp(ref.p[0])))
    return worst


def table_row(name: str, window: tuple[float, float], mesh: TwoBodyMesh) -> str:
    """README table row: mesh, window, quads, nodes, DOFs (Q1), finest h."""
    n_nodes = sum(b.p.shape[1] for b in mesh.bodies)
    return (
        f"| {name} | {window[0]:.4g}..{window[1]:.4g} | {mesh.n_elements} | {n_nodes} | "
        f"{2 * n_nodes} | {mesh.h_min:.4g} |"
    )


def gmsh_module_available() -> bool:
    """Whether this interpreter can import gmsh's Python module."""
    return importlib.util.find_spec("gmsh") is not None


def gmsh_command() -> list[str]:
    """The command that runs gmsh: ``GMSH``, else gmsh's Python module in this interpreter (the
    wheel's ``gmsh`` script runs whatever ``python`` is first on PATH), else ``gmsh`` on PATH;
    a clear error if there is none."""
    if os.environ.get("GMSH"):
        return [os.environ["GMSH"]]
    if gmsh_module_available():
        return [sys.executable, "-c", GMSH_MAIN]
    exe = shutil.which("gmsh")
    if not exe:
        raise SystemExit(
            "meshes/generate.py needs gmsh: `pip install gmsh` (or the project's `test` extra) "
            "or set GMSH=/path/to/gmsh"
        )
    return [exe]


def run_gmsh(gmsh: list[str], case: str, level: int, layout: str, out: Path | None = None,
             **numbers: float) -> Path:
    """Mesh ``<case>.geo`` with ``layout`` ('graded' or 'tensor') at ``level`` into ``out``
    (default ``<case>_<layout>_L<level>.msh`` here; atomic write); ``numbers``: other
    ``-setnumber`` parameters."""
    out = out or HERE / f"{mesh_name(case, level, layout)}.msh"
    tmp = out.with_name(out.name + ".tmp.msh")
    numbers = {"layout": GEO_LAYOUTS[layout][1], "level": level, **numbers}
    cmd = [*gmsh, "-2", str(HERE / f"{case}.geo")]
    cmd += [a for name, v in numbers.items() for a in ("-setnumber", name, f"{v!r}")]
    done = subprocess.run([*cmd, "-o", str(tmp)], capture_output=True, text=True, check=False)
    errors = [ln for ln in (done.stdout + done.stderr).splitlines() if ln.startswith("Error")]
    if done.returncode != 0 or errors or not tmp.is_file():
        tmp.unlink(missing_ok=True)
        raise SystemExit(f"{' '.join(cmd)} failed (exit {done.returncode}): {errors}")
    os.replace(tmp, out)
    return out


def graded_law(params: dict, level: int) -> tuple[float, float, float, float]:
    """(h, rate, xl, xr) of ``graded_bodies.inc``: the window's element size, the grading rate
    (fem.mesh.near_growth) and the widened window."""
    w = params["xmax"] - params["xmin"]
    h = w / (params["n_window"] * 2.0**level)
    rate = near_growth(fem.MeshSpec(level=level, growth=params["growth"]))
    return h, rate, params["xmin"] - params["margin"] * w, params["xmax"] + params["margin"] * w


def element_sizes(body) -> tuple[np.ndarray, np.ndarray]:
    """(sqrt of the area, centroid (2, n)) of every quad of a body."""
    x, y = body.p[0, body.t], body.p[1, body.t]
    area = 0.5 * np.abs(np.sum(x * np.roll(y, -1, axis=0) - np.roll(x, -1, axis=0) * y, axis=0))
    return np.sqrt(area), np.array([x.mean(axis=0), y.mean(axis=0)])


def graded_size_ratios(mesh: TwoBodyMesh, params: dict, level: int) -> np.ndarray:
    """Every element's size over the law ``h + (rate - 1) d`` at its centroid (both bodies)."""
    h, rate, xl, xr = graded_law(params, level)
    out = []
    for body in mesh.bodies:
        size, (cx, cy) = element_sizes(body)
        d = np.hypot(np.clip(np.abs(cx - 0.5 * (xl + xr)) - 0.5 * (xr - xl), 0.0, None), cy)
        out.append(size / (h + (rate - 1.0) * d))
    return np.concatenate(out)


def check_graded(mesh: TwoBodyMesh, params: dict, level: int) -> list[str]:
    """What is wrong with a graded gmsh mesh (empty: nothing): the window's interface spacing
    above h, a kink without a node, an element off the grading law by more than
    GRADED_SIZE_RANGE, a body that is not ``[xc - W, xc + W] x [0, +-H]``.  (Matched interface
    rows and quads only: :func:`fem.mesh.read_mesh` itself.)"""
    h, _, xl, xr = graded_law(params, level)
    W = params["size_factor"] * 0.5 * (params["xmax"] - params["xmin"])
    xc = 0.5 * (params["xmin"] + params["xmax"])
    x = np.sort(mesh.bodies[0].p[0, mesh.nodes["contact_upper"]])
    fine = x[(x >= xl - 1e-9 * W) & (x <= xr + 1e-9 * W)]
    wrong = []
    if np.max(np.diff(fine)) > h * (1 + 1e-9):
        wrong.append(f"window spacing {np.max(np.diff(fine)):.6g} > h = {h:.6g}")
    wrong += [f"no node on kink {k:g}" for k in params["kinks"]
              if np.min(np.abs(x - k)) > 1e-9 * W]
    ratio = graded_size_ratios(mesh, params, level)
    lo, hi = GRADED_SIZE_RANGE
    if ratio.min() < lo or ratio.max() > hi:
        wrong.append(f"element size / law in {ratio.min():.3f}..{ratio.max():.3f}, "
                     f"not within GRADED_SIZE_RANGE {lo:g}..{hi:g}")
    for name, body, sign in (("1", mesh.bodies[0], 1.0), ("2", mesh.bodies[1], -1.0)):
        y = sign * body.p[1]  # H = W
        off = max(abs(body.p[0].min() - (xc - W)), abs(body.p[0].max() - (xc + W)),
                  abs(y.min()), abs(y.max() - W))
        if off > 1e-9 * W:
            wrong.append(f"body {name} is not [xc - W, xc + W] x [0, +-H] (off by {off:.3g})")
    return wrong


def write_rings(case: str, level: int) -> Path:
    """Write fem's ring mesh of ``<case>`` at ``level`` into ``<case>_L<level>.msh``."""
    return write_msh(reference_mesh(case, level, "rings"), HERE / f"{case}_L{level}.msh")


def checked_mesh(gmsh: list[str], case: str, level: int, layout: str) -> TwoBodyMesh:
    """Write ``<case>``'s mesh of ``layout`` at ``level`` (rings: fem's writer; graded, tensor:
    gmsh from the .geo), read it back and check it (rings, tensor: fem's generator grid to
    GRID_RTOL; graded: :func:`check_graded`); SystemExit on a mesh that fails."""
    path = write_rings(case, level) if layout == "rings" else run_gmsh(gmsh, case, level, layout)
    mesh = read_mesh(fem.MeshFile(path))
    if layout == "graded":
        wrong = check_graded(mesh, geo_parameters(case, "graded"), level)
    else:
        offset = grid_offset(mesh, reference_mesh(case, level, layout))
        wrong = ([f"not fem's generator grid: nodes off by {offset:.3g} W > GRID_RTOL = "
                  f"{GRID_RTOL:g}"] if offset > GRID_RTOL else [])
    if wrong:
        raise SystemExit(f"{path.name}: {'; '.join(wrong)}")
    return mesh


def main(levels=LEVELS, layout: str = "rings") -> list[str]:
    """Write every case's meshes of ``layout`` ('rings': fem's writer; 'graded', 'tensor':
    gmsh from the .geo) at ``levels``, check each read back and return the README table rows."""
    gmsh = gmsh_command() if layout != "rings" else []
    rows = []
    for case in CASES:
        params = geo_parameters(case)
        for level in levels:
            mesh = checked_mesh(gmsh, case, level, layout)
            window = (params["xmin"], params["xmax"])
            rows.append(table_row(mesh_name(case, level, layout), window, mesh))
    return rows


if __name__ == "__main__":
    args = sys.argv[1:]
    print("| mesh | window | quads | nodes | DOFs (Q1) | finest h |")
    print("| --- | --- | --- | --- | --- | --- |")
    levels = tuple(int(a) for a in args if not a.startswith("--")) or LEVELS
    chosen = [a[2:] for a in args if a in ("--graded", "--tensor")]
    print("\n".join(main(levels, chosen[0] if chosen else "rings")))
