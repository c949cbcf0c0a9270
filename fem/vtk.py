"""VTK output: per increment a .vtu of both bodies and one of the interface line,
collected in a .pvd time series (time = load-step parameter t). Files are written
atomically (temporary file in the same directory, then ``os.replace``).

Bodies: points = nodal dof locations (Q2 elements are split into 4 linear quads),
point data ``displacement`` (3 components), ``stress`` (3x3 tensor, sigma_zz from
plane strain), ``von_mises``, ``body`` (1 upper, 2 lower), stored for viewing: single
precision (7 digits), zlib-compressed raw binary (:func:`write_bodies_vtu`; 3.6 MB instead of
meshio's 8.6 MB in double precision and base64 for the 193e3-DOF applied-moment case).
Interface: points on y = 0 with ``p``, ``q``, ``status``, ``slip``, ``penetration``, ``w``
(tributary length), ``gap`` and the step's loads as field data ``stage``, ``P``, ``Q``, ``M``,
``theta`` (the exchange format of docs/external.md), in double precision.
``steps="ends"`` writes what a person opens: the interface at the last step of each stage and
the bodies under the largest load (:func:`write_vtk`).
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


#: zlib block size of the bodies' raw binary arrays (VTK's and meshio's default).
VTK_BLOCK = 32768
_VTK_TYPES = {np.dtype(np.float32): "Float32", np.dtype(np.int32): "Int32",
              np.dtype(np.uint8): "UInt8"}


def _zlib_blocks(data: bytes) -> bytes:
    """VTK's compressed array: UInt64 header (blocks, block size, last block size, compressed
    sizes) followed by the zlib-compressed blocks."""
    import zlib

    blocks = [data[i:i + VTK_BLOCK] for i in range(0, len(data), VTK_BLOCK)] or [b""]
    packed = [zlib.compress(b) for b in blocks]
    head = np.array([len(blocks), VTK_BLOCK, len(blocks[-1]), *map(len, packed)], np.uint64)
    return head.tobytes() + b"".join(packed)


def write_bodies_vtu(mesh, path: Path) -> None:
    """Write the bodies' quad mesh as a .vtu for viewing: single precision (7 digits), int32
    connectivity, zlib-compressed raw binary appended data (a third smaller than meshio's
    base64; ParaView, VTK and pyvista read it).  Atomic: temporary file, then os.replace."""
    quads = np.ascontiguousarray(mesh.cells[0].data, dtype=np.int32)
    arrays = [(k, np.asarray(v, np.float32) if np.asarray(v).dtype.kind == "f" else
               np.asarray(v, np.int32)) for k, v in mesh.point_data.items()]
    arrays += [("", np.asarray(mesh.points, np.float32)), ("connectivity", quads.ravel()),
               ("offsets", np.arange(4, 4 * len(quads) + 1, 4, dtype=np.int32)),
               ("types", np.full(len(quads), 9, np.uint8))]  # 9: VTK_QUAD
    blobs, tags, offset = [], {}, 0
    for name, a in arrays:
        blob = _zlib_blocks(np.ascontiguousarray(a).tobytes())
        ncomp = f' NumberOfComponents="{a.shape[1]}"' if a.ndim == 2 else ""
        tags[name] = (f'<DataArray type="{_VTK_TYPES[a.dtype]}"'
                      + (f' Name="{name}"' if name else "")
                      + f'{ncomp} format="appended" offset="{offset}"/>')
        blobs.append(blob)
        offset += len(blob)
    point_data = "".join(tags[k] for k in mesh.point_data)
    head = ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" '
            'byte_order="LittleEndian" header_type="UInt64" '
            'compressor="vtkZLibDataCompressor">\n<UnstructuredGrid>\n'
            f'<Piece NumberOfPoints="{len(mesh.points)}" NumberOfCells="{len(quads)}">\n'
            f'<PointData>{point_data}</PointData>\n<Points>{tags[""]}</Points>\n'
            f'<Cells>{tags["connectivity"]}{tags["offsets"]}{tags["types"]}</Cells>\n'
            '</Piece>\n</UnstructuredGrid>\n<AppendedData encoding="raw">\n_')
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as fh:
        fh.write(head.encode())
        for blob in blobs:
            fh.write(blob)
        fh.write(b"\n</AppendedData>\n</VTKFile>\n")
    os.replace(tmp, path)


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


#: Which steps :func:`write_vtk` writes: every step, or the stage ends (see there).
VTK_STEPS = ("all", "ends")


def stage_ends(history) -> tuple:
    """The last step of each stage that has steps."""
    return tuple(history.stage(k)[-1] for k in (1, 2, 3) if history.stage(k))


def loaded_step(history):
    """The step whose bodies ``steps="ends"`` writes: the end of stage 2 (Q = Q0, the largest
    tangential load), or the end of stage 1 without a tangential load."""
    return history.stage(2)[-1] if history.stage(2) else history.stage(1)[-1]


def write_vtk(history, directory, steps: str = "all") -> Path:
    """Write the .vtu files and the .pvd time series: ``steps="all"``: bodies and interface
    at every step; ``steps="ends"``: the interface at the last step of each stage and the
    bodies at :func:`loaded_step` only (a bodies file is 100-200 times an interface file:
    3.6 MB against 28 kB for the 193e3-DOF applied-moment case)."""
    if steps not in VTK_STEPS:
        raise InputError(f"steps = {steps!r} is not allowed: need one of {', '.join(VTK_STEPS)}")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    chosen = history.steps if steps == "all" else stage_ends(history)
    bodies_at = {s.index for s in chosen} if steps == "all" else {loaded_step(history).index}
    entries = []
    for step in chosen:
        files = [(1, f"interface_{step.index:04d}.vtu")]
        atomic_write_mesh(interface_mesh(step), directory / files[0][1], step_loads(step))
        if step.index in bodies_at:
            files.insert(0, (0, f"bodies_{step.index:04d}.vtu"))
            write_bodies_vtu(bodies_mesh(history, step), directory / files[0][1])
        entries += [
            f'    <DataSet timestep="{step.t:.12g}" part="{k}" file={quoteattr(n)}/>'
            for k, n in files
        ]
    pvd = (
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries)
        + "\n  </Collection>\n</VTKFile>\n"
    )
    path = directory / "history.pvd"
    atomic_write_text(pvd, path)
    return path
