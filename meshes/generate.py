"""Regenerate the two-body meshes of the library cases.

``<case>.geo`` sets the window and the kinks of one case.  Two layouts:

- rings (``fem.MeshSpec(layout="rings")``): ``<case>_L<level>.msh`` written by
  fem's own generator (``fem.mesh.write_msh``, gmsh 2.2 format) with the window and kinks of
  ``<case>.geo``; no gmsh needed.
- tensor (``layout="tensor"``, growth 1.2): ``two_bodies.inc`` builds the two bodies as
  structured gmsh quad blocks from a handful of parameters (level, n_window, growth, margin,
  size_factor, near_depth); with ``--tensor`` this runs

      gmsh -2 <case>.geo -setnumber level <level> -o <case>_tensor_L<level>.msh

  reads the mesh back with ``fem.MeshFile`` and checks it is the grid of fem's tensor generator
  with the same parameters (to gmsh's rounding, :data:`GRID_RTOL`).  gmsh is needed only here:
  ``pip install gmsh`` puts it on PATH (or set ``GMSH`` to the executable).

Every mesh written is read back and checked against the generator; the README table is printed.
Run from the repository root: ``python meshes/generate.py [--tensor] [LEVEL ...]`` (default
levels 0 1 2).  Only the level-0 ring meshes are stored in git (the tests read them).
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

import fem
from fem.mesh import TwoBodyMesh, build_mesh, read_mesh, write_msh

HERE = Path(__file__).resolve().parent
CASES = ("hertz", "double_wedge")
LEVELS = (0, 1, 2)
#: gmsh places the nodes of a progression to ~1e-8 relative: measured at most 5.2e-9 W off
#: fem's generator (levels 0-2 of both cases, gmsh 4.15); fem's own .msh files are exact to
#: the printed digits.
GRID_RTOL = 1e-8
#: gmsh functions and constants used in the parameter expressions, as Python.
GEO_NAMES = {"Sqrt": math.sqrt, "Pi": math.pi}
PARAMETER = re.compile(r"^\s*(\w+)\s*=\s*\{(.+?),\s*Name\s+\"", re.MULTILINE)
KINKS = re.compile(r"^\s*kinks\[\]\s*=\s*\{(.*?)\};", re.MULTILINE)


def geo_parameters(case: str) -> dict:
    """Default parameters of ``<case>.geo`` and ``two_bodies.inc`` (DefineConstant entries)
    and the case's ``kinks`` tuple, evaluated as Python."""
    text = (HERE / f"{case}.geo").read_text() + (HERE / "two_bodies.inc").read_text()
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
    """File stem: ``<case>_L<level>`` (rings) or ``<case>_tensor_L<level>``."""
    return f"{case}_L{level}" if layout == "rings" else f"{case}_tensor_L{level}"


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


def gmsh_executable() -> str:
    """Path of the gmsh executable (``GMSH`` or PATH); a clear error if there is none."""
    exe = os.environ.get("GMSH") or shutil.which("gmsh")
    if not exe:
        raise SystemExit(
            "meshes/generate.py needs gmsh: `pip install gmsh` (puts `gmsh` on PATH) "
            "or set GMSH=/path/to/gmsh"
        )
    return exe


def run_gmsh(exe: str, case: str, level: int) -> Path:
    """Mesh ``<case>.geo`` at ``level`` into ``<case>_tensor_L<level>.msh`` (atomic write)."""
    out = HERE / f"{mesh_name(case, level, 'tensor')}.msh"
    tmp = out.with_name(out.name + ".tmp.msh")
    cmd = [exe, "-2", str(HERE / f"{case}.geo"), "-setnumber", "level", str(level)]
    done = subprocess.run([*cmd, "-o", str(tmp)], capture_output=True, text=True, check=False)
    errors = [ln for ln in (done.stdout + done.stderr).splitlines() if ln.startswith("Error")]
    if done.returncode != 0 or errors or not tmp.is_file():
        tmp.unlink(missing_ok=True)
        raise SystemExit(f"{' '.join(cmd)} failed (exit {done.returncode}): {errors}")
    os.replace(tmp, out)
    return out


def write_rings(case: str, level: int) -> Path:
    """Write fem's ring mesh of ``<case>`` at ``level`` into ``<case>_L<level>.msh``."""
    return write_msh(reference_mesh(case, level, "rings"), HERE / f"{case}_L{level}.msh")


def main(levels=LEVELS, tensor: bool = False) -> list[str]:
    """Write every case's ring meshes at ``levels`` (with ``tensor``: mesh the .geo with gmsh
    instead), check each read back against fem's generator and return the README table rows."""
    layout = "tensor" if tensor else "rings"
    exe = gmsh_executable() if tensor else ""
    rows = []
    for case in CASES:
        params = geo_parameters(case)
        for level in levels:
            path = run_gmsh(exe, case, level) if tensor else write_rings(case, level)
            mesh = read_mesh(fem.MeshFile(path))
            offset = grid_offset(mesh, reference_mesh(case, level, layout))
            if offset > GRID_RTOL:
                raise SystemExit(
                    f"{path.name} is not fem's generator grid: nodes off by "
                    f"{offset:.3g} W > GRID_RTOL = {GRID_RTOL:g}"
                )
            window = (params["xmin"], params["xmax"])
            rows.append(table_row(mesh_name(case, level, layout), window, mesh))
    return rows


if __name__ == "__main__":
    args = sys.argv[1:]
    print("| mesh | window | quads | nodes | DOFs (Q1) | finest h |")
    print("| --- | --- | --- | --- | --- | --- |")
    levels = tuple(int(a) for a in args if a != "--tensor") or LEVELS
    print("\n".join(main(levels, "--tensor" in args)))
