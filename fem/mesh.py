"""Two-body quad meshes: graded tensor-product generator and meshio reader.

Geometry (see docs/conventions.md): body 1 (upper) occupies ``[xc-W, xc+W] x [0, H]``, body 2
(lower) ``[xc-W, xc+W] x [-H, 0]``. Both are flat rectangles: the profile enters only
through the initial gap ``h0(x)`` of the contact law (small-slope / half-plane
assumption, the same one the analytic solution makes). The two interface node rows
have the same x (node-to-node contact). Boundaries: ``contact_upper`` (body 1,
y = 0), ``contact_lower`` (body 2, y = 0), ``top`` (body 1, y = H, tied to the
rigid loading plate) and ``bottom`` (body 2, y = -H, clamped).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from skfem import MeshQuad

from .errors import InputError
from .settings import MeshFile, MeshSpec, validate_mesh_spec

BOUNDARY_NAMES = ("contact_upper", "contact_lower", "top", "bottom")
#: Relative tolerance (to the smallest interface element) for matching node x.
MATCH_TOL = 1e-6


@dataclass(frozen=True)
class TwoBodyMesh:
    """Meshes of body 1 (upper) and body 2 (lower) with their named boundary nodes.

    bodies: (mesh1, mesh2) scikit-fem MeshQuad objects.
    nodes: boundary name -> vertex indices in the body that owns it
        (contact_upper, top: body 1; contact_lower, bottom: body 2).
    h_min: smallest element length along the interface.
    source: 'generated' or the file path.
    """

    bodies: tuple
    nodes: dict
    h_min: float
    source: str

    @property
    def n_elements(self) -> int:
        """Total number of quads of both bodies."""
        return int(sum(m.t.shape[1] for m in self.bodies))


def graded_sizes(first: float, length: float, growth: float) -> np.ndarray:
    """Element sizes starting at ``first`` and growing by ``growth``, summing to ``length``."""
    if length <= 0:
        return np.zeros(0)
    n = max(1, int(np.ceil(np.log1p(length * (growth - 1) / first) / np.log(growth))))
    sizes = first * growth ** np.arange(n)
    return sizes * (length / sizes.sum())


def window_axis(
    window: tuple[float, float], kinks, h: float, spec: MeshSpec, W: float
) -> np.ndarray:
    """Node x: uniform size h in the window (+margin), nodes at kinks, graded out to +-W."""
    width = window[1] - window[0]
    xl, xr = window[0] - spec.margin * width, window[1] + spec.margin * width
    xc = 0.5 * (window[0] + window[1])
    inner = [k for k in sorted(set(float(k) for k in kinks)) if xl < k < xr]
    breaks = [xl, *inner, xr]
    fine = [
        np.linspace(a, b, max(1, int(np.ceil((b - a) / h - 1e-9))) + 1)[:-1]
        for a, b in zip(breaks[:-1], breaks[1:], strict=True)
    ]
    core = np.r_[np.concatenate(fine), xr]
    left = xl - np.cumsum(graded_sizes(h * spec.growth, xl - (xc - W), spec.growth))
    right = xr + np.cumsum(graded_sizes(h * spec.growth, xc + W - xr, spec.growth))
    x = np.r_[left[::-1], core, right]
    return snap_kinks(x, [k for k in kinks if not xl < k < xr])


def snap_kinks(x: np.ndarray, kinks) -> np.ndarray:
    """Move the nearest interior node onto each kink outside the fine region."""
    x = x.copy()
    for k in kinks:
        if x[0] < k < x[-1]:
            i = int(np.clip(np.argmin(np.abs(x - k)), 1, x.size - 2))
            x[i] = k
    if np.any(np.diff(x) <= 0):
        raise InputError(f"kinks={list(kinks)} could not be placed on mesh nodes: refine the mesh")
    return x


def build_mesh(spec: MeshSpec, window: tuple[float, float], kinks=()) -> TwoBodyMesh:
    """Generate the graded tensor-product two-body mesh for a contact window."""
    validate_mesh_spec(spec)
    if not (np.isfinite(window[0]) and np.isfinite(window[1]) and window[1] > window[0]):
        raise InputError(f"window={tuple(window)!r} is not allowed: need finite xmin < xmax")
    width = window[1] - window[0]
    h = width / (spec.n_window * 2.0**spec.level)
    W = spec.W if spec.W is not None else spec.size_factor * 0.5 * width
    H = spec.H if spec.H is not None else W
    if W <= (0.5 + spec.margin) * width * 1.05:
        raise InputError(
            f"W={W:g} is not allowed: need W > {(0.5 + spec.margin) * width * 1.05:g} "
            "(the window plus its margin must fit in the bodies)"
        )
    x = window_axis(window, kinks, h, spec, W)
    depth = np.cumsum(graded_sizes(h, H, spec.growth))
    lower = MeshQuad.init_tensor(x, np.r_[-depth[::-1], 0.0])
    upper = MeshQuad.init_tensor(x, np.r_[0.0, depth])
    return from_bodies(upper, lower, "generated")


def from_bodies(upper: MeshQuad, lower: MeshQuad, source: str) -> TwoBodyMesh:
    """Find the named boundaries of two rectangles-on-y=0 meshes by coordinates."""
    y1, y2 = upper.p[1], lower.p[1]
    nodes = {
        "contact_upper": np.flatnonzero(np.isclose(y1, 0.0, atol=1e-12)),
        "top": np.flatnonzero(np.isclose(y1, y1.max())),
        "contact_lower": np.flatnonzero(np.isclose(y2, 0.0, atol=1e-12)),
        "bottom": np.flatnonzero(np.isclose(y2, y2.min())),
    }
    return finish(upper, lower, nodes, source)


def finish(upper: MeshQuad, lower: MeshQuad, nodes: dict, source: str) -> TwoBodyMesh:
    """Check the interface rows match node-to-node and package the mesh."""
    xu = np.sort(upper.p[0, nodes["contact_upper"]])
    xl = np.sort(lower.p[0, nodes["contact_lower"]])
    if xu.size < 2 or xl.size < 2:
        raise InputError(f"interface rows have {xu.size} and {xl.size} nodes: need >= 2 each")
    h_min = float(np.min(np.diff(xl)))
    if xu.size != xl.size or np.max(np.abs(xu - xl)) > MATCH_TOL * h_min:
        raise InputError(
            f"non-matching interface nodes in {source}: contact_upper has {xu.size} nodes, "
            f"contact_lower {xl.size}; node-to-node contact needs the same x on both rows "
            "(node-to-segment contact is not supported)"
        )
    for name, mesh in (("contact_upper", upper), ("contact_lower", lower)):
        if np.max(np.abs(mesh.p[1, nodes[name]])) > MATCH_TOL * h_min:
            raise InputError(
                f"boundary {name} of {source} is not on y = 0: the interface must be "
                "the flat line y = 0 (the profile enters through h0)"
            )
    return TwoBodyMesh(bodies=(upper, lower), nodes=nodes, h_min=h_min, source=source)


def read_mesh(spec: MeshFile) -> TwoBodyMesh:
    """Read a meshio file with two disconnected quad bodies and named boundaries."""
    import meshio

    path = Path(spec.path)
    if not path.is_file():
        raise InputError(f"mesh file {str(path)!r} does not exist")
    m = meshio.read(path)
    quads = np.concatenate([c.data for c in m.cells if c.type == "quad"] or [np.zeros((0, 4), int)])
    if quads.shape[0] == 0:
        raise InputError(f"mesh file {str(path)!r} has no 'quad' cells: need a quad mesh")
    named = named_line_nodes(m, path)
    pts = m.points[:, :2]
    comp = body_components(quads, pts.shape[0])
    top_comp = np.unique(comp[named["top"]])
    if np.unique(comp[np.unique(quads)]).size != 2 or top_comp.size != 1:
        raise InputError(
            f"mesh file {str(path)!r} must hold exactly two disconnected bodies "
            "with 'top' on the upper one"
        )
    meshes, nodes = {}, {}
    for body, names in (
        (top_comp[0], ("contact_upper", "top")),
        (1 - top_comp[0], ("contact_lower", "bottom")),
    ):
        mesh, old2new = sub_mesh(pts, quads[comp[quads[:, 0]] == body])
        meshes[names[0]] = mesh
        for name in names:
            idx = old2new[named[name]]
            if np.any(idx < 0):
                raise InputError(f"boundary {name} of {str(path)!r} lies on the wrong body")
            nodes[name] = idx
    return finish(meshes["contact_upper"], meshes["contact_lower"], nodes, str(path))


def named_line_nodes(m, path: Path) -> dict:
    """Map each required boundary name to the node indices of its line cells."""
    found = {}
    for name, blocks in (m.cell_sets or {}).items():
        ids = [
            m.cells[b].data[np.asarray(s, int)].ravel()
            for b, s in enumerate(blocks)
            if s is not None and len(s) and m.cells[b].type == "line"
        ]
        if ids:
            found[name] = np.unique(np.concatenate(ids))
    phys = m.cell_data.get("gmsh:physical")
    for name, (tag, dim) in (m.field_data or {}).items():
        if phys is None or name in found or dim != 1:
            continue
        ids = [c.data[phys[b] == tag].ravel() for b, c in enumerate(m.cells) if c.type == "line"]
        found[name] = np.unique(np.concatenate(ids)) if ids else np.zeros(0, int)
    missing = [n for n in BOUNDARY_NAMES if n not in found or found[n].size == 0]
    if missing:
        raise InputError(
            f"mesh file {str(path)!r} lacks boundary name(s) {missing}: need line "
            f"cells named {list(BOUNDARY_NAMES)} (gmsh physical groups)"
        )
    return found


def body_components(quads: np.ndarray, n_points: int) -> np.ndarray:
    """Connected-component label of every point (quads sharing nodes are connected)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows = np.repeat(quads[:, 0], 3)
    cols = quads[:, 1:].ravel()
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n_points, n_points))
    return connected_components(graph, directed=False)[1]


