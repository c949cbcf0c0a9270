"""VTK output: per increment a .vtu of both bodies and one of the interface line,
collected in a .pvd time series (time = load-step parameter t). Files are written
atomically (temporary file in the same directory, then ``os.replace``).

Bodies: points = nodal dof locations (Q2 elements are split into 4 linear quads),
point data ``displacement`` (3 components), ``stress`` (3x3 tensor, sigma_zz from
plane strain), ``von_mises``, ``body`` (1 upper, 2 lower), stored in single precision
(7 digits, for viewing; half the size of double: 4.8 instead of 8.6 MB for the 193e3-DOF
applied-moment case) and zlib-compressed binary.  ``steps="ends"`` writes only the last step
of each stage, the ones a person opens. Interface: points on y = 0
with ``p``, ``q``, ``status``, ``slip``, ``penetration``, ``w`` (tributary length), ``gap``
and the step's loads as field data ``stage``, ``P``, ``Q``, ``M``, ``theta`` (the exchange
format of docs/external.md), in double precision.
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .errors import InputError
from .fields import von_mises


def sub_quads(scalar_basis) -> np.ndarray:
    """Linear quads (rows of 4 scalar dofs) covering the mesh (Q2: 4 per element)."""
    mesh, dofs = scalar_basis.mesh, scalar_basis.element_dofs
    if dofs.shape[0] == 4:
        return dofs.T.copy()
    loc = scalar_basis.doflocs
    v = dofs[:4]
    edges = []
    for k in range(4):
        mid = 0.5 * (loc[:, v[k]] + loc[:, v[(k + 1) % 4]])
        dist = np.linalg.norm(loc[:, dofs[4:8]] - mid[:, None, :], axis=0)
        edges.append(dofs[4:8][np.argmin(dist, axis=0), np.arange(mesh.t.shape[1])])
    c = dofs[8]
    e01, e12, e23, e30 = edges
    quads = [(v[0], e01, c, e30), (e01, v[1], e12, c), (c, e12, v[2], e23), (e30, c, e23, v[3])]
    return np.concatenate([np.array(q).T for q in quads])


def stress_tensor(s: np.ndarray) -> np.ndarray:
    """(n, 9) VTK tensors from (sxx, syy, sxy, szz) rows."""
    sxx, syy, sxy, szz = s
    z = np.zeros_like(sxx)
    return np.stack([sxx, sxy, z, sxy, syy, z, z, z, szz], axis=1)


def bodies_mesh(history, step):
    """meshio.Mesh of both bodies at one step."""
    import meshio

    disc = history.fields.disc
    pts, cells, data, off = (
        [],
        [],
        {"displacement": [], "stress": [], "von_mises": [], "body": []},
        0,
    )
    for b, (u, s) in enumerate(zip(history.displacement(step), history.stress(step), strict=True)):
        sb = disc.scalar_bases[b]
        n = sb.N
        pts.append(np.c_[sb.doflocs.T, np.zeros(n)])
        cells.append(sub_quads(sb) + off)
        data["displacement"].append(np.c_[u[0::2], u[1::2], np.zeros(n)])
        data["stress"].append(stress_tensor(s))
        data["von_mises"].append(von_mises(s))
        data["body"].append(np.full(n, b + 1, dtype=np.int32))
        off += n
    return meshio.Mesh(
        np.vstack(pts),
        [("quad", np.vstack(cells))],
        point_data={k: np.concatenate(v) for k, v in data.items()},
    )


def single_precision(mesh):
    """The mesh with float arrays as float32 and the connectivity as int32 (for viewing)."""
    import meshio

    data = {k: v.astype(np.float32) if v.dtype.kind == "f" else v
            for k, v in mesh.point_data.items()}
    cells = [(c.type, c.data.astype(np.int32)) for c in mesh.cells]
    return meshio.Mesh(mesh.points.astype(np.float32), cells, point_data=data)


def interface_mesh(step):
    """meshio.Mesh of the interface line at one step."""
    import meshio

    f = step.interface
    n = f.x.size
    pts = np.c_[f.x, np.zeros(n), np.zeros(n)]
    lines = np.c_[np.arange(n - 1), np.arange(1, n)]
    data = {
        "p": f.p,
        "q": f.q,
        "status": f.status.astype(np.int32),
        "slip": f.slip,
        "penetration": f.penetration,
        "w": f.w,
        "gap": f.gap,
    }
    return meshio.Mesh(pts, [("line", lines)], point_data=data)


def step_loads(step) -> dict:
    """Field data of an interface .vtu: the step's stage and loads (P, Q, M, theta)."""
    return {"stage": step.stage, "P": step.P, "Q": step.Q, "M": step.M, "theta": step.plate[2]}


def atomic_write_mesh(mesh, path: Path, field_data: dict | None = None) -> None:
    """Write a meshio mesh as .vtu through a temporary file and os.replace; ``field_data``
    (name -> float) is added as an ASCII <FieldData> block (meshio 5 does not write it)."""
    import meshio

    tmp = path.with_name(f".{path.name}.tmp")
    meshio.write(tmp, mesh, file_format="vtu")
    if field_data:
        arrays = "".join(f'<DataArray type="Float64" Name="{k}" NumberOfTuples="1" '
                         f'format="ascii">{float(v)!r}</DataArray>' for k, v in field_data.items())
        text = tmp.read_text(encoding="utf-8")
        tmp.write_text(text.replace("<UnstructuredGrid>", f"<UnstructuredGrid><FieldData>{arrays}"
                                    "</FieldData>", 1), encoding="utf-8")
    os.replace(tmp, path)


def atomic_write_text(text: str, path: Path) -> None:
    """Write text through a temporary file and os.replace."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


#: Which steps :func:`write_vtk` writes: every step, or the last step of each stage.
VTK_STEPS = ("all", "ends")


def stage_ends(history) -> tuple:
    """The last step of each stage that has steps."""
    return tuple(history.stage(k)[-1] for k in (1, 2, 3) if history.stage(k))


def write_vtk(history, directory, steps: str = "all") -> Path:
    """Write bodies and interface .vtu files and the .pvd time series of every step
    (``steps="all"``) or of the last step of each stage (``steps="ends"``)."""
    if steps not in VTK_STEPS:
        raise InputError(f"steps = {steps!r} is not allowed: need one of {', '.join(VTK_STEPS)}")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    entries = []
    for step in history.steps if steps == "all" else stage_ends(history):
        names = (f"bodies_{step.index:04d}.vtu", f"interface_{step.index:04d}.vtu")
        atomic_write_mesh(single_precision(bodies_mesh(history, step)), directory / names[0])
        atomic_write_mesh(interface_mesh(step), directory / names[1], step_loads(step))
        entries += [
            f'    <DataSet timestep="{step.t:.12g}" part="{k}" file={quoteattr(n)}/>'
            for k, n in enumerate(names)
        ]
    pvd = (
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries)
        + "\n  </Collection>\n</VTKFile>\n"
    )
    path = directory / "history.pvd"
    atomic_write_text(pvd, path)
    return path