def sub_mesh(pts: np.ndarray, quads: np.ndarray) -> tuple[MeshQuad, np.ndarray]:
    """Build a MeshQuad from a subset of quads; return it and the old->new node map."""
    used = np.unique(quads)
    old2new = -np.ones(pts.shape[0], dtype=np.int64)
    old2new[used] = np.arange(used.size)
    t = old2new[quads]
    area = signed_area(pts[used].T, t.T)
    t[area < 0] = t[area < 0][:, ::-1]
    return MeshQuad(pts[used].T.copy(), t.T.copy()), old2new


def signed_area(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Shoelace signed area of each quad (positive = counter-clockwise)."""
    x, y = p[0, t], p[1, t]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=0) - np.roll(x, -1, axis=0) * y, axis=0)


def write_msh(mesh: TwoBodyMesh, path: Path) -> Path:
    """Write a two-body mesh as gmsh 2.2 .msh with physical names (atomic write)."""
    import meshio

    upper, lower = mesh.bodies
    off = upper.p.shape[1]
    pts = np.c_[np.hstack([upper.p, lower.p]).T, np.zeros(off + lower.p.shape[1])]
    quads = np.vstack([upper.t.T, lower.t.T + off])
    cells, phys, tags = [("quad", quads)], [np.full(quads.shape[0], 1)], {}
    for k, (name, body) in enumerate(
        (("contact_upper", 0), ("contact_lower", 1), ("top", 0), ("bottom", 1)), start=2
    ):
        m = mesh.bodies[body]
        segs = boundary_segments(m, mesh.nodes[name]) + (off if body else 0)
        cells.append(("line", segs))
        phys.append(np.full(segs.shape[0], k))
        tags[name] = np.array([k, 1])
    tags["bodies"] = np.array([1, 2])
    out = meshio.Mesh(
        pts, cells, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys}, field_data=tags
    )
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp.msh")
    meshio.write(tmp, out, file_format="gmsh22", binary=False)
    os.replace(tmp, path)
    return path


def boundary_segments(m: MeshQuad, nodes: np.ndarray) -> np.ndarray:
    """Boundary facets (as node pairs) whose both ends are in ``nodes``."""
    f = m.facets[:, m.boundary_facets()]
    inside = np.isin(f, nodes).all(axis=0)
    return f[:, inside].T.copy()
